//! The hard cases of `../shared/docs/coherence-notes.md` §5, one test each, on the scenes in
//! `scenes/hard/` (each a file a user can render: the README lists the commands).
//!
//! Every case goes through [`run`], which renders the scene on the GPU with the candidate
//! tables, the BVH and by brute force and on the CPU reference with brute force, its BVH and
//! the tables' order, and asserts what must hold on any scene:
//!
//! - the GPU's tables and BVH each give the same image, id and depth AOVs and ray counts as
//!   GPU brute force, byte for byte (hard cases are where a table or box test that is not
//!   quite conservative shows), and the CPU's three accelerators give one image;
//! - no pixel is NaN or infinite, and `rays.self_hits` is 0 on both backends;
//! - the GPU agrees with the CPU: FLIP mean, eye-ray ids (apart from a per-case number of
//!   pixels, and from triangles of one flat surface meeting at an edge), eye hits, and
//!   spawned rays by kind within 1% (plus 2).
//!
//! Each case then asserts its own expected behaviour, in closed form where there is one.
//! Every test prints a `hard-case NAME:` line with its measured worst values.

use crate::common::{hard, renderer};
use cuberay::arith::geometry::{make_ray, Prim32};
use cuberay::arith::FAR;
use cuberay::compare::compare;
use cuberay::job::{Accel, Precision, RenderOptions, Rendered};
use cuberay::load::{self, Loaded};
use cuberay::output::{Aov, Image};
use cuberay::reference;
use cuberay::scene::{Primitive, Scene};
use glam::DVec3;
use indicatif::ProgressBar;

fn hidden() -> ProgressBar {
    ProgressBar::hidden()
}

fn load_case(file: &str) -> Loaded {
    load::load(&hard(file), &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// The renders of one case and what they measured.
struct Case {
    scene: Scene,
    opts: RenderOptions,
    /// GPU, candidate tables (equal to GPU brute force).
    gpu: Rendered,
    /// CPU reference, BVH (equal to its brute force and tables order).
    cpu: Rendered,
    /// Eye-ray object ids (−1: miss) and hit distances, GPU and CPU.
    gpu_id: Image,
    cpu_id: Image,
    gpu_depth: Image,
    /// Pixels whose eye ray hit another object on the GPU than on the CPU.
    id_disagree: usize,
}

impl Case {
    fn size(&self) -> (u32, u32) {
        (self.opts.width, self.opts.height)
    }

    /// The object id of pixel (x, y) in an id AOV, or None for a miss.
    fn id(img: &Image, x: u32, y: u32) -> Option<u32> {
        let v = img.get(x, y)[0];
        (v >= 0.0).then_some(v as u32)
    }

    /// The CPU's f64 eye ray through the centre of pixel (x, y).
    fn ray(&self, x: u32, y: u32) -> (DVec3, DVec3) {
        let (w, h) = self.size();
        self.scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, w, h)
    }

    fn pixels(&self) -> impl Iterator<Item = (u32, u32)> {
        let (w, h) = self.size();
        (0..h).flat_map(move |y| (0..w).map(move |x| (x, y)))
    }
}

/// Asserts two renders of one backend are identical: every pixel bit and every ray count.
fn assert_identical(name: &str, what: &str, a: &Rendered, b: &Rendered) {
    if let Some((x, y, p, q)) = crate::common::first_difference(&a.image, &b.image) {
        let files =
            crate::common::save_failure(&format!("{name}-{what}"), &[("a", &a.image), ("b", &b.image)], None);
        panic!("{name}: {what}: pixel ({x}, {y}) {p:?} vs {q:?}; images: {files}");
    }
    let (ra, rb) = (&a.stats.rays, &b.stats.rays);
    let counts = |r: &cuberay::stats::RayStats| {
        (r.eye, r.eye_hit, r.reflect, r.refract, r.shadow, r.shadow_blocked, r.self_hits)
    };
    assert_eq!(
        counts(ra),
        counts(rb),
        "{name}: {what}: rays (eye, hit, reflect, refract, shadow, blocked, self-hits)"
    );
}

/// Renders a case on both backends with every accelerator and asserts what holds on every
/// scene (see the module doc); `max_flip` bounds the GPU-vs-CPU FLIP mean and `max_ids` the
/// pixels whose eye ray hit another object on the GPU than on the CPU.
fn run(name: &str, scene: Scene, opts: RenderOptions, max_flip: f64, max_ids: usize) -> Case {
    let r = renderer();
    let with = |accel| RenderOptions { accel, ..opts.clone() };
    let gpu = |accel| r.render(&scene, &with(accel), &hidden()).unwrap_or_else(|e| panic!("{name}: {e}"));
    let gpu_aov = |accel, aov| {
        r.render_aov(&scene, &with(accel), aov, &hidden()).unwrap_or_else(|e| panic!("{name}: {e}"))
    };
    let cpu =
        |accel| reference::render(&scene, &with(accel), &hidden()).unwrap_or_else(|e| panic!("{name}: {e}"));

    let (g_cube, g_brute) = (gpu(Accel::Cube), gpu(Accel::Brute));
    assert_eq!(g_cube.stats.settings.accel, "cube");
    assert_identical(name, "GPU tables vs GPU brute force", &g_cube, &g_brute);
    let g_bvh = gpu(Accel::Bvh);
    assert_eq!(g_bvh.stats.settings.accel, "bvh");
    assert_identical(name, "GPU BVH vs GPU brute force", &g_bvh, &g_brute);
    let (gpu_id, gpu_depth) = (gpu_aov(Accel::Cube, Aov::Id), gpu_aov(Accel::Cube, Aov::Depth));
    let (brute_id, brute_depth) = (gpu_aov(Accel::Brute, Aov::Id), gpu_aov(Accel::Brute, Aov::Depth));
    assert_identical(name, "GPU id AOV, tables vs brute", &gpu_id, &brute_id);
    assert_identical(name, "GPU depth AOV, tables vs brute", &gpu_depth, &brute_depth);
    assert_identical(name, "GPU id AOV, BVH vs brute", &gpu_aov(Accel::Bvh, Aov::Id), &brute_id);
    assert_identical(name, "GPU depth AOV, BVH vs brute", &gpu_aov(Accel::Bvh, Aov::Depth), &brute_depth);

    let c_bvh = cpu(Accel::Bvh);
    assert_identical(name, "CPU BVH vs CPU brute force", &c_bvh, &cpu(Accel::Brute));
    assert_identical(name, "CPU BVH vs CPU tables order", &c_bvh, &cpu(Accel::Cube));
    let cpu_id = reference::render_aov(&scene, &with(Accel::Bvh), Aov::Id, &hidden()).unwrap();

    for (backend, img) in [("GPU", &g_cube.image), ("CPU", &c_bvh.image)] {
        assert!(img.is_finite(), "{name}: a non-finite {backend} pixel");
    }
    assert!(gpu_depth.image.is_finite(), "{name}: a non-finite GPU depth");
    let (gr, cr) = (&g_cube.stats.rays, &c_bvh.stats.rays);
    assert_eq!((gr.self_hits, cr.self_hits), (0, 0), "{name}: self-hits (GPU, CPU)");

    let (cmp, heat) = compare(&c_bvh.image, &g_cube.image, 2.0 / 255.0);
    let id_disagree = gpu_id
        .image
        .pixels
        .iter()
        .zip(&cpu_id.image.pixels)
        .filter(|(a, b)| a[0] != b[0] && !same_surface(&scene, a[0], b[0]))
        .count();
    let case = Case {
        scene,
        opts,
        gpu: g_cube,
        cpu: c_bvh,
        gpu_id: gpu_id.image,
        cpu_id: cpu_id.image,
        gpu_depth: gpu_depth.image,
        id_disagree,
    };
    let (gr, cr) = (&case.gpu.stats.rays, &case.cpu.stats.rays);
    eprintln!(
        "hard-case {name}: GPU vs CPU: FLIP mean {:.5}, max |diff| {:.4}, {:.2}% pixels over 2/255, eye ids \
         differ at {id_disagree} of {} pixels; rays GPU {} CPU {}, blocked shadow rays GPU {} CPU {}; \
         self-hits 0; GPU tables = GPU brute force, CPU BVH = brute = tables order",
        cmp.flip_mean,
        cmp.max_abs,
        100.0 * cmp.over_tolerance,
        case.gpu_id.pixels.len(),
        gr.total,
        cr.total,
        gr.shadow_blocked,
        cr.shadow_blocked
    );
    if cmp.flip_mean > max_flip {
        let files = crate::common::save_failure(
            name,
            &[("gpu", &case.gpu.image), ("cpu", &case.cpu.image)],
            Some((&heat, case.opts.width, case.opts.height)),
        );
        panic!("{name}: GPU vs CPU FLIP mean {} > {max_flip}; images: {files}", cmp.flip_mean);
    }
    assert!(
        case.id_disagree <= max_ids,
        "{name}: eye ids differ at {} pixels (at most {max_ids})",
        case.id_disagree
    );
    assert_eq!(gr.eye, cr.eye, "{name}: eye rays");
    assert!(
        gr.eye_hit.abs_diff(cr.eye_hit) as usize <= max_ids,
        "{name}: eye hits GPU {} CPU {}",
        gr.eye_hit,
        cr.eye_hit
    );
    for (kind, a, b) in [
        ("shadow", gr.shadow, cr.shadow),
        ("reflect", gr.reflect, cr.reflect),
        ("refract", gr.refract, cr.refract),
    ] {
        assert!(a.abs_diff(b) as f64 <= 2.0 + 0.01 * b as f64, "{name}: {kind} rays GPU {a} CPU {b}");
    }
    case
}

/// Whether ids `a` and `b` (id AOV values, −1 a miss) are two triangles of one flat
/// surface: coplanar and sharing an edge, so that a ray through that edge may fairly hit
/// either (the kernels' f32 rounding decides).
fn same_surface(scene: &Scene, a: f32, b: f32) -> bool {
    if a < 0.0 || b < 0.0 {
        return false;
    }
    let (Primitive::Triangle(s), Primitive::Triangle(t)) =
        (&scene.primitives[a as usize], &scene.primitives[b as usize])
    else {
        return false;
    };
    let shared = s.p.iter().filter(|p| t.p.contains(p)).count();
    let (ns, nt) = (s.cross().normalize(), t.cross().normalize());
    shared >= 2 && ns.cross(nt).length() < 1e-9
}

/// Runs a scene file at its own resolution.
fn run_file(file: &str, max_flip: f64, max_ids: usize) -> Case {
    let scene = load_case(file).scene;
    let (w, h) = scene.resolution.expect("hard-case scenes give their resolution");
    run(file, scene, RenderOptions::new(w, h), max_flip, max_ids)
}

/// The distance of the line (o, d) from point c, in f64.
fn miss_distance(o: DVec3, d: DVec3, c: DVec3) -> f64 {
    let d = d.normalize();
    let v = c - o;
    (v - d * v.dot(d)).length()
}

/// Where the ray (o, d) meets the plane z = z0 (None: parallel or behind).
fn on_plane_z(o: DVec3, d: DVec3, z0: f64) -> Option<DVec3> {
    let t = (z0 - o.z) / d.z;
    (t.is_finite() && t > 0.0).then(|| o + d * t)
}

fn sphere_of(scene: &Scene, id: usize) -> (DVec3, f64) {
    match &scene.primitives[id] {
        Primitive::Sphere(s) => (s.center, s.radius),
        p => panic!("primitive {id} is not a sphere: {p:?}"),
    }
}

// ---------------------------------------------------------------------------------------------
// 1. Grazing sphere rays

/// Eye rays pass a unit sphere at 1 ± 208 f32 ulps from its centre, about 0.1 ulp apart.
/// Outside a band of `BAND` ulps the GPU's hit or miss must be the exact one (the f64
/// distance of the ray from the centre, for the ray the camera defines); the CPU's must be
/// exact outside a band of 1e-6 ulps. Inside the band either answer is right. No NaN, and
/// GPU hit distances within 1e-3 of the exact near root.
#[test]
fn grazing_sphere_rays() {
    const ULP: f64 = f32::EPSILON as f64; // ulp(1) in f32: 2⁻²³
    const BAND: f64 = 16.0;
    let c = run_file("grazing_sphere.nff", 0.01, 12);
    let (centre, r) = sphere_of(&c.scene, 0);
    let (mut inside_band, mut checked, mut nearest_checked) = (0, 0, f64::MAX);
    // GPU answers that differ from the exact one: how many, and the farthest from the
    // silhouette (in ulps).
    let (mut wrong_gpu, mut worst_wrong_gpu) = (0, 0.0f64);
    for (x, y) in c.pixels() {
        let (o, d) = c.ray(x, y);
        let ulps = (miss_distance(o, d, centre) / r - 1.0) / ULP;
        let hit_exact = ulps < 0.0;
        let (g, k) = (Case::id(&c.gpu_id, x, y), Case::id(&c.cpu_id, x, y));
        if ulps.abs() > 1e-6 {
            assert_eq!(k.is_some(), hit_exact, "CPU at ({x}, {y}), {ulps:.3} ulps from the silhouette");
        }
        if g.is_some() != hit_exact {
            wrong_gpu += 1;
            worst_wrong_gpu = worst_wrong_gpu.max(ulps.abs());
        }
        if ulps.abs() <= BAND {
            inside_band += 1;
            continue;
        }
        checked += 1;
        nearest_checked = nearest_checked.min(ulps.abs());
        assert_eq!(g.is_some(), hit_exact, "GPU at ({x}, {y}), {ulps:.2} ulps from the silhouette");
        if g.is_some() {
            let t = c.gpu_depth.get(x, y)[0] as f64;
            let t_exact =
                (centre - o).dot(d.normalize()) - (r * r - miss_distance(o, d, centre).powi(2)).sqrt();
            assert!((t - t_exact).abs() < 1e-3, "GPU depth {t} vs {t_exact} at ({x}, {y})");
        }
    }
    eprintln!(
        "hard-case grazing_sphere: {checked} rays outside ±{BAND} ulps all exact on the GPU (nearest {nearest_checked:.2} \
         ulps), {inside_band} inside the band; {wrong_gpu} GPU answers differ from the exact one, all within \
         {worst_wrong_gpu:.3} ulps of the silhouette"
    );
    assert!(checked > 3000 && inside_band > 100, "the view must put rays on both sides of the band");
}

// ---------------------------------------------------------------------------------------------
// 2. Rays parallel to a triangle

/// The middle row of eye rays lies in the plane of triangle 0 (determinant 0) and passes
/// triangle 1 within 1e-7 of its plane: triangle 0 is never hit, every other pixel shows the
/// wall or the triangles exactly where the f64 rays meet them, and shadow rays from the
/// light in that plane pass the edge-on triangle to light the wall.
#[test]
fn rays_parallel_to_a_triangle() {
    let c = run_file("parallel_triangles.nff", 0.01, 0);
    let (_, h) = c.size();
    let mid = h / 2;
    for (x, y) in c.pixels() {
        let (g, k) = (Case::id(&c.gpu_id, x, y), Case::id(&c.cpu_id, x, y));
        assert_ne!(g, Some(0), "GPU hit the edge-on triangle at ({x}, {y})");
        assert_ne!(k, Some(0), "CPU hit the edge-on triangle at ({x}, {y})");
        if y != mid && g != k {
            let same = same_surface(&c.scene, g.map_or(-1.0, |i| i as f32), k.map_or(-1.0, |i| i as f32));
            assert!(same, "GPU {g:?} and CPU {k:?} ids at ({x}, {y}) away from the plane");
        }
        assert!(g.is_some(), "({x}, {y}) missed the wall");
        if y == mid {
            assert_eq!(g == Some(1), k == Some(1), "({x}, {y}): GPU {g:?} CPU {k:?} on the tilted triangle");
        }
    }
    // The middle row crosses the tilted triangle (1e-7 out of its plane) at three pixels.
    let tilted = (0..c.size().0).filter(|&x| Case::id(&c.gpu_id, x, mid) == Some(1)).count();
    assert!(tilted >= 3, "the middle row hits the tilted triangle at {tilted} pixels");
    // The light lies in the edge-on triangle's plane: it blocks no shadow ray.
    assert_eq!((c.gpu.stats.rays.shadow_blocked, c.cpu.stats.rays.shadow_blocked), (0, 0));
    eprintln!(
        "hard-case parallel_triangles: triangle 0 never hit; row {mid} hits the tilted triangle at {tilted} pixels \
         on both backends, the wall elsewhere"
    );
}

// ---------------------------------------------------------------------------------------------
// 3. Shared edges and vertices

/// No eye ray slips between the fan's triangles or the grid's: every pixel whose f64 ray
/// meets the fan (a regular 16-gon of circumradius 1) or the grid more than 1e-3 inside its
/// outline sees one of their triangles, on both backends. Tested one by one with the
/// kernels' f32 triangle test, such a ray hits at least one triangle, and the rays through
/// an edge or the fan's centre hit every triangle there (duplicates, counted): the nearest-hit
/// rule keeps one. Every floor pixel whose shadow ray crosses the fan more than 0.02 inside
/// its outline is in shadow: no shadow ray slips through a crack either.
#[test]
fn rays_through_shared_edges_and_vertices() {
    let c = run_file("shared_edges.nff", 0.01, 0);
    const M: f64 = 1e-3;
    let (fan, grid, floor) = (0..16u32, 16..48u32, 48..50u32);
    let inradius = (std::f64::consts::PI / 16.0).cos();
    let light = c.scene.lights[0].position;
    let prims = Prim32::from_scene(&c.scene, c.scene.camera.eye);
    let (mut covered, mut ring, mut duplicates, mut most) = (0, 0, 0, 0);
    let ambient_only = |px: [f32; 4]| {
        // Floor colour 0.8 · kd 0.9 · ambient 0.5, no light: 0.36.
        (px[0] as f64 - 0.36).abs() < 1e-4
    };
    for (x, y) in c.pixels() {
        let (o, d) = c.ray(x, y);
        let p = on_plane_z(o, d, 0.0).unwrap();
        let in_fan = p.truncate().length() < inradius - M;
        let in_grid = p.x > 1.1 + M && p.x < 2.7 - M && p.y > -0.8 + M && p.y < 0.8 - M;
        for (backend, ids) in [("GPU", &c.gpu_id), ("CPU", &c.cpu_id)] {
            let id = Case::id(ids, x, y);
            if in_fan {
                assert!(
                    id.is_some_and(|i| fan.contains(&i)),
                    "{backend}: a crack in the fan at ({x}, {y}): {id:?}"
                );
            }
            if in_grid {
                assert!(
                    id.is_some_and(|i| grid.contains(&i)),
                    "{backend}: a crack in the grid at ({x}, {y}): {id:?}"
                );
            }
        }
        if in_fan || in_grid {
            covered += 1;
            let ray = make_ray((o - c.scene.camera.eye).as_vec3(), d.as_vec3());
            let hits = (0..48).filter(|&i| prims[i].intersect(&ray, FAR).ok).count();
            assert!(hits >= 1, "the f32 test finds no triangle at ({x}, {y})");
            duplicates += hits - 1;
            most = most.max(hits);
        }
        // A floor pixel (by both backends) whose shadow ray towards the light crosses z = 0
        // well inside the fan.
        let f = on_plane_z(o, d, -1.0).unwrap();
        let cross = f + (light - f) * ((0.0 - f.z) / (light.z - f.z));
        let on_floor = |ids: &Image| Case::id(ids, x, y).is_some_and(|i| floor.contains(&i));
        if cross.truncate().length() < inradius - 0.02 && on_floor(&c.cpu_id) && on_floor(&c.gpu_id) {
            ring += 1;
            for (backend, img) in [("GPU", &c.gpu.image), ("CPU", &c.cpu.image)] {
                let px = img.get(x, y);
                assert!(
                    ambient_only(px),
                    "{backend}: light through the fan at floor pixel ({x}, {y}): {px:?}"
                );
            }
        }
    }
    let (w, h) = c.size();
    let centre_hits = {
        let (o, d) = c.ray(w / 2, h / 2);
        let ray = make_ray((o - c.scene.camera.eye).as_vec3(), d.as_vec3());
        (0..16).filter(|&i| prims[i].intersect(&ray, FAR).ok).count()
    };
    eprintln!(
        "hard-case shared_edges: {covered} pixels inside the fan and grid, 0 cracks ({duplicates} duplicate f32 \
         hits on shared edges, up to {most} on one ray, {centre_hits} of 16 at the fan's centre); {ring} floor \
         pixels shadowed through the fan, 0 lit; middle pixel id GPU {:?} CPU {:?}",
        Case::id(&c.gpu_id, w / 2, h / 2),
        Case::id(&c.cpu_id, w / 2, h / 2)
    );
    assert!(covered > 600 && ring > 50, "the view must cover the fan, the grid and the ring");
    assert!(duplicates > 0, "the middle row and column run along edges: some rays hit two triangles");
    assert_eq!(centre_hits, 16, "the ray through the fan's centre meets all 16 triangles");
}

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
// 5. A scene far from the origin

/// The same scene at the origin and shifted by (1e5, 1e5, 1e5) renders alike on the GPU
/// (the scene is re-centred on the camera in f64 before it is converted to f32).
#[test]
fn a_scene_1e5_from_the_origin() {
    let near = run_file("offset_origin.nff", 0.01, 2);
    let far = run_file("offset_1e5.nff", 0.01, 2);
    let (cmp, heat) = compare(&near.gpu.image, &far.gpu.image, 2.0 / 255.0);
    let ids = near.gpu_id.pixels.iter().zip(&far.gpu_id.pixels).filter(|(a, b)| a[0] != b[0]).count();
    eprintln!(
        "hard-case offset_1e5: GPU at the origin vs 1e5 away: FLIP mean {:.6}, max |diff| {:.5}, {ids} eye ids differ",
        cmp.flip_mean, cmp.max_abs
    );
    if cmp.flip_mean > 1e-3 || ids > 2 {
        let files = crate::common::save_failure(
            "offset_1e5",
            &[("origin", &near.gpu.image), ("far", &far.gpu.image)],
            Some((&heat, near.opts.width, near.opts.height)),
        );
        panic!("the scene 1e5 away differs: FLIP {}, {ids} ids; images: {files}", cmp.flip_mean);
    }
}

// ---------------------------------------------------------------------------------------------
// 6. Tiny and huge spheres

/// A sphere of radius 1e-4 at distance 1 (and one of 5e-5 near it): every pixel whose f64
/// ray passes more than 1e-3 r inside or outside a sphere's silhouette is hit or missed as
/// it should be, on both backends.
#[test]
fn tiny_spheres() {
    let c = run_file("tiny_sphere.nff", 0.01, 2);
    let spheres = [sphere_of(&c.scene, 0), sphere_of(&c.scene, 1)];
    let (mut covered, mut band) = ([0usize; 2], 0);
    for (x, y) in c.pixels() {
        let (o, d) = c.ray(x, y);
        let mut want = None;
        let mut near_edge = false;
        for (i, (centre, r)) in spheres.iter().enumerate() {
            let rel = miss_distance(o, d, *centre) / r - 1.0;
            near_edge |= rel.abs() < 1e-3;
            if rel < 0.0 && want.is_none() {
                want = Some(i as u32);
            }
        }
        if near_edge {
            band += 1;
            continue;
        }
        for (backend, ids) in [("GPU", &c.gpu_id), ("CPU", &c.cpu_id)] {
            let id = Case::id(ids, x, y).filter(|&i| i < 2);
            assert_eq!(id, want, "{backend} at ({x}, {y})");
        }
        if let Some(i) = want {
            covered[i as usize] += 1;
        }
    }
    eprintln!(
        "hard-case tiny_sphere: coverage exact on both backends: {covered:?} pixels, {band} in the 1e-3 band"
    );
    assert!(covered[0] > 50 && covered[1] > 10, "both tiny spheres must cover pixels");
}

/// A ground sphere of radius 1e5: every pixel whose f64 ray meets it (passing more than
/// 1e-4 inside its radius) sees it or the small sphere: no holes. The GPU's hit distances
/// are within 1% of the exact ones (measured: 0.16 at most, see the printed line). Its
/// shadow rays leave from points reprojected onto the sphere, 2⁻²¹ of 2e5 (0.1) above it, and
/// light does not leak under the small sphere: the GPU blocks the rays the CPU blocks (an
/// offset of 2⁻¹⁶ of it, 3 units, used to block none of them).
#[test]
fn a_huge_sphere() {
    let c = run_file("huge_sphere.nff", 0.005, 2);
    let (centre, r) = sphere_of(&c.scene, 0);
    let (mut ground, mut worst_depth) = (0, 0.0f64);
    for (x, y) in c.pixels() {
        let (o, d) = c.ray(x, y);
        let d = d.normalize();
        let m = miss_distance(o, d, centre);
        if m > r - 1e-4 || (centre - o).dot(d) < 0.0 {
            continue;
        }
        ground += 1;
        for (backend, ids) in [("GPU", &c.gpu_id), ("CPU", &c.cpu_id)] {
            let id = Case::id(ids, x, y);
            assert!(matches!(id, Some(0 | 1)), "{backend}: a hole in the huge sphere at ({x}, {y}): {id:?}");
        }
        if Case::id(&c.gpu_id, x, y) == Some(0) {
            // The f32 hit distance against the exact one (f64, near root).
            let exact = (centre - o).dot(d) - (r * r - m * m).sqrt();
            let err = (c.gpu_depth.get(x, y)[0] as f64 - exact).abs();
            assert!(err < 0.01 * exact, "GPU depth at ({x}, {y}) off by {err} of {exact}");
            worst_depth = worst_depth.max(err);
        }
    }
    eprintln!(
        "hard-case huge_sphere: {ground} pixels below the horizon, no holes; GPU hit distances within \
         {worst_depth:.2e} of exact; blocked shadow rays GPU {} CPU {}",
        c.gpu.stats.rays.shadow_blocked, c.cpu.stats.rays.shadow_blocked
    );
    assert!(ground > 1000);
    let blocked = (c.gpu.stats.rays.shadow_blocked, c.cpu.stats.rays.shadow_blocked);
    assert!(
        blocked.1 > 0 && blocked.0 == blocked.1,
        "light leaks: blocked shadow rays (GPU, CPU) {blocked:?}"
    );
}

/// A sky sphere of radius 1e13 around the camera, a light and a unit sphere 5 units below the
/// light: every sky pixel whose shadow line (from the sky point to the light, in f64) passes
/// the unit sphere more than 1% inside its radius shows the ambient term alone on both
/// backends, every one passing more than 1% outside more than that. The CPU's shadow rays used to end 1e-9 of their
/// length (1e4 units) before the light and passed through the sphere: no shadow at all.
#[test]
fn a_sky_sphere_keeps_the_shadows_next_to_the_light() {
    let c = run_file("sky_sphere.nff", 0.02, 0);
    let (sky, r) = sphere_of(&c.scene, 0);
    let (blocker, br) = sphere_of(&c.scene, 1);
    let light = c.scene.lights[0].position;
    // What a sky pixel in shadow shows: the ambient term alone.
    let m = &c.scene.materials[c.scene.primitives[0].material() as usize];
    let ambient_only = (c.scene.ambient * m.kd * m.color).to_array();
    let (mut dark, mut lit) = (0, 0);
    for (x, y) in c.pixels() {
        let (o, d) = c.ray(x, y);
        let d = d.normalize();
        let m = miss_distance(o, d, sky);
        let p = o + d * ((sky - o).dot(d) + (r * r - m * m).sqrt());
        let shadow = miss_distance(light, p - light, blocker);
        for (backend, img) in [("GPU", &c.gpu.image), ("CPU", &c.cpu.image)] {
            let v = img.get(x, y);
            let ambient = v[..3].iter().zip(ambient_only).all(|(a, b)| (*a as f64 - b).abs() < 1e-6);
            if shadow < 0.99 * br {
                assert!(
                    ambient,
                    "{backend}: light leaks at ({x}, {y}): {v:?}, ambient alone {ambient_only:?}"
                );
            } else if shadow > 1.01 * br {
                assert!(!ambient, "{backend}: a false shadow at ({x}, {y})");
            }
        }
        if shadow < 0.99 * br {
            dark += 1;
        } else if shadow > 1.01 * br {
            lit += 1;
        }
    }
    let blocked = (c.gpu.stats.rays.shadow_blocked, c.cpu.stats.rays.shadow_blocked);
    eprintln!("hard-case sky_sphere: {dark} pixels in shadow, {lit} lit; blocked shadow rays (GPU, CPU) {blocked:?}");
    assert!(dark > 100 && lit > 100, "{dark} {lit}");
    assert_eq!(blocked.0, blocked.1);
}

/// A sphere so large that f32 squares of its coordinates overflow (radius 1e20) is refused by
/// the GPU backend with an error naming it and the way out, before any Inf reaches a kernel;
/// the CPU reference renders it.
#[test]
fn a_sphere_beyond_f32_reach_is_refused_on_the_gpu() {
    let mut scene = load_case("sky_sphere.nff").scene;
    match &mut scene.primitives[0] {
        Primitive::Sphere(s) => s.radius = 1e20,
        p => panic!("not a sphere: {p:?}"),
    }
    let opts = RenderOptions::new(16, 16);
    let e = renderer().render(&scene, &opts, &hidden()).err().expect("the GPU refuses it");
    eprintln!("{e}");
    let msg = e.to_string();
    assert!(msg.contains("primitive 0") && msg.contains("--backend cpu"), "{msg}");
    let cpu = reference::render(&scene, &opts, &hidden()).unwrap();
    assert!(cpu.image.pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
}

/// The ground pixels around where a ball touches a huge sphere (hard cases 6c, 6d): the eye
/// ray of each pixel the reference sees ground at, met with the exact ground in f64, lands
/// within `RING` of the contact point.
fn contact_ring(scene: &Scene, cpu_id: &Image, contact: DVec3) -> Vec<(u32, u32)> {
    const RING: f64 = 0.75;
    let (w, h) = (cpu_id.width, cpu_id.height);
    let (centre, radius) = sphere_of(scene, 0);
    let mut ring = Vec::new();
    for y in 0..h {
        for x in 0..w {
            if Case::id(cpu_id, x, y) != Some(0) {
                continue;
            }
            let (o, d) = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, w, h);
            let d = d.normalize();
            let m = miss_distance(o, d, centre);
            let p = o + d * ((centre - o).dot(d) - (radius * radius - m * m).sqrt());
            if (p - contact).length() < RING {
                ring.push((x, y));
            }
        }
    }
    ring
}

/// How far `img` is from the reference `cpu` on the pixels `ring`: the largest difference of
/// a channel, and how many pixels differ by more than 2/255.
fn ring_error(img: &Image, cpu: &Image, ring: &[(u32, u32)]) -> (f32, usize) {
    let mut worst = 0.0f32;
    let mut over = 0;
    for &(x, y) in ring {
        let (a, b) = (img.get(x, y), cpu.get(x, y));
        let d = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max);
        worst = worst.max(d);
        over += usize::from(d > 2.0 / 255.0);
    }
    (worst, over)
}

/// A unit ball resting on a sphere of radius 1e5 (6c), and the same 1e5 from the origin
/// (6d), rendered with no flag: `--precision auto` picks f64 for them (primitives, ray
/// origins and spawn offsets in f64; `precision::` pins the rule), the case passes `run`'s
/// checks (every accelerator alike, no self-hit, the reference's image), and on the ring of
/// ground pixels around the contact it equals the f64 reference within 2/255 at every pixel
/// (measured: 0.0000 at all 454). Forced to f32, the render is off there by at most
/// `F32_WORST` at no more than `F32_OVER` pixels (measured: 0.175 at 54 pixels, with 10
/// self-hits where shadow rays start 0.1 off the ground, inside the ball's underside), and
/// the f64 render is nearer the reference than the f32 one.
#[test]
fn contact_on_huge_geometry() {
    const F32_WORST: f32 = 0.25;
    const F32_OVER: usize = 80;
    for (file, contact) in [("huge_contact.nff", DVec3::ZERO), ("huge_contact_1e5.nff", DVec3::splat(1e5))] {
        let scene = load_case(file).scene;
        let (w, h) = scene.resolution.expect("hard-case scenes give their resolution");
        let auto_opts = RenderOptions::new(w, h);
        let f32_opts = RenderOptions { precision: Precision::F32, ..auto_opts.clone() };
        let g32 = renderer().render(&scene, &f32_opts, &hidden()).unwrap_or_else(|e| panic!("{file}: {e}"));
        let c = run(file, scene, auto_opts, 0.005, 2);
        assert_eq!(c.gpu.stats.settings.precision, "f64", "{file}: auto must choose f64");
        assert!(c.gpu.stats.settings.precision_auto.as_ref().is_some_and(|w| w.contains("touches")));
        let ring = contact_ring(&c.scene, &c.cpu_id, contact);
        let (e32, over32) = ring_error(&g32.image, &c.cpu.image, &ring);
        let (e64, over64) = ring_error(&c.gpu.image, &c.cpu.image, &ring);
        eprintln!(
            "hard-case {file}: {} ring pixels around the contact; against the f64 reference: f64 GPU worst \
             {e64:.4}, {over64} pixels over 2/255; f32 GPU worst {e32:.4}, {over32} pixels over 2/255 \
             (self-hits f32 {}, f64 0)",
            ring.len(),
            g32.stats.rays.self_hits,
        );
        assert!(ring.len() > 200, "{file}: the view must show the ground around the contact");
        assert_eq!(over64, 0, "{file}: f64 GPU differs from the f64 reference by {e64} at the contact");
        assert!(e32 <= F32_WORST && over32 <= F32_OVER, "{file}: f32 GPU {e32} at {over32} pixels");
        assert!(
            e64 < e32 && over64 < over32,
            "{file}: f64 ({e64}, {over64}) not nearer than f32 ({e32}, {over32})"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 7, 8. Tangent, overlapping and nested bounds; the camera inside bounds

/// Spheres touching at a point, overlapping, and a mirror inside a glass sphere: the tables
/// equal brute force (asserted by `run`, every ray kind) and the GPU the CPU.
#[test]
fn tangent_overlapping_and_nested_bounds() {
    let c = run_file("nested_bounds.nff", 0.01, 2);
    assert!(c.gpu.stats.rays.refract > 100 && c.gpu.stats.rays.reflect > 100);
}

/// The eye at the centre of a glass sphere, inside the bounds of a ring of mirror spheres.
#[test]
fn camera_inside_a_glass_sphere_and_bounds() {
    let c = run_file("camera_inside.nff", 0.01, 2);
    // Every eye ray first meets the glass sphere (id 0) from inside, or a ring sphere.
    for (x, y) in c.pixels() {
        for (backend, ids) in [("GPU", &c.gpu_id), ("CPU", &c.cpu_id)] {
            let id = Case::id(ids, x, y);
            assert!(matches!(id, Some(0..=24)), "{backend} at ({x}, {y}): {id:?}");
        }
    }
    assert!(c.gpu.stats.rays.refract > 1000);
}

// ---------------------------------------------------------------------------------------------
// 9. Directions on cell boundaries

/// Eye and shadow rays along axes, face diagonals, cube corners and cell boundaries: the
/// tables find exactly what brute force finds (`run`), and the spheres placed on those
/// directions are seen where the f64 rays meet them. The file's −0.0 components are read
/// and normalised away (the camera's rays carry +0.0); directions with −0.0 components are
/// walked one by one in `tests/it/coherence.rs` (`boundary_directions_from_every_origin_kind`).
#[test]
fn directions_on_cell_boundaries() {
    let c = run_file("cell_boundaries.nff", 0.01, 4);
    let (w, h) = c.size();
    // The middle pixel looks along +x, the corners along the cube's corner directions: each
    // ray passes through the centre of a sphere.
    for (x, y) in [(w / 2, h / 2), (0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1), (0, h / 2), (w / 2, 0)] {
        let (o, d) = c.ray(x, y);
        let want = (0..c.scene.primitives.len() - 2)
            .find(|&i| miss_distance(o, d, sphere_of(&c.scene, i).0) < 1e-9)
            .unwrap_or_else(|| panic!("no sphere on the ray of pixel ({x}, {y}): {d}"));
        for (backend, ids) in [("GPU", &c.gpu_id), ("CPU", &c.cpu_id)] {
            assert_eq!(Case::id(ids, x, y), Some(want as u32), "{backend} at ({x}, {y}), direction {d}");
        }
    }
    eprintln!("hard-case cell_boundaries: axis, diagonal and corner pixels hit their spheres");
}

// ---------------------------------------------------------------------------------------------
// 10. Degenerate triangles

/// Six triangles without area are dropped with one warning naming the first one's line; the
/// four good ones and the tiny well-shaped one are kept (the GPU gets it as a triangle with
/// repeated vertices, once re-centred on the eye in f32) and render without NaN.
#[test]
fn degenerate_triangles() {
    let loaded = load_case("degenerate_triangles.nff");
    assert_eq!(loaded.scene.counts().triangles, 5, "four good triangles and the tiny one");
    assert!(
        loaded.warnings.iter().any(|w| w.contains("dropped 6 degenerate") && w.contains("line 21")),
        "the loader says what it dropped: {:?}",
        loaded.warnings
    );
    let c = run_file("degenerate_triangles.nff", 0.01, 0);
    assert!(c.gpu.stats.rays.eye_hit > 500);
    // Primitive 1 is the tiny triangle (file order, after the first good one). A ray
    // through its corner, by the kernels' f32 test, misses it without NaN.
    let prims = Prim32::from_scene(&c.scene, c.scene.camera.eye);
    let corner = DVec3::new(0.0, -0.5, 0.0) - c.scene.camera.eye;
    let h = prims[1].intersect(&make_ray(DVec3::ZERO.as_vec3(), corner.as_vec3()), FAR);
    assert!(!h.ok && !h.t.is_nan(), "the f32 test of the tiny triangle: {h:?}");
}

// ---------------------------------------------------------------------------------------------
// 11. NaN and Inf in every input field

/// Every number of `every_field.nff` replaced in turn by nan, inf and -inf: the loader
/// refuses the file, naming it and the line, without panicking; a valid file renders.
#[test]
fn nan_and_inf_in_every_input_field() {
    let path = hard("every_field.nff");
    let text = std::fs::read_to_string(&path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut refused = 0;
    for (ln, line) in text.lines().enumerate() {
        if line.starts_with('#') {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        for (k, word) in words.iter().enumerate() {
            if word.parse::<f64>().is_err() {
                continue;
            }
            for bad in ["nan", "inf", "-inf"] {
                let mut w = words.clone();
                w[k] = bad;
                let edited: String = text
                    .lines()
                    .enumerate()
                    .map(|(i, l)| if i == ln { w.join(" ") } else { l.to_string() } + "\n")
                    .collect();
                let p = dir.path().join("every_field.nff");
                std::fs::write(&p, &edited).unwrap();
                let err = match load::load(&p, &Default::default()) {
                    Ok(_) => panic!("line {}: `{}` with {bad} accepted", ln + 1, w.join(" ")),
                    Err(e) => format!("{e}"),
                };
                assert!(
                    err.contains(&format!("every_field.nff:{}:", ln + 1)),
                    "line {} with {bad}: the message names neither file nor line: {err}",
                    ln + 1
                );
                refused += 1;
            }
        }
    }
    eprintln!("hard-case every_field: {refused} edited files refused, each naming its line");
    assert!(refused > 100);
    let c = run_file("every_field.nff", 0.01, 2);
    assert!(c.gpu.stats.rays.shadow > 0);
}

/// glTF: NaN or Inf in positions and in the camera are refused; NaN, Inf and zero normals
/// become the triangle's geometric normal, as the normal AOV shows on both backends.
#[test]
fn nan_and_inf_in_gltf_fields() {
    for (file, words) in [
        ("bad/nan_position.gltf", &["POSITION", "not finite"][..]),
        ("bad/inf_position.gltf", &["POSITION", "not finite"]),
        ("bad/inf_camera.gltf", &["JSON", "number out of range at line"]),
    ] {
        let p = hard(file);
        let err = format!(
            "{}",
            load::load(&p, &Default::default()).err().unwrap_or_else(|| panic!("{file} loaded"))
        );
        assert!(err.contains(p.file_name().unwrap().to_str().unwrap()), "{file}: {err}");
        for w in words {
            assert!(err.contains(w), "{file}: `{w}` missing from: {err}");
        }
    }
    // From the command line: a non-zero exit, the message, and no image file.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.png");
    let st = crate::common::cuberay()
        .arg("render")
        .arg(hard("bad/nan_position.gltf"))
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&st.stderr);
    assert!(!st.status.success() && stderr.contains("position 1 is not finite"), "{stderr}");
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none(), "a refused render left a file");

    let loaded = load_case("bad_normals.gltf");
    assert!(loaded.warnings.iter().any(|w| w.contains("normals")), "{:?}", loaded.warnings);
    let scene = loaded.scene;
    let opts = RenderOptions::new(32, 32);
    for (backend, img) in [
        ("GPU", renderer().render_aov(&scene, &opts, Aov::Normal, &hidden()).unwrap().image),
        ("CPU", reference::render_aov(&scene, &opts, Aov::Normal, &hidden()).unwrap().image),
    ] {
        assert!(img.is_finite(), "{backend}: a non-finite normal");
        for p in img.pixels.iter().filter(|p| p[3] > 0.0) {
            let n = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            assert!((n.length() - 1.0).abs() < 1e-3 && n.z.abs() > 0.999, "{backend}: normal {n}");
        }
    }
    run("bad_normals.gltf", scene, opts, 0.01, 0);
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
// 13. Equal distance bounds and ties

/// Spheres with equal lower bounds, each with an exact twin listed later: the twins (ids
/// 8–15) are never seen, by any accelerator on either backend.
#[test]
fn equal_bounds_and_exact_ties() {
    let c = run_file("equal_ties.nff", 0.01, 4);
    let mut seen = 0;
    for (x, y) in c.pixels() {
        for (backend, ids) in [("GPU", &c.gpu_id), ("CPU", &c.cpu_id)] {
            let id = Case::id(ids, x, y);
            assert!(
                !matches!(id, Some(8..=15)),
                "{backend}: the later twin {id:?} won the tie at ({x}, {y})"
            );
            seen += matches!(id, Some(0..=7)) as usize;
        }
    }
    assert!(seen > 400, "the spheres must be seen");
    eprintln!("hard-case equal_ties: {} sphere pixels per backend, the lower id wins every tie", seen / 2);
}

// ---------------------------------------------------------------------------------------------
// 14. A light on or inside geometry; coplanar triangles

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

/// Coplanar triangles: every ray through an overlap ties within the error bound (their
/// distances differ only by rounding), so the lowest id wins there, on both backends and
/// every accelerator (asserted by `run`): triangle 0 over 1 and over its exact twin 2, at
/// every pixel of the overlaps. GPU and CPU see the same id at every pixel but those whose
/// ray passes within a hair of a triangle's edge (where f32 and f64 may decide the edge
/// apart), and shade alike wherever they see the same. In f32 and with `--precision f64`.
#[test]
fn coplanar_overlapping_triangles() {
    for precision in [Precision::F32, Precision::F64] {
        coplanar_overlaps(precision);
    }
}

fn coplanar_overlaps(precision: Precision) {
    let scene = load_case("coplanar_triangles.nff").scene;
    let (w, h) = scene.resolution.expect("hard-case scenes give their resolution");
    let c = run(
        "coplanar_triangles.nff",
        scene,
        RenderOptions { precision, ..RenderOptions::new(w, h) },
        0.01,
        80,
    );
    let tri = |id: usize| match &c.scene.primitives[id] {
        Primitive::Triangle(t) => t.p,
        p => panic!("{p:?}"),
    };
    // How far p lies inside triangle v (in z = 0, counter-clockwise), in units of edge
    // length × distance: the least of its edge functions (negative outside).
    let inside = |p: DVec3, v: [DVec3; 3]| {
        (0..3)
            .map(|i| {
                let (a, b) = (v[i], v[(i + 1) % 3]);
                (b - a).truncate().perp_dot((p - a).truncate())
            })
            .fold(f64::MAX, f64::min)
    };
    const EDGE: f64 = 1e-5;
    let (mut overlap, mut near_edges, mut counts) = (0, 0, [0usize; 3]);
    for (x, y) in c.pixels() {
        let (g, k) = (Case::id(&c.gpu_id, x, y), Case::id(&c.cpu_id, x, y));
        let (o, d) = c.ray(x, y);
        let p = on_plane_z(o, d, 0.0).unwrap();
        let (in0, in1) = (inside(p, tri(0)), inside(p, tri(1)));
        let near_edge = in0.abs() < EDGE || in1.abs() < EDGE;
        near_edges += near_edge as u32;
        if in0 > EDGE && in1 > EDGE {
            overlap += 1;
            assert_eq!((g, k), (Some(0), Some(0)), "({x}, {y}) lies in the overlap: the lowest id, 0, wins");
        }
        if !near_edge {
            assert_eq!(g, k, "GPU and CPU ids differ at ({x}, {y})");
        }
        assert_ne!(g, Some(2), "GPU: the later twin won at ({x}, {y})");
        if let Some(i) = g {
            counts[i as usize] += 1;
        }
    }
    let mut worst = 0.0f32;
    for (x, y) in c.pixels() {
        if Case::id(&c.gpu_id, x, y) == Case::id(&c.cpu_id, x, y) {
            let (g, k) = (c.gpu.image.get(x, y), c.cpu.image.get(x, y));
            worst = (0..3).map(|i| (g[i] - k[i]).abs()).fold(worst, f32::max);
        }
    }
    assert!(worst <= 2.0 / 255.0, "GPU and CPU differ by {worst} where they see the same triangle");
    let again = renderer().render_aov(&c.scene, &c.opts, Aov::Id, &hidden()).unwrap();
    assert_eq!(crate::common::first_difference(&again.image, &c.gpu_id), None, "a second render differs");
    eprintln!(
        "hard-case coplanar_triangles ({precision:?}): {overlap} pixels in the overlap of triangles 0 and 1, all id 0 on both \
         backends; GPU pixels by id {counts:?}; GPU = CPU ids at every pixel ({near_edges} within {EDGE:e} of an \
         edge checked by colour only); colours within {worst:.2e}"
    );
    assert!(overlap > 200 && counts[1] > 100);
}
