//! Environments (`--env`): what rays leaving the scene see and the median-cut lights that
//! stand in for the map, on both backends against closed forms; the camera flags; the
//! reader's errors.

use std::f64::consts::PI;
use std::path::Path;

use cuberay::job::{Accel, RenderOptions, Rendered};
use cuberay::load::{self, EnvChoice, Setup};
use cuberay::output::{Aov, Image};
use cuberay::reference;
use cuberay::scene::{
    Camera, Environment, FovSpan, Material, Primitive, Projection, Scene, Sphere, Transfer, Triangle,
    ViewOverride,
};
use glam::DVec3;
use indicatif::ProgressBar;

use crate::common::{cuberay, renderer};

fn hidden() -> ProgressBar {
    ProgressBar::hidden()
}

/// A scene of `prims` seen by `camera` (Y up, no light, no ambient, linear radiance).
fn scene(camera: Camera, materials: Vec<Material>, prims: Vec<Primitive>) -> Scene {
    Scene {
        camera,
        lights: Vec::new(),
        ambient: DVec3::ZERO,
        background: DVec3::ZERO,
        materials,
        textures: Vec::new(),
        primitives: prims,
        resolution: None,
        up: DVec3::Y,
        environment: None,
        transfer: Transfer::Srgb,
    }
}

fn look(from: DVec3, at: DVec3, fov: f64) -> Camera {
    let p = Projection::Perspective { fov_y: fov.to_radians(), span: FovSpan::ImageEdges };
    Camera::look_at(from, at, DVec3::Y, p).unwrap()
}

/// A map of `w`×`w/2` texels whose radiance at direction `d` is `f(d)`.
fn map(w: u32, f: impl Fn(DVec3) -> DVec3) -> Environment {
    let probe = Environment::from_rgb("probe", 4, 2, &[0.0; 24], DVec3::Y, DVec3::X).unwrap();
    let h = w / 2;
    let mut rgb = Vec::with_capacity((3 * w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let c = f(probe.direction((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64));
            rgb.extend([c.x as f32, c.y as f32, c.z as f32]);
        }
    }
    Environment::from_rgb("test", w, h, &rgb, DVec3::Y, DVec3::X).unwrap()
}

/// The GPU's and the CPU's renders of `scene`.
fn both(scene: &Scene, opts: &RenderOptions) -> [(&'static str, Rendered); 2] {
    let g = renderer().render(scene, opts, &hidden()).unwrap_or_else(|e| panic!("GPU: {e}"));
    let c = reference::render(scene, opts, &hidden()).unwrap_or_else(|e| panic!("CPU: {e}"));
    [("GPU", g), ("CPU", c)]
}

fn id_at(img: &Image, x: u32, y: u32) -> Option<u32> {
    let v = img.get(x, y)[0];
    (v >= 0.0).then_some(v as u32)
}

/// A mirror sphere (mirror weight 1, nothing else) under a uniform environment of radiance
/// L, with no lights standing in for it: every pixel, background and sphere alike, is L, on
/// both backends, bit for bit.
#[test]
fn a_mirror_sphere_under_a_uniform_environment_is_the_background() {
    let l = DVec3::new(0.25, 0.5, 0.75);
    let mirror = Material { kd: 0.0, mirror: DVec3::ONE, ..Material::default() };
    let ball =
        Primitive::Sphere(Sphere { center: DVec3::ZERO, radius: 1.0, inside_only: false, material: 0 });
    let mut s = scene(look(DVec3::new(0.0, 1.0, 4.0), DVec3::ZERO, 40.0), vec![mirror], vec![ball]);
    s.set_environment(Some(map(64, |_| l)), 0);
    assert!(s.lights.is_empty());
    let opts = RenderOptions::new(48, 48);
    for (backend, r) in both(&s, &opts) {
        assert!(r.stats.rays.eye_hit > 300 && r.stats.rays.reflect > 300, "{backend}: {:?}", r.stats.rays);
        let want = [l.x as f32, l.y as f32, l.z as f32, 1.0];
        for (i, p) in r.image.pixels.iter().enumerate() {
            assert_eq!(*p, want, "{backend}: pixel {i}");
        }
    }
}

/// A white diffuse plane (kd 1) under the median-cut lights of a uniform environment of
/// radiance L shows L: the lights above it carry the upper hemisphere's power πL·2, over π
/// (`scene::environment`). Each light shines its region's whole power from one direction, so
/// the cosine of a wide region's light overstates the region's mean cosine: with the default
/// 16 lights the plane comes out 8.9 % too bright (8.4 % in closed form for its regions of
/// π/4 sr: docs/scenes.md), with 64 2.8 %, with 256 0.9 %.
#[test]
fn a_white_plane_under_the_lights_of_a_uniform_environment_has_its_radiance() {
    let l = 0.6;
    let white = Material { kd: 1.0, color: DVec3::ONE, ..Material::default() };
    let s = 20.0;
    let quad = [
        Triangle::new([DVec3::new(-s, 0.0, -s), DVec3::new(-s, 0.0, s), DVec3::new(s, 0.0, s)], 0),
        Triangle::new([DVec3::new(-s, 0.0, -s), DVec3::new(s, 0.0, s), DVec3::new(s, 0.0, -s)], 0),
    ];
    let prims = quad.into_iter().map(Primitive::Triangle).collect();
    let base = scene(look(DVec3::new(0.0, 3.0, 0.5), DVec3::ZERO, 30.0), vec![white], prims);
    let opts = RenderOptions::new(24, 24);
    for (k, tolerance) in [(16, 0.09), (64, 0.03), (256, 0.01)] {
        let mut sc = base.clone();
        sc.set_environment(Some(map(128, |_| DVec3::splat(l))), k);
        for (backend, r) in both(&sc, &opts) {
            let (mut lo, mut hi) = (f64::MAX, 0.0f64);
            for p in &r.image.pixels {
                lo = lo.min(p[0] as f64);
                hi = hi.max(p[0] as f64);
            }
            eprintln!("{k} lights, {backend}: the plane shows {lo:.4}..{hi:.4} under a sky of {l}");
            assert!(
                (lo / l - 1.0).abs() < tolerance && (hi / l - 1.0).abs() < tolerance,
                "{k}, {backend}: {lo}..{hi}"
            );
        }
    }
}

/// A sun: a disc of angular radius 2° and radiance 5000 in a sky of 0.2, in direction `sun`.
fn sun_sky(sun: DVec3) -> Environment {
    let sun = sun.normalize();
    map(1024, |d| if d.dot(sun) > 2f64.to_radians().cos() { DVec3::splat(5000.0) } else { DVec3::splat(0.2) })
}

/// Median cut puts lights on a sun: the brightest lights of a sky with a sun lie within the
/// sun's disc, and they carry most of the map's power.
#[test]
fn a_sun_gets_lights_within_its_disc() {
    let sun = DVec3::new(0.5, 0.8, -0.3).normalize();
    let env = sun_sky(sun);
    let lights = env.lights(16);
    let power = |l: &cuberay::scene::Light| l.color.x * PI;
    let total: f64 = lights.iter().map(power).sum();
    let on_sun: Vec<_> =
        lights.iter().filter(|l| (-l.direction).angle_between(sun) < 2.5f64.to_radians()).collect();
    let sun_power: f64 = on_sun.iter().map(|l| power(l)).sum();
    eprintln!(
        "{} of {} lights on the sun, {:.3} of the power",
        on_sun.len(),
        lights.len(),
        sun_power / total
    );
    assert!(on_sun.len() >= 2 && sun_power > 0.8 * total, "{} lights, {sun_power} of {total}", on_sun.len());
    assert!((total - env.power().x).abs() < 1e-9 * total);
}

/// A ball above a plane under a sky with a sun casts its shadow where the sun's direction
/// puts it: the plane is dark at the point the ray from the ball's centre away from the sun
/// meets it, and lit as far again to the other side, on both backends.
#[test]
fn a_ball_under_a_sun_casts_its_shadow_along_the_suns_direction() {
    let sun = DVec3::new(-0.6, 0.7, 0.3).normalize();
    let white = Material { kd: 1.0, color: DVec3::ONE, ..Material::default() };
    let s = 30.0;
    let mut prims: Vec<Primitive> = [
        [DVec3::new(-s, 0.0, -s), DVec3::new(-s, 0.0, s), DVec3::new(s, 0.0, s)],
        [DVec3::new(-s, 0.0, -s), DVec3::new(s, 0.0, s), DVec3::new(s, 0.0, -s)],
    ]
    .into_iter()
    .map(|p| Primitive::Triangle(Triangle::new(p, 0)))
    .collect();
    let centre = DVec3::new(0.0, 1.5, 0.0);
    prims.push(Primitive::Sphere(Sphere { center: centre, radius: 0.7, inside_only: false, material: 0 }));
    // Where the shadow's centre falls, and a point as far on the sun's side.
    let shadow = centre - sun * (centre.y / sun.y);
    let lit = centre + (centre - shadow).with_y(0.0) - DVec3::Y * centre.y;
    let mut sc = scene(
        look(DVec3::new(0.0, 9.0, 6.0), DVec3::new(shadow.x * 0.5, 0.0, shadow.z * 0.5), 55.0),
        vec![white],
        prims,
    );
    sc.set_environment(Some(sun_sky(sun)), 16);
    let (w, h) = (64, 48);
    let opts = RenderOptions::new(w, h);
    let pixel = |p: DVec3| {
        // The pixel whose centre ray passes nearest p.
        let mut best = (0, 0, f64::MAX);
        for y in 0..h {
            for x in 0..w {
                let (o, d) = sc.camera.ray(x as f64 + 0.5, y as f64 + 0.5, w, h);
                let v = p - o;
                let miss = (v - d * v.dot(d)).length();
                if miss < best.2 {
                    best = (x, y, miss);
                }
            }
        }
        (best.0, best.1)
    };
    let (sx, sy) = pixel(shadow);
    let (lx, ly) = pixel(lit);
    for (backend, r) in both(&sc, &opts) {
        let (dark, bright) = (r.image.get(sx, sy)[0], r.image.get(lx, ly)[0]);
        eprintln!("{backend}: the plane in the shadow {dark:.3}, in the sun {bright:.3}");
        assert!(
            dark < 0.25 * bright,
            "{backend}: shadow {dark} at ({sx}, {sy}), sunlit {bright} at ({lx}, {ly})"
        );
    }
}

/// `--look-at` puts its point at the image's centre: a small ball there is what the centre
/// pixel's ray hits, from several `--look-from` points, on both backends.
#[test]
fn the_camera_flags_put_the_look_at_point_at_the_centre() {
    let p = DVec3::new(1.5, -0.5, 2.0);
    let grey = Material { kd: 0.8, ..Material::default() };
    let prims = vec![
        Primitive::Sphere(Sphere { center: p, radius: 0.05, inside_only: false, material: 0 }),
        Primitive::Sphere(Sphere { center: DVec3::ZERO, radius: 1.0, inside_only: false, material: 0 }),
    ];
    let base = scene(look(DVec3::new(0.0, 0.0, 6.0), DVec3::ZERO, 40.0), vec![grey], prims);
    for from in [DVec3::new(6.0, 1.0, 4.0), DVec3::new(-3.0, 4.0, 7.0), DVec3::new(1.5, 5.0, 2.5)] {
        let mut s = base.clone();
        let o = ViewOverride {
            from: Some(from),
            at: Some(p),
            fov_degrees: Some(10.0),
            ..ViewOverride::default()
        };
        s.camera = s.camera.overridden(&o, s.up).unwrap();
        let opts = RenderOptions::new(33, 33);
        let g = renderer().render_aov(&s, &opts, Aov::Id, &hidden()).unwrap();
        let c = reference::render_aov(
            &s,
            &RenderOptions { accel: Accel::Bvh, ..opts.clone() },
            Aov::Id,
            &hidden(),
        )
        .unwrap();
        for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
            assert_eq!(id_at(img, 16, 16), Some(0), "{backend}: from {from}");
            // The ball is a few pixels wide: the pixels 4 away see past it.
            assert_ne!(id_at(img, 16, 11), Some(0), "{backend}: from {from}");
        }
    }
}

/// Writes a `w`×`h` Radiance .hdr of one radiance `c` to `path`.
fn write_hdr(path: &Path, w: u32, h: u32, c: [f32; 3]) {
    let pixels = vec![image::Rgb(c); (w * h) as usize];
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    image::codecs::hdr::HdrEncoder::new(f).encode(&pixels, w as usize, h as usize).unwrap();
}

/// `--env FILE` reads an .hdr map into the scene (its texels what the file says) and the
/// default and given settings apply: glTF without lights gets the studio, `--env none` the
/// headlight, NFF keeps its lights and gets the map's besides.
#[test]
fn env_files_and_defaults_set_the_scene_up() {
    let dir = tempfile::tempdir().unwrap();
    let hdr = dir.path().join("sky.hdr");
    write_hdr(&hdr, 64, 32, [0.5, 0.25, 1.0]);
    let gltf = crate::common::shared("gltf/Box/Box.gltf");
    let setup = |env: EnvChoice| Setup { env, ..Setup::default() };
    let loaded = |path: &Path, s: &Setup| {
        let mut l = load::load(path, &Default::default()).unwrap();
        load::apply_setup(&mut l, path, s).map(|_| l)
    };
    let studio = loaded(&gltf, &Setup::default()).unwrap();
    assert_eq!(studio.scene.environment.as_ref().unwrap().name, "studio");
    assert_eq!(studio.scene.lights.len(), 16);
    let none = loaded(&gltf, &setup(EnvChoice::None)).unwrap();
    assert!(none.scene.environment.is_none() && none.scene.lights.len() == 1);
    let file =
        loaded(&gltf, &Setup { env_lights: 4, env_intensity: 2.0, ..setup(EnvChoice::File(hdr.clone())) })
            .unwrap();
    let env = file.scene.environment.as_ref().unwrap();
    assert_eq!((env.name.as_str(), env.width, env.height, env.intensity), ("sky.hdr", 64, 32, 2.0));
    assert_eq!(env.radiance(DVec3::new(0.3, 0.2, 0.9)), DVec3::new(1.0, 0.5, 2.0));
    assert_eq!(file.scene.lights.len(), 4);
    let nff = crate::common::shared("spd/nff/balls_s1.nff");
    let plain = loaded(&nff, &Setup::default()).unwrap();
    assert!(plain.scene.environment.is_none() && plain.scene.lights.len() == 3);
    let lit = loaded(&nff, &setup(EnvChoice::File(hdr))).unwrap();
    assert_eq!(lit.scene.lights.len(), 3 + 16);
    assert_eq!(lit.scene.environment.as_ref().unwrap().up, DVec3::Z, "an NFF scene's up is its viewpoint's");
}

/// A file without lights gets its default headlight at the eye the render looks from: with
/// `--look-from`, the new eye (and the warning names it), not the file's.
#[test]
fn the_default_headlight_follows_look_from() {
    let dir = tempfile::tempdir().unwrap();
    let nff = dir.path().join("unlit.nff");
    std::fs::write(&nff, "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\nf 1 1 1 1 0 0 0 0\ns 0 0 0 1\n")
        .unwrap();
    let from = DVec3::new(3.0, 4.0, 5.0);
    let setup =
        Setup { view: ViewOverride { from: Some(from), ..ViewOverride::default() }, ..Setup::default() };
    let mut l = load::load(&nff, &Default::default()).unwrap();
    assert_eq!(l.scene.lights[0].position, DVec3::new(0.0, 0.0, 5.0));
    load::apply_setup(&mut l, &nff, &setup).unwrap();
    assert_eq!(l.scene.lights.len(), 1);
    assert_eq!((l.scene.lights[0].position, l.scene.lights[0].intensity), (from, 1.0));
    let said: Vec<_> = l.warnings.iter().filter(|w| w.contains("headlight")).collect();
    assert!(said.len() == 1 && said[0].contains(&from.to_string()), "{said:?}");
}

/// The repository's `scenes/sky.hdr` (written by `scenes/make_sky.py`) loads as the 512×256
/// map the script describes, and median cut finds the sun where the script puts it (u = 0.68,
/// 35° above the horizon, in the documented convention): several of the 16 lights lie
/// within 3° of it (its 1.5° disc and the texels around it), carrying much of the power.
#[test]
fn the_repositorys_sky_map_puts_its_sun_where_its_script_says() {
    let sky = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sky.hdr");
    let gltf = crate::common::shared("gltf/Box/Box.gltf");
    let mut l = load::load(&gltf, &Default::default()).unwrap();
    load::apply_setup(&mut l, &gltf, &Setup { env: EnvChoice::File(sky), ..Setup::default() }).unwrap();
    let env = l.scene.environment.as_ref().unwrap();
    assert_eq!((env.width, env.height), (512, 256));
    let (phi, el) = ((0.68f64 - 0.5) * 2.0 * PI, 35f64.to_radians());
    let sun = DVec3::new(el.cos() * phi.cos(), el.sin(), el.cos() * phi.sin());
    let luminance = |c: DVec3| c.dot(DVec3::new(0.2126, 0.7152, 0.0722));
    let total: f64 = l.scene.lights.iter().map(|li| luminance(li.color)).sum();
    let near: Vec<_> =
        l.scene.lights.iter().filter(|li| (-li.direction).angle_between(sun) < 3f64.to_radians()).collect();
    let share = near.iter().map(|li| luminance(li.color)).sum::<f64>() / total;
    eprintln!(
        "sky.hdr: {} of {} lights within 3° of the sun, {share:.3} of the power",
        near.len(),
        l.scene.lights.len()
    );
    assert!(near.len() >= 4 && share > 0.3, "{} lights near the sun, {share} of the power", near.len());
}

/// Bad maps get an `error:` naming the file before anything renders, and write nothing:
/// unreadable, not an image, not equirectangular, NaN, Inf and negative texels, and a header
/// claiming an absurd size.
#[test]
fn bad_environment_maps_are_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_hdr(&d.join("square.hdr"), 32, 32, [1.0; 3]);
    std::fs::write(d.join("text.hdr"), "not an image at all").unwrap();
    std::fs::write(d.join("huge.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 200000 +X 400000\n")
        .unwrap();
    let exr = |name: &str, v: f32| {
        let img = image::Rgb32FImage::from_pixel(16, 8, image::Rgb([1.0, 1.0, 1.0]));
        let mut img = img;
        img.put_pixel(3, 5, image::Rgb([1.0, v, 1.0]));
        image::DynamicImage::ImageRgb32F(img).save(d.join(name)).unwrap();
    };
    exr("nan.exr", f32::NAN);
    exr("inf.exr", f32::INFINITY);
    exr("negative.exr", -2.0);
    let cases = [
        ("missing.hdr", "missing.hdr"),
        ("text.hdr", "not an .hdr or .exr"),
        ("square.hdr", "twice as wide"),
        ("huge.hdr", "huge.hdr"),
        ("nan.exr", "texel (3, 5)"),
        ("inf.exr", "texel (3, 5)"),
        ("negative.exr", "texel (3, 5)"),
    ];
    for (file, says) in cases {
        let out = d.join("out.png");
        let st = cuberay()
            .args(["render", "--width", "8", "--height", "8", "--env"])
            .arg(d.join(file))
            .arg("-o")
            .arg(&out)
            .arg(crate::common::shared("gltf/Box/Box.gltf"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&st.stderr);
        eprintln!("{file}: {}", err.lines().last().unwrap_or(""));
        assert_eq!(st.status.code(), Some(1), "{file}: {err}");
        assert!(err.contains("error:") && err.contains(file) && err.contains(says), "{file}: {err}");
        assert!(!err.contains("panicked"), "{file}: {err}");
        assert!(!out.exists(), "{file}: an image was written");
    }
    // An intensity that takes the brightest texel beyond f32 never reaches a kernel as Inf,
    // with or without the lights (whose radiance is checked on its own).
    for lights in ["0", "16"] {
        let out = d.join("out.png");
        let st = cuberay()
            .args(["render", "--width", "8", "--height", "8", "--env", "studio", "--env-intensity", "1e300"])
            .args(["--env-lights", lights, "-o"])
            .arg(&out)
            .arg(crate::common::shared("gltf/Box/Box.gltf"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&st.stderr);
        assert_eq!(st.status.code(), Some(1), "{lights} lights: {err}");
        assert!(err.contains("error:") && err.contains("beyond f32"), "{lights} lights: {err}");
        assert!(!out.exists(), "{lights} lights: an image was written");
    }
}

/// The studio and map lookups exist only in kernels whose scene has an environment.
#[test]
fn only_a_scene_with_an_environment_compiles_its_lookup() {
    use cuberay::gpu::shaders::{compose, Accel, Kernel, Variant};
    let with = compose(Kernel::Nearest, Variant::full(Accel::Cube)).unwrap();
    let full = Variant::full(Accel::Cube);
    let dark = cuberay::scene::Effects { environment: false, ..full.effects };
    let without = compose(Kernel::Nearest, Variant { effects: dark, ..full }).unwrap();
    assert!(with.contains("fn environment(") && !without.contains("fn environment("));
    assert!(!without.contains("env_texel("));
}
