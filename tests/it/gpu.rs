//! GPU tests run on whatever adapter wgpu finds (lavapipe in CI). Without one they fail,
//! and the message says how to install lavapipe. Images are small to keep lavapipe fast.
//! Every scene is its own test (a failure names its scene and hides no other), and a
//! failed comparison writes both images and the FLIP map into the tests' scratch folder,
//! naming the files in its message.

use crate::common::renderer;
use cuberay::arith::spawn::SpawnPolicy;
use cuberay::coherence::walk::WALK_CHUNK;
use cuberay::compare::compare;
use cuberay::gpu::GpuRenderer;
use cuberay::job::{Accel, RenderOptions, Rendered};
use cuberay::load;
use cuberay::output::Aov;
use cuberay::reference;
use cuberay::sampling::Sampling;
use cuberay::scene::{Primitive, Scene};
use glam::DVec3;
use indicatif::ProgressBar;

fn hidden() -> ProgressBar {
    ProgressBar::hidden()
}

fn showcase() -> Scene {
    load::showcase().expect("showcase loads").scene
}

fn spd(name: &str) -> Scene {
    let p = crate::common::shared(&format!("spd/nff/{name}.nff"));
    load::load(&p, &Default::default()).unwrap_or_else(|e| panic!("{name}: {e}")).scene
}

#[test]
fn kernels_are_compiled_once_per_effect_set() {
    let r = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    let scene = showcase();
    let opts = RenderOptions::new(8, 6);
    r.render(&scene, &opts, &hidden()).unwrap();
    r.render(&scene, &opts, &hidden()).unwrap();
    // The wavefront's kernels: nearest for the eye's depth and for the later ones (whose
    // rays walk the BVH), shade, shadow (the showcase has shadows), resolve.
    assert_eq!(r.compiled_kernels(), 5);
    // The AOV pass traces eye rays only: a module (and tables) without effects.
    r.render_aov(&scene, &opts, Aov::Id, &hidden()).unwrap();
    r.render_aov(&scene, &opts, Aov::Depth, &hidden()).unwrap();
    assert_eq!(r.compiled_kernels(), 6);
    // Depth 1 needs neither reflection nor refraction: other modules of the kernels that
    // trace, one nearest for its one depth (`resolve` traces nothing: one module of it
    // serves every variant).
    let shallow = RenderOptions { max_depth: 1, ..opts.clone() };
    r.render(&scene, &shallow, &hidden()).unwrap();
    assert_eq!(r.compiled_kernels(), 9);
}

#[test]
fn an_uncounted_render_is_the_counted_one_without_its_counts() {
    // The showcase has mirrors, glass and shadows: every kind of ray, every counter.
    let scene = showcase();
    let counted = RenderOptions { sampling: Sampling::Corners, ..RenderOptions::new(24, 18) };
    let uncounted = RenderOptions { count: false, ..counted.clone() };
    let a = renderer().render(&scene, &counted, &hidden()).unwrap();
    let b = renderer().render(&scene, &uncounted, &hidden()).unwrap();
    assert_eq!(a.image.pixels, b.image.pixels, "counting changed the image");
    let (ca, cb) = (a.stats.counters, b.stats.counters);
    assert!(ca.rays.iter().all(|&r| r > 0), "a counted render counts every kind of ray: {ca:?}");
    assert!(ca.tests.iter().all(|t| t.total() > 0), "and tests for each: {ca:?}");
    assert_eq!(cb, cuberay::stats::Counters::default(), "an uncounted render counts nothing");
    // And says so, rather than reporting zeros.
    assert!(a.stats.counted && !b.stats.counted);
    assert!(b.stats.to_text().contains("not counted") && !b.stats.to_text().contains("per ray"));
}

/// Renders on both backends and checks agreement: FLIP mean, finite pixels, and ray
/// counts by kind within 2% (where two surfaces cross or lie within f32's error bound of
/// each other, the GPU's tie rule takes the lower id and the CPU's f64 the nearer surface:
/// measured 1.2 % more shadow rays on LightsPunctualLamp).
fn agree(name: &str, scene: &Scene, opts: &RenderOptions, max_flip: f64) -> (Rendered, Rendered) {
    let g = renderer().render(scene, opts, &hidden()).unwrap_or_else(|e| panic!("{name}: {e}"));
    let c = reference::render(scene, opts, &hidden()).unwrap();
    assert!(g.image.is_finite(), "{name}: non-finite GPU pixel");
    let (cmp, heat) = compare(&c.image, &g.image, 2.0 / 255.0);
    eprintln!(
        "{name}: FLIP mean {:.5}, RMSE {:.5}, rays gpu {} cpu {}",
        cmp.flip_mean, cmp.rmse, g.stats.rays.total, c.stats.rays.total
    );
    if cmp.flip_mean > max_flip {
        let files = crate::common::save_failure(
            name,
            &[("gpu", &g.image), ("cpu", &c.image)],
            Some((&heat, opts.width, opts.height)),
        );
        panic!("{name}: FLIP mean {} > {max_flip}; images: {files}", cmp.flip_mean);
    }
    let (gr, cr) = (g.stats.rays, c.stats.rays);
    for (kind, a, b) in [
        ("eye", gr.eye, cr.eye),
        ("shadow", gr.shadow, cr.shadow),
        ("reflect", gr.reflect, cr.reflect),
        ("refract", gr.refract, cr.refract),
    ] {
        let tol = (b as f64 * 0.02).max(1.0);
        assert!((a as f64 - b as f64).abs() <= tol, "{name}: {kind} rays gpu {a} cpu {b}");
    }
    assert_eq!(g.stats.effects, c.stats.effects, "{name}: simulated effects");
    // Self-hits: none with the reference's tiny offsets; on the GPU only rays leaving near
    // where two primitives touch or cross (tangent spheres, a cylinder's end in its joint
    // sphere, overlapping spheres, where the tie rule may take the farther surface within
    // f32's error bound, so that a ray leaving it starts inside the nearer: 3 of 1451 on
    // shells_s2), far fewer than any acne (`a_spawn_offset_too_small_shows_as_self_hits`).
    assert_eq!(cr.self_hits, 0, "{name}: CPU self-hits");
    let spawned = (gr.shadow + gr.reflect + gr.refract).max(1);
    assert!(gr.self_hits * 200 <= spawned, "{name}: {} self-hits of {spawned} spawned rays", gr.self_hits);
    (g, c)
}

#[test]
fn showcase_agrees_with_the_cpu() {
    let (g, c) = agree("showcase", &showcase(), &RenderOptions::new(96, 72), 0.01);
    // Every kind of ray is exercised.
    assert!(g.stats.rays.reflect > 0 && g.stats.rays.refract > 0 && g.stats.rays.shadow_blocked > 0);
    // The same statistics keys on both backends, and GPU kernel times when measured.
    let keys = |s: &str| {
        let v: serde_json::Value = serde_json::from_str(s).unwrap();
        let mut k = Vec::new();
        for (group, inner) in v.as_object().unwrap() {
            match inner.as_object() {
                Some(o) => k.extend(o.keys().map(|n| format!("{group}.{n}"))),
                None => k.push(group.clone()),
            }
        }
        k
    };
    assert_eq!(keys(&g.stats.to_json()), keys(&c.stats.to_json()));
    assert_eq!(g.stats.settings.backend, "gpu");
    assert_eq!(g.stats.time.gpu_s.is_some(), renderer().ctx.timestamps);
    // The wavefront's kernels ran: their times add up to the total.
    let k = g.stats.time.gpu_kernel_s;
    if let Some(total) = g.stats.time.gpu_s {
        let parts = [k.nearest, k.shade, k.shadow, k.resolve].map(|t| t.unwrap_or(0.0));
        assert!(k.nearest.is_some() && k.shade.is_some() && k.resolve.is_some(), "{k:?}");
        assert!((parts.iter().sum::<f64>() - total).abs() <= 1e-9 * total.max(1.0), "{k:?} against {total}");
        // By depth, the same passes: the depths' times add up to nearest + shade + shadow,
        // and every depth of the render ran.
        let depths = g.stats.time.gpu_depth_s.as_ref().expect("timed by depth");
        assert_eq!(depths.iter().map(|d| d.depth).collect::<Vec<_>>(), (1..=5).collect::<Vec<_>>());
        let by_depth: f64 = depths.iter().map(|d| d.all).sum();
        assert!((by_depth - parts[..3].iter().sum::<f64>()).abs() <= 1e-9 * total.max(1.0), "{depths:?}");
    }
    assert_eq!(k.aov, None);
    // Lane coherence: the eye pass had one invocation per grid point, in full groups (96·72
    // points are whole workgroups), so that a group pays at least its mean and a group of 32
    // at least one of 8; the CPU has none.
    let lanes = &g.stats.lanes;
    let eye = lanes.nearest[0];
    assert_eq!((eye.depth, eye.invocations), (1, 96 * 72));
    assert!(eye.steps > 0.0 && eye.max8 >= eye.steps && eye.max32 >= eye.max8, "{eye:?}");
    assert!(lanes.nearest.len() >= 2 && !lanes.shade.is_empty(), "{lanes:?}");
    assert!(lanes.nearest.iter().chain(&lanes.shade).all(|l| l.steps > 0.0 && l.max8 > 0.0), "{lanes:?}");
    assert!(c.stats.lanes.nearest.is_empty());
}

#[test]
fn jitter_and_corners_sample_where_the_cpu_does() {
    let scene = showcase();
    let jitter = RenderOptions { spp: 4, seed: 7, ..RenderOptions::new(48, 36) };
    agree("showcase jitter", &scene, &jitter, 0.01);
    let corners = RenderOptions { sampling: Sampling::Corners, ..RenderOptions::new(48, 36) };
    let (g, _) = agree("showcase corners", &scene, &corners, 0.01);
    assert_eq!(g.stats.rays.eye, 49 * 37);
}

/// The showcase moved far from the origin: re-centring on the camera keeps f32 precise.
#[test]
fn a_scene_far_from_the_origin_keeps_its_precision() {
    let mut scene = showcase();
    let shift = DVec3::new(3.0e5, -2.0e5, 1.0e5);
    scene.camera.eye += shift;
    for l in &mut scene.lights {
        l.position += shift;
    }
    for p in &mut scene.primitives {
        match p {
            Primitive::Sphere(s) => s.center += shift,
            Primitive::Triangle(t) => t.p.iter_mut().for_each(|v| *v += shift),
            Primitive::Cylinder(c) => {
                c.base += shift;
                c.apex += shift;
            }
        }
    }
    agree("showcase far away", &scene, &RenderOptions::new(64, 48), 0.01);
}

#[test]
fn aovs_match_the_cpu() {
    let scene = showcase();
    let opts = RenderOptions::new(64, 48);
    let g = renderer().render_aov(&scene, &opts, Aov::Id, &hidden()).unwrap();
    let c = reference::render_aov(&scene, &opts, Aov::Id, &hidden()).unwrap();
    let same = g.image.pixels.iter().zip(&c.image.pixels).filter(|(a, b)| a == b).count();
    // Only pixels whose centre grazes an edge may differ between f32 and f64.
    assert!(same as f64 >= 0.995 * g.image.pixels.len() as f64, "ids agree at {same} pixels");
    let g = renderer().render_aov(&scene, &opts, Aov::Depth, &hidden()).unwrap();
    let c = reference::render_aov(&scene, &opts, Aov::Depth, &hidden()).unwrap();
    let close = g
        .image
        .pixels
        .iter()
        .zip(&c.image.pixels)
        .filter(|(a, b)| (a[0] - b[0]).abs() <= 1e-4 * b[0].abs().max(1.0) && a[3] == b[3])
        .count();
    assert!(close as f64 >= 0.995 * g.image.pixels.len() as f64, "depths agree at {close} pixels");
    assert_eq!(g.stats.rays.eye, 64 * 48);
}

/// An SPD size-1 database, 64×64, the SPD depth 5, on the tables (the GPU's default).
fn spd_size_1_agrees_with_the_cpu(db: &str) {
    let name = format!("{db}_s1");
    let (g, _) = agree(&name, &spd(&name), &RenderOptions::new(64, 64), 0.01);
    assert_eq!(g.stats.settings.accel, "cube");
}
spd_cases!(spd_size_1_agrees_with_the_cpu: super::spd_size_1_agrees_with_the_cpu => [balls, gears, jacks, lattice, mount, rings, shells, sombrero, teapot, tetra, tree]);

/// An SPD size-2 database, 48×48 with SPD corner sampling, on the tables.
fn spd_size_2_agrees_with_the_cpu(db: &str) {
    let name = format!("{db}_s2");
    let opts = RenderOptions { sampling: Sampling::Corners, ..RenderOptions::new(48, 48) };
    let (g, _) = agree(&name, &spd(&name), &opts, 0.01);
    assert_eq!(g.stats.settings.accel, "cube");
}
spd_cases!(spd_size_2_agrees_with_the_cpu: super::spd_size_2_agrees_with_the_cpu => [balls, gears, jacks, lattice, mount, rings, shells, sombrero, teapot, tetra, tree]);

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

/// A glTF sample model agrees with the CPU and exercises `effect`.
fn gltf_model_agrees_with_the_cpu(file: &str, effect: &str) {
    let path = crate::common::shared(&format!("gltf/{file}"));
    let mut loaded = load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}"));
    // As `cuberay render` sets it up: a model without lights in the studio environment.
    load::apply_setup(&mut loaded, &path, &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}"));
    let studio = loaded.scene.environment.is_some();
    assert_eq!(studio, loaded.scene.file_lights().count() == 0, "{file}");
    // Every map is applied: no warning says one is averaged or ignored.
    for w in &loaded.warnings {
        let dropped = ["mean", "normal maps", "alphaMode", "not applied"].iter().any(|k| w.contains(k));
        assert!(!dropped || w.contains("occlusion maps are not applied"), "{file}: {w}");
    }
    let opts = RenderOptions { spp: 4, ..RenderOptions::new(64, 64) };
    let (g, _) = agree(file, &loaded.scene, &opts, 0.01);
    // The textures' memory on the device is stated: every texel of every scene texture and of
    // the environment map.
    let env_texels = loaded.scene.environment.as_ref().map_or(0, |e| e.texels.len());
    let texels: usize = loaded.scene.textures.iter().map(|t| t.texels.len()).sum::<usize>() + env_texels;
    assert_eq!(g.stats.texture_bytes, 4 * texels as u64, "{file}");
    if g.stats.texture_bytes > 0 {
        assert!(g.stats.to_text().contains("MiB on the device"), "{file}");
    }
    assert!(g.stats.effects.contains(&effect), "{file}: {:?}", g.stats.effects);
    assert_eq!(g.stats.effects.contains(&"environment"), studio, "{file}");
    assert!(g.stats.rays.eye_hit > 0, "{file}: nothing hit");
}

// glTF sample models: textures, emission, punctual lights, transmission, smooth normals.
/// Vertex colours (glTF COLOR_0 as normalised bytes, `scenes/vertex_colors.gltf`) tint as
/// given: under a light that reaches every point of the quad alike, each pixel is the
/// colour interpolated from its triangle's vertices times one number, on the GPU and the
/// CPU (which agree, FLIP ≤ 0.01).
#[test]
fn vertex_colors_tint_as_given() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vertex_colors.gltf");
    let scene = load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{e}")).scene;
    assert!(scene.effects().vertex_colors);
    let opts = RenderOptions::new(48, 48);
    let (g, c) = agree("vertex_colors", &scene, &opts, 0.01);
    assert!(g.stats.effects.contains(&"vertex_colors"), "{:?}", g.stats.effects);
    // Corners red (-1, -1), green (1, -1), blue (1, 1), white (-1, 1); triangles (0, 1, 2)
    // below the diagonal y = x and (0, 2, 3) above it.
    let v = [
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(1.0, -1.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(-1.0, 1.0, 0.0),
    ];
    let col = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
    let (mut checked, mut worst) = (0, 0.0f64);
    for y in 0..opts.height {
        for x in 0..opts.width {
            let (o, d) = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, opts.width, opts.height);
            let p = o + d * (-o.z / d.z);
            if p.x.abs() > 0.95 || p.y.abs() > 0.95 || (p.x - p.y).abs() < 0.05 {
                continue;
            }
            let [a, b, e] = if p.y < p.x { [0, 1, 2] } else { [0, 2, 3] };
            // Barycentrics in the plane z = 0.
            let area = |p: DVec3, q: DVec3, r: DVec3| (q - p).truncate().perp_dot((r - p).truncate());
            let whole = area(v[a], v[b], v[e]);
            let (wa, wb) = (area(p, v[b], v[e]) / whole, area(v[a], p, v[e]) / whole);
            let want = col[a] * wa + col[b] * wb + col[e] * (1.0 - wa - wb);
            for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
                let px = img.get(x, y);
                let got = DVec3::new(px[0] as f64, px[1] as f64, px[2] as f64);
                // The one number: the least-squares scale of `want` onto `got`.
                let k = got.dot(want) / want.dot(want);
                let off = (got - want * k).abs().max_element() / got.max_element();
                assert!(
                    k > 0.05 && off < 0.01,
                    "{backend} ({x}, {y}) at {p}: {got} is not a multiple of {want}"
                );
                worst = worst.max(off);
            }
            checked += 1;
        }
    }
    assert!(checked > 1000, "{checked} pixels checked");
    eprintln!(
        "vertex_colors: {checked} pixels, each within {worst:.1e} of its vertex colour times one number"
    );
}

/// A scene of the project's own `scenes/`.
fn own_scene(file: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(file);
    load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}")).scene
}

/// The linear RGB of pixel (`x`, `y`).
fn rgb(img: &cuberay::output::Image, x: u32, y: u32) -> DVec3 {
    let px = img.get(x, y);
    DVec3::new(px[0] as f64, px[1] as f64, px[2] as f64)
}

/// An alpha-masked checker (`scenes/alpha_mask.gltf`, from `scenes/make_maps.py`: 4×4
/// texels, nearest, cutoff 0.5) in front of a lit wall, seen straight on: its opaque texels
/// glow red, its clear ones show the wall, whose points are in the checker's shadow exactly
/// where the ray towards the tilted sun meets an opaque texel. On both backends, pixel by
/// pixel, and they agree (FLIP ≤ 0.01).
#[test]
fn alpha_mask_shows_the_wall_through_exactly_the_clear_texels() {
    let scene = own_scene("alpha_mask.gltf");
    assert!(scene.effects().alpha && !scene.effects().blend, "{:?}", scene.effects());
    checker_over_wall("alpha_mask", &scene, 1.0);
}

/// The same checker blended (glTF BLEND) with its opaque texels at alpha 0.6: each of their
/// pixels is 0.6 of the red glow and 0.4 of the wall behind (a pass-through ray), its clear
/// texels show the wall, and shadow rays take it as masked at 0.5, so its shadow is the
/// masked checker's.
#[test]
fn alpha_blend_lets_one_minus_alpha_through() {
    let mut scene = own_scene("alpha_mask.gltf");
    scene.materials[0].alpha = cuberay::scene::Alpha::Blend;
    scene.materials[0].opacity = 0.6;
    assert!(scene.effects().blend && !scene.effects().alpha, "{:?}", scene.effects());
    let (g, _) = checker_over_wall("alpha_blend", &scene, 0.6);
    assert!(g.stats.rays.refract > 0, "pass-through rays are counted as refraction rays");
}

/// Renders the checker over the wall on both backends and checks every pixel against the
/// closed form for opaque texels of alpha `a` (1: masked).
fn checker_over_wall(name: &str, scene: &Scene, a: f64) -> (Rendered, Rendered) {
    let opts = RenderOptions::new(64, 64);
    let (g, c) = agree(name, scene, &opts, 0.01);
    // Texel (i, j) of the quad [-1, 1]² (v downwards) at a point of the plane; opaque where
    // i + j is even.
    let opaque = |x: f64, y: f64| {
        let (i, j) = (((x + 1.0) * 2.0).floor(), ((1.0 - y) * 2.0).floor());
        (0.0..4.0).contains(&i) && (0.0..4.0).contains(&j) && (i + j) as i64 % 2 == 0
    };
    let to_sun = -scene.lights[0].direction;
    let (mut holes, mut shadowed) = (0, 0);
    for y in 0..opts.height {
        for x in 0..opts.width {
            let (o, d) = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, opts.width, opts.height);
            let p = o + d * (-o.z / d.z);
            // The wall point behind, lit unless its ray to the sun crosses z = 0 in an
            // opaque texel: its blue glow plus the lit grey.
            let w = o + d * ((-1.0 - o.z) / d.z);
            let q = w + to_sun * (1.0 / to_sun.z);
            let lit = if opaque(q.x, q.y) { 0.0 } else { 0.5 * to_sun.z };
            let wall = DVec3::new(lit, lit, lit + 0.5);
            let want = if opaque(p.x, p.y) {
                DVec3::X * a + wall * (1.0 - a)
            } else {
                holes += 1;
                shadowed += (lit == 0.0) as u32;
                wall
            };
            for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
                let got = rgb(img, x, y);
                assert!(
                    (got - want).abs().max_element() < 1e-4,
                    "{name}: {backend} ({x}, {y}) at {p}: {got}, not {want}"
                );
            }
        }
    }
    assert!(
        holes == 64 * 32 && shadowed > 200 && shadowed < holes,
        "{holes} hole pixels, {shadowed} in shadow"
    );
    assert!(g.stats.effects.contains(&if a < 1.0 { "blend" } else { "alpha" }), "{:?}", g.stats.effects);
    (g, c)
}

/// A floor whose metallic-roughness texture is smooth metal on its left half and rough
/// dielectric on its right (`scenes/metal_half.gltf`) mirrors the green card only on the
/// metal half; the rough half is plain grey. Both backends, which agree (FLIP ≤ 0.01).
#[test]
fn half_metal_texture_reflects_only_on_the_metal_half() {
    let scene = own_scene("metal_half.gltf");
    let e = scene.effects();
    assert!(e.maps && e.reflection && !e.refraction, "{e:?}");
    let opts = RenderOptions::new(64, 64);
    let (g, c) = agree("metal_half", &scene, &opts, 0.01);
    for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
        let (mut green_left, mut grey_right) = (0, 0);
        for y in 0..opts.height {
            for x in 0..opts.width {
                let (o, d) = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, opts.width, opts.height);
                let p = o + d * (-o.y / d.y);
                if d.y >= 0.0 || p.x.abs() > 1.9 || p.x.abs() < 0.1 || p.z.abs() > 1.9 {
                    continue;
                }
                let px = rgb(img, x, y);
                if p.x < 0.0 {
                    green_left += (px.y > 0.5 && px.x < 0.05 && px.z < 0.05) as u32;
                } else {
                    // Rough, non-metallic: kd·base under the overhead sun, and no mirror.
                    assert!(
                        (px - DVec3::splat(0.8)).abs().max_element() < 1e-3,
                        "{backend} ({x}, {y}): {px}"
                    );
                    grey_right += 1;
                }
            }
        }
        assert!(green_left > 100 && grey_right > 300, "{backend}: {green_left} green, {grey_right} grey");
    }
    assert!(g.stats.rays.reflect > 0);
}

/// A one-texel normal map tilts every normal of a quad towards +x and +y, near the half-way
/// vector of the light and the viewer (`scenes/normal_tilt.gltf`): each pixel is the closed
/// form's diffuse kd·C·(n'·L) plus Phong highlight ks·(R'·V)^shine for the tilted normal n'
/// (a flat normal's highlight is 0.577^76: none), on the half with a TANGENT attribute and on
/// the half whose tangents come from MikkTSpace alike (so both agree on glTF's +Y: up the
/// image, where v grows down), on both backends, which agree (FLIP ≤ 0.01).
#[test]
fn normal_map_tilts_shading_as_the_closed_form_says() {
    let scene = own_scene("normal_tilt.gltf");
    assert!(scene.effects().normal_maps, "{:?}", scene.effects());
    let opts = RenderOptions::new(48, 48);
    let (g, c) = agree("normal_tilt", &scene, &opts, 0.01);
    assert!(g.stats.effects.contains(&"normal_maps"), "{:?}", g.stats.effects);
    // Texel (169, 169, 241) in tangent space: T = +x (u grows right), B = +y (up the image),
    // N = +z.
    let t = |c: f64| 2.0 * c / 255.0 - 1.0;
    let m = &scene.materials[0];
    let l = -scene.lights[0].direction;
    let shade = |n: DVec3| {
        let r = n * (2.0 * n.dot(l)) - l;
        0.5 * m.kd * n.dot(l) + m.ks * r.dot(DVec3::Z).max(0.0).powf(m.shine)
    };
    let want = shade(DVec3::new(t(169.0), t(169.0), t(241.0)).normalize());
    let flat = shade(DVec3::Z);
    assert!(m.ks > 0.01 && (m.shine - 76.125).abs() < 1e-3, "{m:?}");
    for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
        for y in 0..opts.height {
            for x in 0..opts.width {
                let got = rgb(img, x, y);
                assert!(
                    (got - DVec3::splat(want)).abs().max_element() < 1e-4,
                    "{backend} ({x}, {y}): {got}, not {want}"
                );
            }
        }
    }
    eprintln!("normal_tilt: every pixel {want:.5} (an untilted normal gives {flat:.5})");
    assert!(want - flat > 0.1);
}

cases!(gltf_models_agree_with_the_cpu: super::gltf_model_agrees_with_the_cpu {
    avocado_normal_maps => ("Avocado/Avocado.gltf", "normal_maps"),
    damaged_helmet_maps => ("DamagedHelmet/DamagedHelmet.gltf", "maps"),
    flight_helmet_blend => ("FlightHelmet/FlightHelmet.gltf", "blend"),
    metal_rough_spheres => ("MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf", "reflection"),
    box_shadows => ("Box/Box.gltf", "shadows"),
    box_textured => ("BoxTextured/BoxTextured.gltf", "textures"),
    cornell_box_emission => ("CornellBox/CornellBox.glb", "emission"),
    lights_punctual_lamp_refraction => ("LightsPunctualLamp/LightsPunctualLamp.gltf", "refraction"),
    cameras => ("Cameras/Cameras.gltf", "shadows"),
    suzanne => ("Suzanne/Suzanne.gltf", "shadows"),
    toy_car_tinted_glass => ("ToyCar/ToyCar.gltf", "refraction"),
});

/// The README's first command renders the showcase on the GPU: `render` without a scene
/// or a backend.
#[test]
fn render_defaults_to_the_gpu_and_the_showcase() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("show.png");
    let st = crate::common::cuberay()
        .args(["render", "--width", "32", "--height", "24", "--stats", "json", "-o"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    let v: serde_json::Value = serde_json::from_slice(&st.stdout).unwrap();
    assert_eq!(v["settings"]["backend"], "gpu");
    assert_eq!(v["rays"]["eye"], 32 * 24);
    assert_eq!(image::open(&png).unwrap().width(), 32);
}

#[test]
fn compare_reports_writes_images_and_applies_the_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let run = |threshold: &str| {
        crate::common::cuberay()
            .args(["compare", "--width", "96", "--height", "72", "--json", "--threshold", threshold])
            .arg("--out-dir")
            .arg(dir.path())
            .output()
            .unwrap()
    };
    let st = run("0.01");
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    let v: serde_json::Value = serde_json::from_slice(&st.stdout).unwrap();
    for key in ["rmse", "psnr", "flip_mean", "max_abs", "over_tolerance"] {
        assert!(v.get(key).is_some(), "{key} missing");
    }
    let flip = v["flip_mean"].as_f64().unwrap();
    assert!(flip > 0.0 && flip <= 0.01, "{flip}");
    for f in ["showcase.gpu.png", "showcase.cpu.png", "showcase.flip.png"] {
        assert!(dir.path().join(f).is_file(), "{f} not written");
    }
    // A threshold below the FLIP mean fails the command (after printing the report).
    let st = run(&format!("{}", flip / 2.0));
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("exceeds the threshold"));
}

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
    let (g, _) = agree(name, scene, &RenderOptions::new(64, 48), 0.01);
    assert_eq!(g.stats.settings.accel, "cube", "{name}: the GPU's default is the tables");
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

/// A long render's memory does not grow with its length: `cuberay render` is sampled while
/// it traces tetra_s6 by brute force (256² or, where that ends within 3 s, a bigger image:
/// dozens of kernel passes over many tiles), and its resident memory over the last tenth of the run stays within 15% of the second tenth.
/// (With the kernel parameters in a uniform buffer, lavapipe compiled a kernel variant per
/// tile and kept them all: this render grew from 110 to 210 MB.) A small render of the same
/// kernel first compiles it, so that the one-time compilation (lavapipe compiles at the first
/// dispatch, and caches on disk) is not mistaken for growth.
#[test]
fn a_long_render_keeps_its_memory_flat() {
    let dir = tempfile::tempdir().unwrap();
    let render = |size: &str| {
        let mut c = crate::common::cuberay();
        c.args(["render", "--accel", "brute", "--width", size, "--height", size, "-o"])
            .arg(dir.path().join("long.png"))
            .arg(crate::common::shared("spd/nff/tetra_s6.nff"))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null());
        c
    };
    assert!(render("8").status().unwrap().success(), "the warm-up render failed");
    // Sampled every 100 ms, the render must last at least 3 s to be judged: a faster machine
    // (or a faster kernel) renders a bigger image rather than passing on too few samples.
    let sample = |size: &str| {
        let mut child = render(size).spawn().unwrap();
        let status = format!("/proc/{}/status", child.id());
        let mut rss_kib = Vec::new();
        while child.try_wait().unwrap().is_none() {
            if let Some(kib) = std::fs::read_to_string(&status).ok().and_then(|s| {
                s.lines().find(|l| l.starts_with("VmRSS:"))?.split_whitespace().nth(1)?.parse::<u64>().ok()
            }) {
                rss_kib.push(kib);
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        assert!(child.wait().unwrap().success(), "the {size}² render failed");
        rss_kib
    };
    let mut rss_kib = Vec::new();
    for size in ["256", "384", "576", "864"] {
        rss_kib = sample(size);
        if rss_kib.len() >= 30 {
            break;
        }
        eprintln!("a {size}² render took only {} samples of 100 ms: rendering a bigger one", rss_kib.len());
    }
    let n = rss_kib.len();
    assert!(n >= 30, "the render took only {n} samples of 100 ms: too short to judge; make it longer");
    let mean = |a: usize, b: usize| rss_kib[a..b].iter().sum::<u64>() as f64 / (b - a) as f64;
    let (second, last) = (mean(n / 10, 2 * n / 10), mean(9 * n / 10, n));
    eprintln!(
        "resident memory: second tenth {:.0} MiB, last tenth {:.0} MiB ({n} samples)",
        second / 1024.0,
        last / 1024.0
    );
    assert!(last <= 1.15 * second, "memory grew from {:.0} to {:.0} MiB", second / 1024.0, last / 1024.0);
}

/// A device that is gone ends a render with an error that says so: no hang, no panic.
#[test]
fn a_lost_device_ends_the_render_with_an_error() {
    let r = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    r.ctx.device.destroy();
    let e = r.render(&showcase(), &RenderOptions::new(16, 12), &hidden()).err().expect("an error");
    eprintln!("{e}");
    assert!(matches!(e, cuberay::Error::Gpu(_)), "{e:?}");
}

/// Compilation at first dispatch is timed apart from the kernel time: the first render of a
/// kernel warms it up once (a dispatch over no points), later renders in the process do not;
/// both report the longest submission.
#[test]
fn the_first_dispatch_is_timed_apart_from_the_kernel_time() {
    let r = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    let opts = RenderOptions::new(16, 12);
    let first = r.render(&showcase(), &opts, &hidden()).unwrap().stats.time;
    let second = r.render(&showcase(), &opts, &hidden()).unwrap().stats.time;
    eprintln!("first {first:?}\nsecond {second:?}");
    assert!(first.compile_s.is_some_and(|c| c > 0.0), "{first:?}");
    assert_eq!(second.compile_s, Some(0.0));
    for t in [&first, &second] {
        let longest = t.longest_submit_s.expect("longest submission");
        assert!(longest > 0.0 && longest <= t.trace_s, "{t:?}");
    }
}

/// `rays.self_hits` counts spawned rays that hit within 4 spawn offsets of their origin.
/// With a fixed offset below the rounding error of the hit points, rays re-hit the surface
/// they leave (rings: cylinders, which a ray leaving them still tests; mount: the facets
/// next to the one left) and the count says so, as the image does; with the default offset
/// it is 0, as on the f64 reference.
fn a_spawn_offset_too_small_shows_as_self_hits(name: &str, epsilon: f32, at_least: u64) {
    let scene = spd(name);
    let opts = |spawn| RenderOptions { spawn, ..RenderOptions::new(64, 64) };
    let render = |spawn| renderer().render(&scene, &opts(spawn), &hidden()).unwrap();
    let (scaled, tiny) = (render(SpawnPolicy::Scaled), render(SpawnPolicy::Fixed(epsilon)));
    let cpu = reference::render(&scene, &opts(SpawnPolicy::Scaled), &hidden()).unwrap();
    let (flip_scaled, flip_tiny) = (
        compare(&cpu.image, &scaled.image, 0.0).0.flip_mean,
        compare(&cpu.image, &tiny.image, 0.0).0.flip_mean,
    );
    let (s, t) = (scaled.stats.rays, tiny.stats.rays);
    eprintln!(
        "{name}: self-hits scaled {} of {} rays (FLIP {flip_scaled:.5}), fixed {epsilon:e} {} of {} (FLIP \
         {flip_tiny:.5}), cpu {}",
        s.self_hits, s.total, t.self_hits, t.total, cpu.stats.rays.self_hits
    );
    assert_eq!((s.self_hits, cpu.stats.rays.self_hits), (0, 0), "{name}: self-hits with the default offset");
    assert!(t.self_hits >= at_least, "{name}: only {} self-hits with a {epsilon:e} offset", t.self_hits);
    assert!(flip_tiny > flip_scaled, "{name}: the acne does not show ({flip_tiny} <= {flip_scaled})");
}
cases!(a_spawn_offset_too_small_shows_as_self_hits: super::a_spawn_offset_too_small_shows_as_self_hits {
    rings => ("rings_s1", 1e-7, 100),
    mount => ("mount_s1", 1e-8, 1000),
});
