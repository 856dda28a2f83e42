//! Hard cases of rays leaving surfaces: self-intersection (4), two parallel mirrors (12), a
//! light on or inside geometry (14).

use crate::common::renderer;
use cuberay::job::RenderOptions;
use cuberay::reference;
use glam::DVec3;

use super::{hidden, load_case, on_plane_z, run, run_file, Case};

// ---------------------------------------------------------------------------------------------
// 4. Self-intersection

/// Reflection, refraction and shadow rays leave a mirror floor and mirror, glass and diffuse
/// spheres: `run` asserts 0 self-hits on both backends; here, the GPU blocks the same
/// shadow rays as the CPU (acne would block more) and the image agrees. The kernels do not
/// test the primitive a ray leaves where it cannot meet it again (a triangle, a convex
/// sphere left outward), so what is measured is the neighbours (the floor's other triangle
/// across the diagonal) and rays inside the glass sphere, which do test it.
#[test]
fn self_intersection() {
    let c = run_file("self_intersection.nff", 0.01, 2);
    let (g, k) = (&c.gpu.stats.rays, &c.cpu.stats.rays);
    assert!(g.reflect > 1000 && g.refract > 100 && g.shadow > 1000, "every spawned kind is exercised");
    let diff = g.shadow_blocked.abs_diff(k.shadow_blocked);
    assert!(diff * 1000 <= k.shadow, "blocked shadow rays GPU {} CPU {}", g.shadow_blocked, k.shadow_blocked);
    eprintln!(
        "hard-case self_intersection: {} spawned rays, 0 self-hits; blocked shadow rays GPU {} CPU {}",
        g.reflect + g.refract + g.shadow,
        g.shadow_blocked,
        k.shadow_blocked
    );
}

// ---------------------------------------------------------------------------------------------
// 12. Two parallel mirrors

/// Between two mirrors lit only by the ambient term, every pixel's radiance is
/// Σ_{k<D} (Π_{j<k} ρ_j)·a·kd_k·C_k for maximum depth D; the GPU matches it to 2e-6 and
/// the CPU to its f32 storage, reflection rays number (D − 1) per pixel, every shadow ray is blocked
/// by the lower mirror, and no ray is stuck (self-hits 0, asserted by `run`).
#[test]
fn two_parallel_mirrors() {
    let scene = load_case("parallel_mirrors.nff").scene;
    let ambient = scene.ambient;
    let (lower, upper) = (&scene.materials[0], &scene.materials[1]);
    let mut worst = (0.0f64, 0.0f64);
    for depth in [1u32, 2, 5, 15] {
        let opts = RenderOptions { max_depth: depth, ..RenderOptions::new(32, 32) };
        let c = run(&format!("parallel_mirrors depth {depth}"), scene.clone(), opts, 0.01, 0);
        let mut want = DVec3::ZERO;
        let mut weight = DVec3::ONE;
        for k in 0..depth {
            let m = if k % 2 == 0 { lower } else { upper };
            want += weight * ambient * m.kd * m.color;
            weight *= m.mirror;
        }
        // The CPU's f64 radiance is stored as f32: a relative 2⁻²⁴ at most.
        for (backend, img, tol) in [("GPU", &c.gpu.image, 2e-6), ("CPU", &c.cpu.image, 1.5e-7)] {
            for (x, y) in c.pixels() {
                let p = img.get(x, y);
                let got = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                let err = (got - want).abs().max_element();
                assert!(err <= tol, "{backend} depth {depth} ({x}, {y}): {got} vs {want}");
                if backend == "GPU" {
                    worst.0 = worst.0.max(err);
                } else {
                    worst.1 = worst.1.max(err);
                }
            }
        }
        let (g, pixels) = (&c.gpu.stats.rays, 32 * 32);
        assert_eq!(g.reflect, pixels * (depth as u64 - 1), "depth {depth}: reflection rays");
        assert_eq!(g.shadow, pixels * (depth as u64 / 2), "depth {depth}: shadow rays (upper mirror hits)");
        assert_eq!(g.shadow_blocked, g.shadow, "depth {depth}: the lower mirror blocks every shadow ray");
        // The eye ray travels half the gap over the cosine of its slant.
        for (x, y) in c.pixels() {
            let (_, d) = c.ray(x, y);
            let t = 0.5 / d.normalize().z.abs();
            let got = c.gpu_depth.get(x, y)[0] as f64;
            assert!((got - t).abs() < 1e-5 * t, "depth AOV ({x}, {y}): {got} vs {t}");
        }
    }
    eprintln!(
        "hard-case parallel_mirrors: radiance = closed form at depths 1, 2, 5, 15: worst error GPU {:.2e}, CPU {:.2e}",
        worst.0, worst.1
    );
}

// ---------------------------------------------------------------------------------------------
// 14. A light on or inside geometry

/// Light 0 lies on a sphere's surface, light 1 inside a closed sphere. The floor is lit by
/// light 0 exactly where x > 1 (elsewhere the sphere is in the way); light 1 lights
/// nothing: removing it leaves every pixel bit-identical on both backends.
#[test]
fn a_light_on_and_inside_geometry() {
    let c = run_file("light_on_geometry.nff", 0.01, 2);
    let (mut lit, mut dark) = (0, 0);
    let ambient_floor = 0.7 * 0.9 * c.scene.ambient.x;
    for (x, y) in c.pixels() {
        if Case::id(&c.cpu_id, x, y) != Some(0) && Case::id(&c.cpu_id, x, y) != Some(1) {
            continue;
        }
        let (o, d) = c.ray(x, y);
        let p = on_plane_z(o, d, -0.5).unwrap();
        // The floor's two triangles are ids 0 and 1; the sphere of light 0 is 2.
        for (backend, img) in [("GPU", &c.gpu.image), ("CPU", &c.cpu.image)] {
            let v = img.get(x, y)[0] as f64;
            if p.x > 1.0 + 0.05 {
                assert!(v > ambient_floor + 0.01, "{backend}: floor at x = {:.3} not lit: {v}", p.x);
            } else if p.x < 1.0 - 0.05 {
                assert!((v - ambient_floor).abs() < 1e-5, "{backend}: floor at x = {:.3} lit: {v}", p.x);
            }
        }
        if p.x > 1.05 {
            lit += 1;
        } else if p.x < 0.95 {
            dark += 1;
        }
    }
    let mut without = c.scene.clone();
    without.lights.truncate(1);
    let g = renderer().render(&without, &c.opts, &hidden()).unwrap();
    let k = reference::render(&without, &c.opts, &hidden()).unwrap();
    assert_eq!(
        crate::common::first_difference(&g.image, &c.gpu.image),
        None,
        "GPU: light 1 inside its sphere lights something"
    );
    assert_eq!(
        crate::common::first_difference(&k.image, &c.cpu.image),
        None,
        "CPU: light 1 inside its sphere lights something"
    );
    eprintln!("hard-case light_on_geometry: floor lit at {lit} pixels (x > 1), dark at {dark}; the enclosed light adds nothing");
    assert!(lit > 100 && dark > 100);
}
