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
//!
//! The cases are grouped by kind, a sub-module each (the numbers are those of §5):
//!
//! - `boundaries`: rays on a boundary: grazing a sphere (1), in a triangle's plane (2),
//!   through shared edges and vertices (3), along cell boundaries (9);
//! - `secondary_rays`: rays leaving surfaces: self-intersection (4), two parallel mirrors
//!   (12), a light on or inside geometry (14);
//! - `scale`: a scene far from the origin (5), tiny, huge and sky spheres, a sphere beyond
//!   f32's reach, contact on huge geometry (6);
//! - `overlaps`: tangent, overlapping and nested bounds and the camera inside them (7, 8),
//!   equal bounds and exact ties (13), coplanar triangles (14);
//! - `bad_input`: degenerate triangles (10), NaN and Inf in every input field (11).

use crate::common::{hard, renderer};
use cuberay::compare::compare;
use cuberay::job::{Accel, RenderOptions, Rendered};
use cuberay::load::{self, Loaded};
use cuberay::output::{Aov, Image};
use cuberay::reference;
use cuberay::scene::{Primitive, Scene};
use glam::DVec3;
use indicatif::ProgressBar;

mod bad_input;
mod boundaries;
mod overlaps;
mod scale;
mod secondary_rays;

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
