//! The accelerators on the GPU: the tables and the BVH against GPU brute force, pixel for
//! pixel with every ray count, on scenes written here, the showcase and the SPD databases;
//! the tables against the CPU; BVH walks longer than a kernel step; brute force within
//! lavapipe's loop limit.

use crate::common::renderer;
use cuberay::coherence::walk::WALK_CHUNK;
use cuberay::job::{Accel, RenderOptions};
use cuberay::load;
use cuberay::output::Aov;
use cuberay::scene::Scene;

use super::{agree, hidden, showcase, spd};

/// A scene from NFF text (written to a temporary file and loaded as a user's would be).
fn nff(src: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("scene.nff");
    std::fs::write(&p, src).unwrap();
    load::load(&p, &Default::default()).unwrap_or_else(|e| panic!("{e}")).scene
}

const VIEW: &str =
    "b 0.2 0.2 0.3\nv\nfrom 7 -9 5\nat 0 0 0.5\nup 0 0 1\nangle 45\nhither 0.01\nresolution 64 48\n\
                    l 5 -3 8\nl -6 -4 7\n";

/// Spheres of many sizes, some overlapping, a mirror finish, on a large sphere.
fn spheres_scene() -> Scene {
    let mut s = format!("{VIEW}f 0.8 0.5 0.3 0.6 0.3 20 0 1\ns 0 0 -100 99.5\n");
    for i in -3i32..=3 {
        for j in -3..=3 {
            let r = 0.25 + 0.08 * ((i * 7 + j * 3).rem_euclid(5)) as f64;
            s += &format!(
                "s {} {} {} {r}\n",
                i as f64 * 0.9,
                j as f64 * 0.9,
                0.2 * ((i + j).rem_euclid(3)) as f64
            );
        }
    }
    nff(&s)
}

/// A folded triangle mesh (shared edges, both sides seen) and loose triangles.
fn triangles_scene() -> Scene {
    let mut s = format!("{VIEW}f 0.4 0.8 0.4 0.7 0.2 10 0 1\n");
    let z = |x: f64, y: f64| 0.6 * (x * 1.3).sin() * (y * 0.9).cos();
    let n = 10;
    let at = |i: i32, j: i32| {
        let (x, y) = (-3.0 + 6.0 * i as f64 / n as f64, -3.0 + 6.0 * j as f64 / n as f64);
        format!("{x} {y} {}", z(x, y))
    };
    for i in 0..n {
        for j in 0..n {
            s += &format!("p 3\n{}\n{}\n{}\n", at(i, j), at(i + 1, j), at(i + 1, j + 1));
            s += &format!("p 3\n{}\n{}\n{}\n", at(i, j), at(i + 1, j + 1), at(i, j + 1));
        }
    }
    s += "p 3\n-1 -1 1.5\n1 -1 1.7\n0 1 2.2\np 4\n-2 2 0.5\n2 2 0.5\n2 2 2.5\n-2 2 2.5\n";
    nff(&s)
}

/// Cylinders and cones, upright, tilted, crossing each other.
fn cylinders_scene() -> Scene {
    let mut s = format!("{VIEW}f 0.9 0.9 0.5 0.7 0.2 10 0 1\nc 0 0 -0.5 4 0 0 -0.4 4\n");
    for i in -2i32..=2 {
        for j in -2..=2 {
            let (x, y) = (i as f64 * 1.2, j as f64 * 1.2);
            let top = 0.3 + 0.15 * ((i * 3 + j).rem_euclid(4)) as f64;
            s += &format!("c {x} {y} 0 0.3 {} {} {} {}\n", x + 0.3 * j as f64, y, 1.0 + top, top * 0.4);
        }
    }
    s += "c -3 0 0.8 0.2 3 0 0.8 0.2\nc 0 -3 1.1 0.15 0 3 0.6 0.15\n";
    nff(&s)
}

/// Renders `scene` with the tables, with the BVH and by brute force on the GPU. The id and
/// depth AOVs (eye rays) must be identical, and so must the full render, pixel for pixel,
/// with every ray count: an accelerator changes which primitives are tested, never the
/// answer, for rays of every kind (all trace the same shadow ray, from a positional light
/// towards the point). Only the test counts differ, and must be lower than brute force's.
fn accels_match_brute_force(name: &str, scene: &Scene, w: u32, h: u32) {
    let r = renderer();
    let opts = |accel| RenderOptions { accel, ..RenderOptions::new(w, h) };
    let accels = [(Accel::Cube, "cube"), (Accel::Bvh, "bvh")];
    for aov in [Aov::Id, Aov::Depth] {
        let render = |accel| {
            r.render_aov(scene, &opts(accel), aov, &hidden()).unwrap_or_else(|e| panic!("{name}: {e}"))
        };
        let brute = render(Accel::Brute);
        assert_eq!(brute.stats.settings.accel, "brute");
        for (accel, label) in accels {
            let a = render(accel);
            assert_eq!(a.stats.settings.accel, label);
            assert_same_pixels(&format!("{name}-{aov:?}-{label}"), label, &a.image, &brute.image);
            assert!(a.stats.rays.eye_hit > 0, "{name}: nothing hit");
        }
    }
    let render = |accel| r.render(scene, &opts(accel), &hidden()).unwrap_or_else(|e| panic!("{name}: {e}"));
    let brute = render(Accel::Brute);
    let rb = brute.stats.rays;
    for (accel, label) in accels {
        let a = render(accel);
        let ra = a.stats.rays;
        assert_eq!(
            (ra.eye, ra.eye_hit, ra.reflect, ra.refract, ra.shadow, ra.shadow_blocked),
            (rb.eye, rb.eye_hit, rb.reflect, rb.refract, rb.shadow, rb.shadow_blocked),
            "{name}: ray counts (eye, hits, reflect, refract, shadow, blocked), {label} left, brute force right"
        );
        assert_same_pixels(&format!("{name}-{label}"), label, &a.image, &brute.image);
        let (ta, tb) = (a.stats.tests_per_ray.all, brute.stats.tests_per_ray.all);
        eprintln!(
            "{name}: {label} = brute force, {} blocked shadow rays; tests per ray {ta:.2} vs {tb:.2}, \
             bound tests {:.2}",
            ra.shadow_blocked, a.stats.bound_tests_per_ray.all
        );
        if scene.primitives.len() > 16 {
            assert!(ta < tb, "{name}: {label} tests {ta} per ray, brute force {tb}");
        }
    }
}

/// Fails, saving both images, at the first pixel where accelerator `label`'s image differs
/// from brute force's in any bit.
fn assert_same_pixels(name: &str, label: &str, a: &cuberay::output::Image, brute: &cuberay::output::Image) {
    if let Some((x, y, c, b)) = crate::common::first_difference(a, brute) {
        let files = crate::common::save_failure(name, &[(label, a), ("brute", brute)], None);
        panic!("{name}: pixel ({x}, {y}) {label} {c:?} brute force {b:?}; images: {files}");
    }
}

cases!(accels_match_brute_force: super::accels_match_brute_force {
    spheres => ("spheres", &super::spheres_scene(), 64, 48),
    triangles => ("triangles", &super::triangles_scene(), 64, 48),
    cylinders => ("cylinders", &super::cylinders_scene(), 64, 48),
    showcase => ("showcase", &super::showcase(), 64, 48),
});

/// An SPD size-1 database traced with the tables, the BVH and by brute force on the GPU.
fn spd_size_1_accels_match_brute_force(db: &str) {
    let name = format!("{db}_s1");
    accels_match_brute_force(&name, &spd(&name), 48, 48);
}
spd_cases!(spd_size_1_accels_match_brute_force: super::spd_size_1_accels_match_brute_force => [balls, gears, jacks, lattice, mount, rings, shells, sombrero, teapot, tetra, tree]);

/// The tables traced on the GPU agree with the CPU reference on the small test scenes
/// (every ray kind; shadow rays traced from the lights).
fn tables_agree_with_the_cpu(name: &str, scene: &Scene) {
    let opts = RenderOptions { accel: Accel::Cube, ..RenderOptions::new(64, 48) };
    let (g, _) = agree(name, scene, &opts, 0.01);
    assert_eq!(g.stats.settings.accel, "cube", "{name}");
    assert!(g.stats.rays.reflect > 0 && g.stats.rays.shadow_blocked > 0, "{name}");
}

cases!(tables_agree_with_the_cpu: super::tables_agree_with_the_cpu {
    spheres => ("spheres", &super::spheres_scene()),
    triangles => ("triangles", &super::triangles_scene()),
    cylinders => ("cylinders", &super::cylinders_scene()),
});

/// A large mirror floor under small objects: its reflection rays leave the floor in every
/// direction (the tables send them to the BVH), and the image agrees with the CPU reference.
#[test]
fn a_mirror_floor_agrees_with_the_cpu() {
    let mut s = format!("{VIEW}f 0.7 0.7 0.7 0.4 0.6 30 0 1\np 4\n-8 -8 0\n8 -8 0\n8 8 0\n-8 8 0\n");
    s += "f 0.9 0.3 0.2 0.8 0.1 10 0 1\n";
    for i in -2i32..=2 {
        for j in -2i32..=2 {
            let (x, y) = (i as f64 * 1.2, j as f64 * 1.2);
            if (i + j).rem_euclid(2) == 0 {
                s += &format!("s {x} {y} 0.3 0.3\n");
            } else {
                s += &format!("p 3\n{x} {y} 0\n{} {y} 0.5\n{x} {} 0.8\n", x + 0.5, y + 0.5);
            }
        }
    }
    let scene = nff(&s);
    let opts = RenderOptions { accel: Accel::Cube, ..RenderOptions::new(64, 48) };
    let (g, _) = agree("mirror floor", &scene, &opts, 0.01);
    assert_eq!(g.stats.settings.accel, "cube");
    assert!(g.stats.rays.reflect > 1000);
}

/// Walks longer than a kernel step resume where they stopped: 9000 triangles on the planes
/// x + y = c (c from 0.2 to 0.8) all have boxes around the camera's axis, so an eye ray with
/// x + y < 0.2, which misses them all, visits every node and leaf of the BVH, more than a
/// step's WALK_CHUNK iterations; and the shadow rays of eight lights on the axis, back
/// through the stack, are longer than their inline budget, so they become jobs walked over
/// several steps. AOVs and ray counts must equal brute force's, and so must the image, up
/// to the order in which a pixel's light terms are added.
#[test]
fn bvh_walks_longer_than_a_step_resume() {
    let mut s = String::from(
        "b 0.1 0.1 0.1\nv\nfrom 0 0 -5\nat 0 0 10\nup 0 1 0\nangle 4\nhither 0.01\nresolution 16 16\n",
    );
    for i in 0..8 {
        s += &format!("l {} -0.3 -8\n", 0.02 * i as f64 - 0.08);
    }
    s += "f 0.8 0.6 0.4 0.8 0 1 0 1\ns 0 0 15 3\nf 0.3 0.7 0.9 0.8 0 1 0 1\n";
    for k in 0..9000 {
        let c = 0.2 + 0.6 * (k % 97) as f64 / 97.0;
        let z = (k % 600) as f64 * 0.0133;
        s += &format!("p 3\n{} -1 {z}\n-1 {} {z}\n{} -1 {}\n", c + 1.0, c + 1.0, c + 1.0, z + 2.0);
    }
    let scene = nff(&s);
    let bvh = cuberay::layout::bvh::pack_bvh(&scene);
    // Each iteration tests a queued primitive and perhaps a node: a ray that misses
    // everything still tests all the primitives, one an iteration, more than a step allows.
    assert!(scene.primitives.len() > WALK_CHUNK as usize + 500);
    let r = renderer();
    let opts = |accel| RenderOptions { accel, ..RenderOptions::new(16, 16) };
    let brute = r.render(&scene, &opts(Accel::Brute), &hidden()).unwrap();
    let b = r.render(&scene, &opts(Accel::Bvh), &hidden()).unwrap();
    // Brute force makes every shadow ray of this scene a job (it has more primitives than
    // an inline walk may test), the BVH traces the short ones at once: the same light terms
    // are added to a pixel in another order, which may change its last bit, no more.
    for (i, (p, q)) in b.image.pixels.iter().zip(&brute.image.pixels).enumerate() {
        for c in 0..4 {
            assert!(
                (p[c] - q[c]).abs() <= 4.0 * f32::EPSILON * q[c].abs(),
                "pixel {i}: bvh {p:?} brute force {q:?}"
            );
        }
    }
    assert_eq!(b.stats.rays, brute.stats.rays);
    assert!(b.stats.rays.shadow_blocked > 0 && b.stats.rays.shadow > b.stats.rays.shadow_blocked);
    let nodes = b.stats.bound_tests_per_ray;
    eprintln!(
        "long bvh walks: {} nodes, node tests per ray {:.0} eye, {:.0} shadow; primitive tests per ray {:.0} eye, {:.0} shadow",
        bvh.nodes.len(), nodes.eye, nodes.shadow, b.stats.tests_per_ray.eye, b.stats.tests_per_ray.shadow
    );
    // The misses of eye and shadow rays walk far past one step.
    let tests = b.stats.tests_per_ray;
    assert!(tests.eye > WALK_CHUNK as f64 / 2.0 && tests.shadow > WALK_CHUNK as f64 / 4.0, "{tests:?}");
    // The waves are planned for typical BVH walks (WalkBounds::planned): these outlast them,
    // and a tile runs again with more passes, its counts restored (the ray counts above).
    assert!(b.stats.time.tiles_run_again.unwrap() > 0, "{:?}", b.stats.time);
    for aov in [Aov::Id, Aov::Depth] {
        let a = r.render_aov(&scene, &opts(Accel::Bvh), aov, &hidden()).unwrap();
        let b = r.render_aov(&scene, &opts(Accel::Brute), aov, &hidden()).unwrap();
        assert_same_pixels(&format!("long bvh walks {aov:?}"), "bvh", &a.image, &b.image);
    }
}

/// lavapipe stops an invocation's loops after 65535 iterations in all. Brute force tests
/// WALK_CHUNK primitives per pass, so gears_s4 (36,610 primitives, 5 lights) renders, and
/// right, at depth 5 and at depth 16 (the stepped kernel's ray stack could fill up there,
/// and it refused such a render; the wavefront's queues cannot).
#[test]
fn brute_force_passes_within_lavapipes_loop_limit() {
    let r = renderer();
    if !r.ctx.info.name.to_lowercase().contains("llvmpipe") {
        eprintln!("adapter {} has no loop limit: nothing to check", r.ctx.info.name);
        return;
    }
    let scene = spd("gears_s4");
    let opts = RenderOptions { accel: Accel::Brute, ..RenderOptions::new(8, 8) };
    let (g, _) = agree("gears_s4 brute", &scene, &opts, 0.01);
    assert_eq!(g.stats.settings.accel, "brute");
    assert!(g.stats.tests_per_ray.eye > 36_000.0, "every primitive per eye ray: {:?}", g.stats.tests_per_ray);
    let deep = RenderOptions { accel: Accel::Brute, max_depth: 16, ..RenderOptions::new(4, 4) };
    let (g, _) = agree("gears_s4 brute depth 16", &scene, &deep, 0.01);
    assert!(g.stats.rays.reflect + g.stats.rays.refract > 16, "{:?}", g.stats.rays);
}
