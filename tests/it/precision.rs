//! `--precision auto`: the rule of `cuberay::arith::precision` pinned from both sides on
//! scenes whose ratios are known in closed form, on the hard cases, and on every shared
//! scene (none of which may switch to f64). The renders that prove f64 is right where the
//! rule picks it are the hard cases' own (`hard::scale::contact_on_huge_geometry`, which
//! renders with no flag).

use std::path::Path;

use cuberay::arith::precision::{f32_need, F32Need, CONTACT_LIMIT, OWN_LIMIT};
use cuberay::job::{Precision, RenderOptions};
use cuberay::load::{self, LoadOptions};
use cuberay::scene::Scene;

use crate::common::{cuberay, hard, shared_scenes};

fn nff(text: &str) -> Scene {
    load::nff::parse(text, Path::new("test.nff")).expect("the test scene parses").scene
}

/// The need of `scene` at `height` pixels, printed.
fn need(what: &str, scene: &Scene, height: u32) -> F32Need {
    let n = f32_need(scene, height);
    eprintln!("{what}: {} ({})", if n.needs_f64() { "f64" } else { "f32" }, n.reason());
    n
}

/// A unit ball resting on a ground sphere of radius `r` (touching at the origin), seen
/// from 3 units away.
fn ball_on_ground_sphere(r: f64) -> Scene {
    nff(&format!(
        "v\nfrom 0.4 -3 0.5\nat 0 0 0.15\nup 0 0 1\nangle 40\nhither 0.01\nresolution 128 96\n\
         l 6 3 3.5\nf 0.8 0.8 0.7 0.9 0 1 0 1\ns 0 0 {} {r}\ns 0 0 1 1\n",
        -r
    ))
}

/// On a ground sphere of radius R, f32's offset is 2⁻²¹·2R, which is 2⁻²⁰·R of the unit
/// ball touching it: f64 from R = 2¹³ (8192) on. R = 2¹² and 2¹⁴ fall on either side, the
/// ground's own size never decides, and the ratio is the closed form's.
#[test]
fn a_ball_on_a_ground_sphere_switches_at_the_contact_limit() {
    for (r, f64_wanted) in [(100.0, false), (4096.0, false), (16384.0, true), (1e5, true)] {
        let n = need(&format!("unit ball on a ground of radius {r}"), &ball_on_ground_sphere(r), 96);
        assert_eq!(n.needs_f64(), f64_wanted, "radius {r}: {}", n.reason());
        if r >= 4096.0 {
            assert!(n.exact, "radius {r}: the contact must be found, not bounded");
            assert_eq!((n.offset_prim, n.feature_prim), (Some(0), Some(1)), "radius {r}");
            assert_eq!(n.limit, CONTACT_LIMIT);
            let want = r / 1_048_576.0;
            assert!((n.ratio / want - 1.0).abs() < 1e-3, "radius {r}: ratio {} against {want}", n.ratio);
        }
    }
}

/// The same ball on a flat ground of two triangles as wide as the ground sphere: the
/// triangles' offset is 2⁻²¹ of their largest coordinate, so f64 from half-width 2¹⁴ on.
#[test]
fn a_ball_on_a_huge_flat_ground_needs_f64_and_on_a_small_one_does_not() {
    for (s, f64_wanted) in [(1000.0, false), (1e5, true)] {
        let scene = nff(&format!(
            "v\nfrom 0.4 -3 0.5\nat 0 0 0.15\nup 0 0 1\nangle 40\nhither 0.01\nresolution 128 96\n\
             l 6 3 3.5\nf 0.8 0.8 0.7 0.9 0 1 0 1\np 4\n{0} {0} 0\n{1} {0} 0\n{1} {1} 0\n{0} {1} 0\ns 0 0 1 1\n",
            -s, s
        ));
        let n = need(&format!("unit ball on a ground of half-width {s}"), &scene, 96);
        assert_eq!(n.needs_f64(), f64_wanted, "half-width {s}: {}", n.reason());
    }
}

/// A lone sphere of radius r one unit from the eye, seen through a view narrow enough
/// that a pixel is smaller than it: its own offset is 2⁻²¹ of its magnitude (1 + r), so
/// f64 from r ≈ 2⁻²¹ / 2⁻⁴ = 2⁻¹⁷ (7.6·10⁻⁶) down; seen through a wide view, the same
/// sphere is smaller than a pixel and stays in f32 whatever its size.
#[test]
fn a_tiny_sphere_needs_f64_only_below_its_own_limit_and_when_the_image_resolves_it() {
    let tiny = |r: f64, angle: f64| {
        nff(&format!(
            "v\nfrom 0 -1 0\nat 0 0 0\nup 0 0 1\nangle {angle}\nhither 1e-6\nresolution 512 512\n\
             l -3 -4 5\nf 0.9 0.6 0.2 0.9 0.1 20 0 1\ns 0 0 0 {r}\n"
        ))
    };
    for (r, f64_wanted) in [(3e-5, false), (1.5e-5, false), (3.8e-6, true), (1e-6, true)] {
        let n = need(&format!("sphere of radius {r}, 0.001 degrees"), &tiny(r, 0.001), 512);
        assert_eq!(n.needs_f64(), f64_wanted, "radius {r}: {}", n.reason());
        assert_eq!(n.limit, OWN_LIMIT, "radius {r}");
    }
    let n = need("sphere of radius 1e-6, 40 degrees", &tiny(1e-6, 40.0), 512);
    assert!(!n.needs_f64(), "a sphere under a pixel asks for nothing: {}", n.reason());
}

/// A sliver triangle (altitude 10⁻⁹ of its length) among ordinary ones asks for no f64: the
/// image cannot show its width, so its feature is the pixel's footprint.
#[test]
fn a_sliver_triangle_in_a_mesh_keeps_f32() {
    let scene = nff("v\nfrom 0 -5 1\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0.01\nresolution 256 256\n\
         l 6 3 3.5\nf 0.8 0.8 0.7 0.9 0 1 0 1\n\
         p 3\n-1 0 0\n1 0 0\n0 0 1\np 3\n-1 0 0\n1 0 0\n0 0 -1\np 3\n-1 0 0\n1 0 0\n0 0 1e-9\n");
    let n = need("a sliver among two triangles", &scene, 256);
    assert!(!n.needs_f64() && n.margin > 20.0, "{}", n.reason());
    assert!(n.feature > 1e-3, "the sliver's feature is the pixel's footprint: {}", n.reason());
}

/// The hard cases: the ball on ground spheres of radius 10⁵ (`huge_contact`, the same 10⁵
/// from the origin, `huge_sphere`) switch to f64; every other hard case keeps f32, the tiny
/// spheres by a margin of 6.5 on their own size.
#[test]
fn the_hard_cases_that_f32_gets_wrong_switch_and_the_others_do_not() {
    let want_f64 = ["huge_contact.nff", "huge_contact_1e5.nff", "huge_sphere.nff"];
    let mut seen = 0;
    for entry in std::fs::read_dir(hard("")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "nff") {
            continue;
        }
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let scene = load::load(&path, &LoadOptions::default()).unwrap().scene;
        let (_, h) = scene.resolution.expect("hard cases give their resolution");
        let opts = cuberay::gpu::resolve(&scene, &RenderOptions::new(1, h), None).unwrap();
        let n = opts.auto_precision.clone().expect("auto resolves");
        eprintln!("{name}: {} ({})", opts.precision.name(), n.reason());
        let wanted = if want_f64.contains(&name.as_str()) { Precision::F64 } else { Precision::F32 };
        assert_eq!(opts.precision, wanted, "{name}: {}", n.reason());
        if name == "tiny_sphere.nff" {
            assert!(n.margin > 4.0 && n.margin < 10.0, "{name}: margin {}", n.margin);
        }
        seen += 1;
    }
    assert!(seen >= 20, "only {seen} hard-case scenes");
}

/// Every SPD database and glTF sample model in the shared scenes keeps f32 at its own
/// size, by a margin of at least 5.
#[test]
fn no_shared_scene_switches_to_f64() {
    let root = shared_scenes();
    let mut files = Vec::new();
    for entry in std::fs::read_dir(root.join("spd/nff")).unwrap() {
        files.push(entry.unwrap().path());
    }
    for model in std::fs::read_dir(root.join("gltf")).unwrap() {
        let dir = model.unwrap().path();
        let name = dir.file_name().unwrap().to_string_lossy().to_string();
        files.push(dir.join(format!("{name}.gltf")));
    }
    let mut checked = 0;
    for path in files.iter().filter(|p| p.exists()) {
        let scene = load::load(path, &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
            .scene;
        let (_, h) = scene.resolution.unwrap_or_else(|| scene.camera.default_resolution());
        let n = need(&path.display().to_string(), &scene, h);
        assert!(!n.needs_f64() && n.margin >= 5.0, "{}: {}", path.display(), n.reason());
        checked += 1;
    }
    assert!(checked >= 52, "only {checked} shared scenes were found");
}

/// `info --json` has a top-level "precision", and says why.
#[test]
fn info_says_which_precision_and_why() {
    for (file, want, height) in [("huge_contact.nff", "f64", 96), ("tiny_sphere.nff", "f32", 65)] {
        let out = cuberay().arg("info").arg("--json").arg(hard(file)).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["precision"], want, "{file}");
        let why = &v["precision_auto"];
        assert!(
            why["margin"].as_f64().is_some() && why["reason"].as_str().unwrap().contains("margin"),
            "{why}"
        );
        assert_eq!(why["height"], height, "{file}: decided at the file's resolution");
        let text = cuberay().arg("info").arg(hard(file)).output().unwrap();
        let text = String::from_utf8_lossy(&text.stdout);
        assert!(text.contains(&format!("precision:  {want} (auto")), "{text}");
    }
}
