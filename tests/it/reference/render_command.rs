//! The `render` command: images and statistics written, nothing written by a failed render,
//! PNG transfers by scene format.

use std::path::{Path, PathBuf};

use crate::common::cuberay;

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
