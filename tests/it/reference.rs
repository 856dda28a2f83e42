//! Tests of the CPU reference renderer: analytic scenes whose pixels are known in closed
//! form, sampling and statistics, brute force against the BVH, and the `render` command.

use std::path::{Path, PathBuf};

use glam::DVec3;
use indicatif::ProgressBar;

use crate::common::cuberay;

use cuberay::job::{Accel, RenderOptions, Rendered};
use cuberay::output::{Aov, Image};
use cuberay::reference::{render, render_aov};
use cuberay::sampling::{pcg, Sampling};
use cuberay::scene::{
    Camera, Cylinder, FovSpan, Light, Material, Primitive, Projection, Scene, Sphere, Triangle,
};

// ---------------------------------------------------------------------------------------
// Helpers

fn ortho(eye: DVec3, at: DVec3, up: DVec3, half_height: f64) -> Camera {
    Camera::look_at(eye, at, up, Projection::Orthographic { half_height }).unwrap()
}

fn scene(camera: Camera) -> Scene {
    let camera_up = camera.up;
    Scene {
        camera,
        lights: Vec::new(),
        ambient: DVec3::ZERO,
        background: DVec3::ZERO,
        materials: Vec::new(),
        textures: Vec::new(),
        primitives: Vec::new(),
        resolution: None,
        up: camera_up,
        environment: None,
        transfer: Default::default(),
    }
}

fn add_material(s: &mut Scene, m: Material) -> u32 {
    s.materials.push(m);
    (s.materials.len() - 1) as u32
}

fn matte(color: DVec3, kd: f64) -> Material {
    Material { color, kd, ..Material::default() }
}

fn sphere(center: DVec3, radius: f64, material: u32) -> Primitive {
    Primitive::Sphere(Sphere { center, radius, inside_only: false, material })
}

fn tri(p0: DVec3, p1: DVec3, p2: DVec3, material: u32) -> Primitive {
    Primitive::Triangle(Triangle::new([p0, p1, p2], material))
}

/// Two triangles covering the axis-aligned square [x0,x1]×[y0,y1] at height z.
fn quad_z(x0: f64, x1: f64, y0: f64, y1: f64, z: f64, material: u32) -> [Primitive; 2] {
    let a = DVec3::new(x0, y0, z);
    let b = DVec3::new(x1, y0, z);
    let c = DVec3::new(x1, y1, z);
    let d = DVec3::new(x0, y1, z);
    [tri(a, b, c, material), tri(a, c, d, material)]
}

fn opts(w: u32, h: u32) -> RenderOptions {
    RenderOptions::new(w, h)
}

fn run(s: &Scene, o: &RenderOptions) -> Rendered {
    let r = render(s, o, &ProgressBar::hidden()).expect("render");
    assert!(r.image.is_finite(), "non-finite pixel");
    r
}

fn px(img: &Image, x: u32, y: u32) -> DVec3 {
    let p = img.get(x, y);
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

fn assert_close(got: DVec3, want: DVec3, tol: f64, what: &str) {
    assert!((got - want).abs().max_element() <= tol, "{what}: got {got}, want {want}");
}

/// The statistics invariants every render must satisfy.
fn check_stats(r: &Rendered) {
    let s = &r.stats;
    assert!(s.rays.eye_hit <= s.rays.eye, "eye_hit > eye");
    assert!(s.rays.shadow_blocked <= s.rays.shadow, "shadow_blocked > shadow");
    assert_eq!(s.rays.total, s.rays.eye + s.rays.reflect + s.rays.refract + s.rays.shadow);
    let tpr = &s.tests_per_ray;
    let tests_from_rates = tpr.eye * s.rays.eye as f64
        + tpr.shadow * s.rays.shadow as f64
        + tpr.reflect * s.rays.reflect as f64
        + tpr.refract * s.rays.refract as f64;
    assert!((tests_from_rates - s.tests.total() as f64).abs() < 1e-6 * (1.0 + s.tests.total() as f64));
}

// ---------------------------------------------------------------------------------------
// Analytic scenes

/// A unit sphere under one point light (no falloff), seen straight on by an orthographic
/// camera: every pixel is ambient + diffuse + Phong in closed form.
#[test]
fn diffuse_sphere_matches_closed_form() {
    let mut s = scene(ortho(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 1.2));
    let color = DVec3::new(0.9, 0.6, 0.3);
    let m = add_material(&mut s, Material { color, kd: 0.7, ks: 0.3, shine: 12.0, ..Material::default() });
    s.primitives.push(sphere(DVec3::ZERO, 1.0, m));
    let light_pos = DVec3::new(3.0, 4.0, 6.0);
    s.lights.push(Light::point(light_pos, DVec3::new(1.0, 0.9, 0.8), 0.8));
    s.ambient = DVec3::splat(0.1);
    s.background = DVec3::new(0.0, 0.0, 0.25);
    let (w, h) = (24, 24);
    let r = run(&s, &opts(w, h));
    check_stats(&r);
    let mut hits = 0;
    for j in 0..h {
        for i in 0..w {
            // Orthographic: the pixel centre's ray runs along −z from (x, y, 5).
            let (o, _) = s.camera.ray(i as f64 + 0.5, j as f64 + 0.5, w, h);
            let rho2 = o.x * o.x + o.y * o.y;
            let want = if rho2 >= 1.0 {
                s.background
            } else {
                hits += 1;
                let p = DVec3::new(o.x, o.y, (1.0 - rho2).sqrt());
                let n = p;
                let l = (light_pos - p).normalize();
                let v = DVec3::Z;
                let mut c = s.ambient * color * 0.7;
                let ndl = n.dot(l);
                if ndl > 0.0 {
                    let refl = n * 2.0 * ndl - l;
                    let spec = 0.3 * refl.dot(v).max(0.0).powf(12.0);
                    c += DVec3::new(1.0, 0.9, 0.8) * 0.8 * (color * 0.7 * ndl + DVec3::splat(spec));
                }
                c
            };
            assert_close(px(&r.image, i, j), want, 1e-6, &format!("pixel ({i},{j})"));
        }
    }
    assert!(hits > 100);
    assert_eq!(r.stats.rays.eye_hit, hits);
    // A lone convex sphere never shadows itself: one shadow ray per lit hit, none blocked.
    assert_eq!(r.stats.rays.shadow_blocked, 0);
    assert!(r.stats.rays.shadow > 0 && r.stats.rays.shadow < hits);
}

/// A mirror inside a uniformly emitting, inside-only sky sphere: the mirror shows ρ·E,
/// the sky E; at depth 1 the mirror spawns nothing and is black.
#[test]
fn mirror_reflects_uniform_surroundings() {
    let cam = Camera::look_at(
        DVec3::new(0.0, -3.0, 2.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y: 50f64.to_radians(), span: FovSpan::ImageEdges },
    )
    .unwrap();
    let mut s = scene(cam);
    let e = DVec3::new(0.2, 0.5, 0.8);
    let sky = add_material(&mut s, Material { kd: 0.0, emission: e, ..Material::default() });
    let rho = DVec3::new(0.9, 0.8, 0.5);
    let mirror = add_material(&mut s, Material { kd: 0.0, mirror: rho, ..Material::default() });
    s.primitives.push(Primitive::Sphere(Sphere {
        center: DVec3::ZERO,
        radius: 50.0,
        inside_only: true,
        material: sky,
    }));
    s.primitives.extend(quad_z(-1.0, 1.0, -1.0, 1.0, 0.0, mirror));
    let (w, h) = (20, 16);
    let r = run(&s, &opts(w, h));
    check_stats(&r);
    let ids = render_aov(&s, &opts(w, h), Aov::Id, &ProgressBar::hidden()).unwrap().image;
    let mut mirror_pixels = 0;
    for j in 0..h {
        for i in 0..w {
            let on_mirror = ids.get(i, j)[0] >= 1.0;
            mirror_pixels += on_mirror as u64;
            let want = if on_mirror { rho * e } else { e };
            assert_close(px(&r.image, i, j), want, 1e-6, &format!("pixel ({i},{j})"));
        }
    }
    assert!(mirror_pixels > 20 && mirror_pixels < (w * h) as u64);
    assert_eq!(r.stats.rays.reflect, mirror_pixels);
    assert_eq!(r.stats.rays.eye_hit, (w * h) as u64);
    // Depth 1: eye rays only.
    let mut o = opts(w, h);
    o.max_depth = 1;
    let r1 = run(&s, &o);
    assert_eq!(r1.stats.rays.reflect, 0);
    for j in 0..h {
        for i in 0..w {
            let want = if ids.get(i, j)[0] >= 1.0 { DVec3::ZERO } else { e };
            assert_close(px(&r1.image, i, j), want, 1e-6, "depth 1");
        }
    }
}

/// The camera sits inside a glass sphere. A ray meeting the wall beyond the critical
/// angle is totally reflected, and chords of a sphere keep their angle, so it stays
/// inside: every hit adds the glass's emission and no refraction ray is ever spawned.
/// Below the critical angle each hit also refracts out to the background. Glass whose
/// transmission is tinted (glTF's KHR_materials_transmission) weights what it transmits by
/// its colour too, per channel.
#[test]
fn total_internal_reflection_in_a_glass_sphere() {
    for tinted in [false, true] {
        total_internal_reflection_in_a_glass_sphere_tinted(tinted);
    }
}

fn total_internal_reflection_in_a_glass_sphere_tinted(tinted: bool) {
    let (radius, ior, depth) = (2.0, 1.5, 5u32);
    let color = DVec3::new(0.3, 0.8, 0.5);
    let tint = if tinted { color } else { DVec3::ONE };
    let e = DVec3::new(0.05, 0.1, 0.2);
    let bg = DVec3::new(0.3, 0.6, 0.9);
    let (mirror, trans) = (0.1, 0.8);
    let build = |offset: f64| {
        // A 1×1 orthographic image: one ray along −z from (offset, 0, 0).
        let mut s = scene(ortho(DVec3::new(offset, 0.0, 0.0), DVec3::new(offset, 0.0, -1.0), DVec3::Y, 1e-3));
        s.background = bg;
        let glass = add_material(
            &mut s,
            Material {
                kd: 0.0,
                mirror: DVec3::splat(mirror),
                transmittance: trans,
                tinted_transmission: tinted,
                color,
                ior,
                emission: e,
                ..Material::default()
            },
        );
        s.primitives.push(sphere(DVec3::ZERO, radius, glass));
        s
    };
    // sin θ = offset / radius; critical: sin θ = 1/1.5.
    let tir = run(&build(0.8 * radius), &opts(1, 1));
    check_stats(&tir);
    assert_eq!(tir.stats.rays.refract, 0, "a refraction ray was spawned under total internal reflection");
    assert_eq!(tir.stats.rays.reflect, (depth - 1) as u64);
    // Each of the `depth` hits adds e, weighted by (mirror + transmittance·tint)^k.
    let w = DVec3::splat(mirror) + trans * tint;
    let want: DVec3 = (0..depth).map(|k| e * w.powf(k as f64)).sum();
    assert_close(px(&tir.image, 0, 0), want, 1e-6, "total internal reflection");

    let out = run(&build(0.3 * radius), &opts(1, 1));
    assert_eq!(out.stats.rays.refract, (depth - 1) as u64);
    assert_eq!(out.stats.rays.reflect, (depth - 1) as u64);
    // V_depth = e; V_k = e + mirror·V_{k+1} + trans·bg.
    let mut v = e;
    for _ in 1..depth {
        v = e + v * mirror + bg * trans * tint;
    }
    assert_close(px(&out.image, 0, 0), v, 1e-6, "partial refraction");
}

/// A square occluder above a floor under a point light, seen from straight above: each
/// floor pixel is lit or in shadow as the line to the light says, with a sharp edge.
#[test]
fn shadow_boundary_is_exact() {
    let mut s = scene(ortho(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, DVec3::Y, 2.0));
    let floor = add_material(&mut s, matte(DVec3::ONE, 0.8));
    let blocker = add_material(&mut s, matte(DVec3::new(1.0, 0.0, 0.0), 1.0));
    s.primitives.extend(quad_z(-3.0, 3.0, -3.0, 3.0, 0.0, floor));
    let (bx0, bx1, by0, by1, bz) = (-0.5, 0.4, -0.3, 0.6, 1.0);
    s.primitives.extend(quad_z(bx0, bx1, by0, by1, bz, blocker));
    let lp = DVec3::new(0.7, -0.4, 3.0);
    s.lights.push(Light::point(lp, DVec3::ONE, 1.0));
    s.ambient = DVec3::splat(0.05);
    let (w, h) = (40, 40);
    let r = run(&s, &opts(w, h));
    check_stats(&r);
    let (mut lit, mut dark, mut edge) = (0, 0, 0);
    for j in 0..h {
        for i in 0..w {
            let (o, _) = s.camera.ray(i as f64 + 0.5, j as f64 + 0.5, w, h);
            let p = DVec3::new(o.x, o.y, 0.0);
            if p.x >= bx0 && p.x <= bx1 && p.y >= by0 && p.y <= by1 {
                continue; // the blocker itself
            }
            // Where the segment to the light crosses the blocker's plane.
            let q = p + (lp - p) * (bz / lp.z);
            let margin =
                (q.x - bx0).abs().min((q.x - bx1).abs()).min((q.y - by0).abs()).min((q.y - by1).abs());
            if margin < 1e-9 {
                edge += 1;
                continue; // exactly on the shadow edge: either answer is right
            }
            let shadowed = q.x > bx0 && q.x < bx1 && q.y > by0 && q.y < by1;
            let l = (lp - p).normalize();
            let want = if shadowed {
                dark += 1;
                DVec3::splat(0.05 * 0.8)
            } else {
                lit += 1;
                DVec3::splat(0.05 * 0.8 + 0.8 * l.z)
            };
            assert_close(px(&r.image, i, j), want, 1e-6, &format!("floor pixel ({i},{j})"));
        }
    }
    assert!(lit > 100 && dark > 20, "lit {lit}, dark {dark}");
    // Pixel row 22 projects exactly onto the blocker's edge y = −0.3.
    assert!(edge > 0);
    let blocked = r.stats.rays.shadow_blocked;
    assert!(blocked >= dark && blocked <= dark + edge, "{blocked} blocked, {dark} dark, {edge} on the edge");
}

// ---------------------------------------------------------------------------------------
// Sampling and statistics

fn small_scene() -> Scene {
    let cam = Camera::look_at(
        DVec3::new(0.0, -4.0, 1.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y: 45f64.to_radians(), span: FovSpan::EdgePixelCenters },
    )
    .unwrap();
    let mut s = scene(cam);
    let m = add_material(&mut s, Material { ks: 0.5, mirror: DVec3::splat(0.5), ..Material::default() });
    s.primitives.push(sphere(DVec3::ZERO, 0.8, m));
    s.primitives.extend(quad_z(-5.0, 5.0, -5.0, 5.0, -0.8, 0));
    s.lights.push(Light::point(DVec3::new(2.0, -2.0, 4.0), DVec3::ONE, 1.0));
    s
}

#[test]
fn corners_sampling_traces_the_pixel_corners() {
    let (w, h, hh) = (7u32, 5u32, 1.5);
    let cam =
        |half_height| ortho(DVec3::new(0.3, -4.0, 1.0), DVec3::new(0.3, 0.0, 0.2), DVec3::Z, half_height);
    let mut s = small_scene();
    s.camera = cam(hh);
    let mut o = opts(w, h);
    o.sampling = Sampling::Corners;
    let r = run(&s, &o);
    check_stats(&r);
    assert_eq!(r.stats.rays.eye, ((w + 1) * (h + 1)) as u64);
    assert_eq!(r.stats.settings.sampling, "corners");
    // An orthographic (W+1)×(H+1) centre-sampled image with the same pixel pitch samples
    // exactly the corners of the W×H image: each corners pixel is the mean of four of its
    // pixels.
    s.camera = cam(hh * (h + 1) as f64 / h as f64);
    let c = run(&s, &opts(w + 1, h + 1));
    for j in 0..h {
        for i in 0..w {
            let mean = (px(&c.image, i, j)
                + px(&c.image, i + 1, j)
                + px(&c.image, i, j + 1)
                + px(&c.image, i + 1, j + 1))
                * 0.25;
            assert_close(px(&r.image, i, j), mean, 1e-6, &format!("pixel ({i},{j})"));
        }
    }
    assert_eq!(r.stats.rays, c.stats.rays, "the same rays are traced");
}

#[test]
fn spp_counts_and_determinism() {
    let s = small_scene();
    let mut o = opts(6, 4);
    o.spp = 3;
    o.seed = 9;
    let a = run(&s, &o);
    check_stats(&a);
    assert_eq!(a.stats.rays.eye, 6 * 4 * 3);
    assert_eq!(a.stats.settings.sampling, "jitter");
    let b = run(&s, &o);
    assert_eq!(a.image, b.image, "same seed, different image");
    o.seed = 10;
    let c = run(&s, &o);
    assert_ne!(a.image, c.image, "the seed changes nothing");
}

// ---------------------------------------------------------------------------------------
// Brute force against the BVH on random scenes

/// A deterministic random scene of spheres, triangles, cylinders and cones with matte,
/// mirror and glass materials and two lights.
fn random_scene(seed: u32) -> Scene {
    let mut state = pcg(seed);
    let mut rnd = move || {
        state = pcg(state);
        state as f64 / 4294967296.0
    };
    let cam = Camera::look_at(
        DVec3::new(0.0, -12.0, 5.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y: 60f64.to_radians(), span: FovSpan::ImageEdges },
    )
    .unwrap();
    let mut s = scene(cam);
    s.ambient = DVec3::splat(0.1);
    s.background = DVec3::new(0.1, 0.2, 0.3);
    add_material(&mut s, matte(DVec3::new(0.8, 0.7, 0.6), 0.9));
    add_material(&mut s, Material { ks: 0.6, shine: 20.0, mirror: DVec3::splat(0.6), ..Material::default() });
    add_material(&mut s, Material { kd: 0.1, transmittance: 0.8, ior: 1.4, ..Material::default() });
    s.lights.push(Light::point(DVec3::new(5.0, -5.0, 9.0), DVec3::ONE, 0.7));
    s.lights.push(Light::point(DVec3::new(-6.0, -2.0, 7.0), DVec3::new(1.0, 0.8, 0.6), 0.5));
    s.primitives.extend(quad_z(-20.0, 20.0, -20.0, 20.0, -4.0, 0));
    let mut pt = || DVec3::new(rnd() * 10.0 - 5.0, rnd() * 10.0 - 5.0, rnd() * 6.0 - 3.0);
    for k in 0..60 {
        let m = (k % 3) as u32;
        let c = pt();
        let prim = match k % 4 {
            0 => sphere(c, 0.3 + 0.01 * (k as f64), m),
            1 => tri(c, c + DVec3::new(1.0, 0.2, 0.3), c + DVec3::new(0.1, 0.3, 1.2), m),
            2 => Primitive::Cylinder(Cylinder {
                base: c,
                base_radius: 0.3,
                apex: c + DVec3::new(0.2, 0.3, 1.5),
                apex_radius: if k % 8 == 2 { 0.3 } else { 0.1 },
                inside_only: false,
                material: m,
            }),
            _ => sphere(c, 0.5, m),
        };
        s.primitives.push(prim);
    }
    s.validate().unwrap();
    s
}

#[test]
fn brute_bvh_and_cube_give_identical_images() {
    for seed in 1..=4 {
        let s = random_scene(seed);
        let mut o = opts(40, 30);
        o.accel = Accel::Brute;
        let brute = run(&s, &o);
        o.accel = Accel::Bvh;
        let bvh = run(&s, &o);
        assert_eq!(brute.stats.settings.accel, "brute");
        assert_eq!(bvh.stats.settings.accel, "bvh");
        check_stats(&brute);
        check_stats(&bvh);
        assert!(brute.stats.rays.reflect > 0 && brute.stats.rays.refract > 0 && brute.stats.rays.shadow > 0);
        assert_eq!(brute.image, bvh.image, "seed {seed}: images differ");
        assert_eq!(brute.stats.rays, bvh.stats.rays, "seed {seed}: ray counts differ");
        // The BVH must test fewer primitives per eye ray than testing all 62.
        assert!(bvh.stats.tests_per_ray.eye < brute.stats.tests_per_ray.eye);
        // The direction-cube tables (with the BVH for rays leaving surfaces) choose which
        // primitives the same f64 tests run on.
        o.accel = Accel::Cube;
        let cube = run(&s, &o);
        assert_eq!(cube.stats.settings.accel, "cube");
        check_stats(&cube);
        assert_eq!(brute.image, cube.image, "seed {seed}: cube image differs");
        assert_eq!(brute.stats.rays, cube.stats.rays, "seed {seed}: cube ray counts differ");
        assert!(cube.stats.tests_per_ray.eye < brute.stats.tests_per_ray.eye);
        assert!(cube.stats.tests_per_ray.shadow < brute.stats.tests_per_ray.shadow);
        assert!(cube.stats.tests_per_ray.reflect < brute.stats.tests_per_ray.reflect);
        for aov in [Aov::Id, Aov::Depth] {
            o.accel = Accel::Brute;
            let a = render_aov(&s, &o, aov, &ProgressBar::hidden()).unwrap();
            for accel in [Accel::Bvh, Accel::Cube] {
                o.accel = accel;
                let b = render_aov(&s, &o, aov, &ProgressBar::hidden()).unwrap();
                assert_eq!(a.image, b.image, "seed {seed}: {aov:?} differs with {accel:?}");
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// The render command

fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect()
}

#[test]
fn a_failed_render_writes_nothing() {
    let dir = tempdir();
    let out = dir.path().join("out.png");
    // A scene that cannot be loaded.
    let bad = dir.path().join("missing.nff");
    let st = cuberay().arg("render").arg(&bad).arg("-o").arg(&out).output().unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("missing.nff"));
    // An unknown image format is refused before anything else.
    let st = cuberay().arg("render").arg(&bad).arg("-o").arg(dir.path().join("out.bmp")).output().unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("unknown image format"));
    // The GPU backend fails the same way on a missing scene.
    let st = cuberay().args(["render", "x.nff", "--backend", "gpu", "-o"]).arg(&out).output().unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("x.nff"));
    assert!(files_in(dir.path()).is_empty(), "{:?}", files_in(dir.path()));
}

// ---------------------------------------------------------------------------------------
// SPD scenes (read from the shared scenes folder; the tests fail when it is missing)

fn load_spd(name: &str) -> Scene {
    let path = crate::common::shared(&format!("spd/nff/{name}.nff"));
    cuberay::load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{e}")).scene
}

/// An SPD database at size 1, small and at SPD depth with corner sampling: finite pixels
/// and consistent statistics.
fn spd_size_1_renders_without_nan(name: &str) {
    let s = load_spd(&format!("{name}_s1"));
    let mut o = opts(24, 24);
    o.sampling = Sampling::Corners;
    let r = run(&s, &o);
    check_stats(&r);
    assert_eq!(r.stats.rays.eye, 25 * 25, "{name}");
    assert!(r.stats.rays.eye_hit > 0, "{name}: nothing hit");
}
spd_cases!(spd_size_1_renders_without_nan: super::spd_size_1_renders_without_nan =>
    [balls, gears, jacks, lattice, mount, rings, shells, sombrero, teapot, tetra, tree]);

/// Mean luminance over `k`×`k` blocks of an 8-bit sRGB image.
fn block_luminance(img: &image::RgbImage, k: u32) -> Vec<f64> {
    let (w, h) = (img.width() / k, img.height() / k);
    let mut out = Vec::new();
    for by in 0..h {
        for bx in 0..w {
            let mut sum = 0.0;
            for y in 0..k {
                for x in 0..k {
                    let p = img.get_pixel(bx * k + x, by * k + y).0;
                    sum += 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
                }
            }
            out.push(sum / (k * k) as f64);
        }
    }
    out
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma) * (x - ma);
        bb += (y - mb) * (y - mb);
    }
    ab / (aa * bb).sqrt()
}

/// The SPD reference images (POV-Ray, its own shading and tone) cannot be matched pixel
/// for pixel, but their layout can: at 64×64, our render's luminance must correlate
/// clearly with the reference's, and better than its own mirror image does (a mirrored
/// camera moves the teapot's spout to the other side, the tree's shadows, the gears...).
fn spd_render_matches_the_orientation_of_its_reference_image(name: &str) {
    let size = match name {
        "balls" | "gears" => 4,
        "mount" | "tetra" => 6,
        "rings" => 7,
        "tree" => 11,
        "teapot" => 12,
        _ => unreachable!("{name} is not a canonical SPD scene"),
    };
    {
        let s = load_spd(&format!("{name}_s{size}"));
        let reference = image::open(crate::common::shared(&format!("spd/doc/reference_images/{name}.png")))
            .unwrap()
            .into_rgb8();
        assert_eq!(reference.dimensions(), (512, 512));
        let ours = cuberay::output::to_rgb8(&run(&s, &opts(64, 64)).image);
        let mirrored = image::imageops::flip_horizontal(&ours);
        let r = block_luminance(&reference, 8);
        let a = correlation(&block_luminance(&ours, 1), &r);
        let m = correlation(&block_luminance(&mirrored, 1), &r);
        eprintln!("{name}: correlation {a:.3}, mirrored {m:.3}");
        assert!(a > 0.5, "{name}: the render does not resemble the reference (correlation {a:.3})");
        // Measured at 64×64: every scene correlates 0.51–0.92 and beats its mirror image by
        // 0.08 (tree, nearly symmetric) to 0.63 (gears).
        assert!(a > m + 0.05, "{name}: the mirror image matches the reference as well ({a:.3} vs {m:.3})");
    }
}
spd_cases!(spd_renders_match_the_orientation_of_the_reference_images:
    super::spd_render_matches_the_orientation_of_its_reference_image =>
    [balls, gears, mount, rings, teapot, tetra, tree]);

/// A tiny NFF file: a mirror sphere on a matte square under one light.
const TINY_NFF: &str = "\
v
from 0 -4 1
at 0 0 0
up 0 0 1
angle 40
hither 1
resolution 16 12
b 0.1 0.2 0.3
l 2 -2 4
f 1 0.2 0.2 0.7 0.3 20 0 0
s 0 0 0 0.8
f 0.8 0.8 0.8 1 0 1 0 0
p 4
-3 -3 -0.8
3 -3 -0.8
3 3 -0.8
-3 3 -0.8
";

#[test]
fn render_command_writes_images_and_statistics() {
    let dir = tempdir();
    let scene = dir.path().join("tiny.nff");
    std::fs::write(&scene, TINY_NFF).unwrap();
    let png = dir.path().join("tiny.png");
    let st = cuberay()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&png)
        .args(["--backend", "cpu", "--sampling", "corners", "--stats", "json"])
        .output()
        .unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (16, 12), "the scene's resolution is the default");
    let v: serde_json::Value = serde_json::from_slice(&st.stdout).expect("one JSON object on stdout");
    assert_eq!(v["rays"]["eye"], 17 * 13);
    assert_eq!(v["settings"]["sampling"], "corners");
    assert_eq!(v["settings"]["backend"], "cpu");
    assert!(v["rays"]["reflect"].as_u64().unwrap() > 0);
    assert!(v["tests_per_ray"]["shadow"].as_f64().unwrap() > 0.0);
    assert_eq!(v["effects"], serde_json::json!(["shadows", "reflection"]));

    // An AOV to EXR, at an overridden size, with text statistics.
    let exr = dir.path().join("id.exr");
    let st = cuberay()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&exr)
        .args(["--backend", "cpu", "--aov", "id", "--width", "8", "--height", "6", "--stats"])
        .output()
        .unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    assert!(String::from_utf8_lossy(&st.stdout).contains("rays:"));
    let ids = image::open(&exr).unwrap().into_rgba32f();
    assert_eq!(ids.dimensions(), (8, 6));
    // The sphere (id 0) is in the middle, the floor (ids 1, 2) below it.
    assert_eq!(ids.get_pixel(4, 3).0, [0.0, 0.0, 0.0, 1.0]);
    assert!(ids.get_pixel(4, 5).0[0] >= 1.0);

    // A failing render leaves an existing output untouched.
    let before = std::fs::read(&png).unwrap();
    let st = cuberay()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&png)
        .args(["--spp", "2", "--sampling", "corners"])
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert_eq!(std::fs::read(&png).unwrap(), before);
    assert_eq!(files_in(dir.path()).len(), 3, "a temporary file was left behind");
}

/// A glTF sample model renders with finite pixels, and the effect it calls for is simulated.
fn gltf_model_renders_without_nan(file: &str, effect: &str) {
    {
        let path = crate::common::shared(&format!("gltf/{file}"));
        let s = cuberay::load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{e}")).scene;
        let r = run(&s, &opts(24, 24));
        check_stats(&r);
        assert!(r.stats.rays.eye_hit > 0, "{file}: nothing hit");
        assert!(r.stats.effects.contains(&effect), "{file}: {:?}", r.stats.effects);
    }
}
cases!(gltf_models_render_without_nan: super::gltf_model_renders_without_nan {
    box_shadows => ("Box/Box.gltf", "shadows"),
    box_textured => ("BoxTextured/BoxTextured.gltf", "textures"),
    cornell_box_emission => ("CornellBox/CornellBox.glb", "emission"),
    lights_punctual_lamp_refraction => ("LightsPunctualLamp/LightsPunctualLamp.gltf", "refraction"),
});

/// PNG output encodes by the scene's transfer: NFF colours are display values, stored as
/// they are; `--transfer srgb` sRGB-encodes them instead; glTF defaults to sRGB. `--stats`
/// says which was used.
#[test]
fn png_transfer_defaults_to_the_scene_format_and_can_be_chosen() {
    let dir = tempdir();
    let scene = dir.path().join("tiny.nff");
    std::fs::write(&scene, TINY_NFF).unwrap();
    let render = |out: &str, extra: &[&str]| {
        let st = cuberay()
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(dir.path().join(out))
            .args(["--backend", "cpu", "--stats", "json"])
            .args(extra)
            .output()
            .unwrap();
        assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
        let v: serde_json::Value = serde_json::from_slice(&st.stdout).unwrap();
        v["settings"]["transfer"].as_str().unwrap().to_string()
    };
    assert_eq!(render("lin.exr", &[]), "display");
    assert_eq!(render("display.png", &[]), "display");
    assert_eq!(render("srgb.png", &["--transfer", "srgb"]), "srgb");
    let lin = image::open(dir.path().join("lin.exr")).unwrap().into_rgb32f();
    let display = image::open(dir.path().join("display.png")).unwrap().into_rgb8();
    let srgb = image::open(dir.path().join("srgb.png")).unwrap().into_rgb8();
    let mut brighter = 0;
    for (x, y, p) in lin.enumerate_pixels() {
        for c in 0..3 {
            let v = p.0[c].clamp(0.0, 1.0);
            assert_eq!(
                display.get_pixel(x, y).0[c],
                (v * 255.0).round() as u8,
                "display value at ({x}, {y})"
            );
            let s = cuberay::output::png_value(p.0[c], cuberay::scene::Transfer::Srgb);
            assert_eq!(srgb.get_pixel(x, y).0[c], s, "sRGB value at ({x}, {y})");
            brighter += (s > display.get_pixel(x, y).0[c]) as u32;
        }
    }
    assert!(brighter > 0, "sRGB encoding lifts mid-tones");
    let gltf = crate::common::shared("gltf/Box/Box.gltf");
    let st = cuberay()
        .arg("render")
        .arg(&gltf)
        .arg("-o")
        .arg(dir.path().join("box.png"))
        .args(["--backend", "cpu", "--width", "8", "--height", "8", "--stats", "json"])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&st.stdout).unwrap();
    assert_eq!(v["settings"]["transfer"], "srgb");
}
