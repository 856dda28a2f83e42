//! The preview: its progressive session converges to the headless render (no window
//! needed), and the window itself, run under Xvfb with `--frames`/`--screenshot`, shows
//! what `cuberay render` writes for the same samples and seed.

use std::ffi::OsString;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;

use cuberay::gpu::GpuRenderer;
use cuberay::job::{Accel, Precision, RenderOptions};
use cuberay::load;
use cuberay::preview::controls::Controller;
use cuberay::preview::session::{EyeTable, Session, Toggles};
use cuberay::scene::Camera;
use indicatif::ProgressBar;

use crate::common::cuberay;

fn opts(w: u32, h: u32, spp: u32) -> RenderOptions {
    RenderOptions { spp, seed: 3, ..RenderOptions::new(w, h) }
}

fn max_abs(a: &cuberay::output::Image, b: &cuberay::output::Image) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0, f32::max)
}

/// After N passes the session holds the headless render's N samples; after a camera move
/// (the eye-dependent rebuild) it renders what the headless renderer renders from there. In
/// f32 and with `--precision f64` (whose primitives the rebuild packs in f64 again).
#[test]
fn session_converges_to_the_headless_render() {
    let gpu = Arc::new(GpuRenderer::new().expect("a GPU adapter (run `bash .ci/setup`)"));
    let scene = load::showcase().unwrap().scene;
    for precision in [Precision::F32, Precision::F64] {
        let o = RenderOptions { precision, ..opts(48, 32, 5) };
        let reference = gpu.render(&scene, &o, &ProgressBar::hidden()).unwrap().image;
        let mut s = Session::new(gpu.clone(), scene.clone(), o.clone(), Toggles::default(), o.spp).unwrap();
        s.finish().unwrap();
        assert_eq!(s.passes(), 5);
        let img = s.image().unwrap();
        let d = max_abs(&reference, &img);
        assert!(d < 1e-4, "{precision:?}: session differs from the headless render by {d}");
        // Not trivially equal: something was rendered.
        assert!(img.pixels.iter().any(|p| p[0] > 0.05), "{precision:?}: the image is black");

        // Move the eye: the session restarts and matches a headless render from the new eye.
        let c = &scene.camera;
        let moved =
            Camera::from_basis(c.eye + c.right * 0.7 - c.forward * 0.5, c.forward, c.up, c.projection)
                .unwrap();
        s.set_camera(moved.clone());
        assert_eq!(s.passes(), 0);
        // The move did not wait for the eye's table: the BVH traces meanwhile.
        assert_eq!(s.eye_table(), EyeTable::Building, "{precision:?}");
        let mut there = scene.clone();
        there.camera = moved.clone();
        // A moving camera's frame: a coarse image, one ray per block, that of the pixel at
        // the block's centre in a render with one sample at the pixel centres.
        let (block, depth) = s.trace_coarse().unwrap();
        assert_eq!(depth, o.max_depth, "{precision:?}");
        let coarse = s.coarse_image().unwrap().expect("a coarse image");
        let centres = RenderOptions { spp: 1, ..o.clone() };
        let full = gpu.render(&there, &centres, &ProgressBar::hidden()).unwrap().image;
        let mut worst = 0.0f32;
        for j in 0..coarse.height {
            for i in 0..coarse.width {
                let (x, y) = (i * block + block / 2, j * block + block / 2);
                let (p, q) = (coarse.get(i, j), full.get(x, y));
                worst = (0..3).map(|c| (p[c] - q[c]).abs()).fold(worst, f32::max);
            }
        }
        assert!(worst < 1e-5, "{precision:?}: the coarse image ({block}x{block} blocks) differs by {worst}");
        s.finish().unwrap();
        let reference2 = gpu.render(&there, &o, &ProgressBar::hidden()).unwrap().image;
        let d = max_abs(&reference2, &s.image().unwrap());
        assert!(d < 1e-4, "{precision:?}: after the camera move: differs by {d}");
        // Swapped in between passes, the tables trace the same pixels.
        s.wait_for_eye_table().unwrap();
        assert_eq!(s.eye_table(), EyeTable::Ready, "{precision:?}");
        s.restart();
        s.finish().unwrap();
        let d = max_abs(&reference2, &s.image().unwrap());
        assert!(d < 1e-4, "{precision:?}: with the rebuilt eye table: differs by {d}");
        assert!(max_abs(&reference, &reference2) > 0.05, "{precision:?}: the move changed nothing");
    }
}

/// Moves with every accelerator: with the BVH and brute force the session traces them as
/// it did; with the tables, a move while the eye table is being rebuilt for the previous
/// camera, and one while a rebuilt table waits for a pass boundary, both end with the tables
/// of the last camera. Each converges to the headless render of its last camera: for the
/// showcase, and for a textured, alpha-masked scene (a move packs without the textures,
/// which stay in their buffer).
#[test]
fn moves_with_every_accelerator_end_on_the_headless_render() {
    let masked = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/alpha_mask.gltf");
    let masked = load::load(&masked, &Default::default()).unwrap().scene;
    for scene in [load::showcase().unwrap().scene, masked] {
        moves_end_on_the_headless_render(scene);
    }
}

fn moves_end_on_the_headless_render(scene: cuberay::scene::Scene) {
    let gpu = Arc::new(GpuRenderer::new().expect("a GPU adapter (run `bash .ci/setup`)"));
    let c = scene.camera.clone();
    let step = |k: f64| {
        Camera::from_basis(c.eye + c.right * (0.3 * k) - c.forward * 0.2, c.forward, c.up, c.projection)
            .unwrap()
    };
    for accel in [Accel::Bvh, Accel::Brute, Accel::Cube] {
        let o = RenderOptions { accel, ..opts(32, 24, 2) };
        let mut s = Session::new(gpu.clone(), scene.clone(), o.clone(), Toggles::default(), o.spp).unwrap();
        s.set_camera(step(1.0));
        s.trace_coarse().unwrap();
        // Resting: the eye table's rebuild starts (tables) while the passes run.
        s.finish().unwrap();
        s.set_camera(step(2.0));
        s.finish().unwrap();
        if accel == Accel::Cube {
            // A rebuilt table waiting for its pass boundary when the camera moves again.
            s.wait_for_eye_table().unwrap();
            s.set_camera(step(3.0));
            s.wait_for_eye_table().unwrap();
            assert_eq!(s.eye_table(), EyeTable::Ready);
        } else {
            s.set_camera(step(3.0));
            assert_eq!(s.eye_table(), EyeTable::None);
        }
        s.restart();
        s.finish().unwrap();
        let mut there = scene.clone();
        there.camera = step(3.0);
        let want = gpu.render(&there, &o, &ProgressBar::hidden()).unwrap().image;
        let d = max_abs(&want, &s.image().unwrap());
        assert!(d < 1e-4, "{accel:?}: differs from the headless render by {d}");
        assert!(want.pixels.iter().any(|p| p[0] > 0.5 || p[2] > 0.5), "{accel:?}: an empty picture");
    }
}

/// Effects switched off render as the headless renderer does without them.
#[test]
fn session_toggles_and_depth_restart_and_change_the_picture() {
    let gpu = Arc::new(GpuRenderer::new().expect("a GPU adapter (run `bash .ci/setup`)"));
    let scene = load::showcase().unwrap().scene;
    let o = opts(32, 24, 1);
    let mut s = Session::new(gpu.clone(), scene.clone(), o.clone(), Toggles::default(), 1).unwrap();
    s.finish().unwrap();
    let all = s.image().unwrap();
    s.set_effects(Toggles { shadows: false, ..Toggles::default() }, 5).unwrap();
    assert_eq!(s.passes(), 0);
    s.finish().unwrap();
    let unshadowed = s.image().unwrap();
    assert!(max_abs(&all, &unshadowed) > 0.05, "turning shadows off changed nothing");
    // Depth 1 is the same as no reflection at all.
    s.set_effects(Toggles::default(), 1).unwrap();
    s.finish().unwrap();
    let depth1 = s.image().unwrap();
    s.set_effects(Toggles { reflection: false, ..Toggles::default() }, 5).unwrap();
    s.finish().unwrap();
    assert!(max_abs(&depth1, &s.image().unwrap()) < 1e-6);
    assert!(max_abs(&all, &depth1) > 0.05, "the showcase has mirrors and glass");
}

/// An Xvfb server on a display number it picks itself (`-displayfd`), killed on drop.
pub struct Xvfb {
    child: Child,
    pub display: String,
}

impl Xvfb {
    pub fn start() -> Xvfb {
        let mut child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "640x480x24", "-nolisten", "tcp"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| {
                panic!(
                    "cannot start Xvfb ({e}): the preview test needs a virtual X display. \
                     Install it with `bash .ci/setup` (Debian package xvfb)"
                )
            });
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let n = line.trim();
        assert!(
            !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()),
            "Xvfb did not report a display: {line:?}"
        );
        Xvfb { display: format!(":{n}"), child }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Runs `cuberay preview ARGS` on Xvfb display `x` (its runtime folder `dir`) and asserts it
/// succeeded without a panic.
fn run_preview(x: &Xvfb, dir: &Path, args: &[OsString]) {
    let out = cuberay()
        .arg("preview")
        .args(args)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "preview failed: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

fn rgb8(path: &Path) -> image::RgbImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).into_rgb8()
}

#[test]
fn preview_window_matches_the_headless_render() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("preview.png");
    let reference = dir.path().join("render.png");
    let size = ["--width", "64", "--height", "48", "--seed", "11"];
    let mut args: Vec<OsString> =
        size.iter().chain(&["--frames", "3", "--screenshot"]).map(|a| a.into()).collect();
    args.push(shot.clone().into());
    run_preview(&x, dir.path(), &args);
    let out = cuberay().arg("render").args(size).args(["--spp", "3", "-o"]).arg(&reference).output().unwrap();
    assert!(out.status.success(), "render failed: {}", String::from_utf8_lossy(&out.stderr));

    let (a, b) = (rgb8(&reference), rgb8(&shot));
    assert_eq!(a.dimensions(), (64, 48));
    assert_eq!(b.dimensions(), (64, 48));
    let fa = nv_flip::FlipImageRgb8::with_data(64, 48, a.as_raw());
    let fb = nv_flip::FlipImageRgb8::with_data(64, 48, b.as_raw());
    let map = nv_flip::flip(fa, fb, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mean = nv_flip::FlipPool::from_image(&map).mean();
    assert!(mean <= 0.02, "FLIP mean {mean} between the preview and the headless render");
    // The showcase is not one flat colour: the comparison means something.
    let first = b.get_pixel(0, 0);
    assert!(b.pixels().any(|p| p != first), "the screenshot is uniform");
}

/// A scripted orbit (`--orbit 3 --orbit-frames 5`) under Xvfb: the frame log has one line
/// per frame with its fields, the orbit's frames say they moved, the eye's table ends
/// "ready", and after the camera rests the screenshot after 3 frames is the headless render
/// of the final camera at 3 spp, byte for byte.
#[test]
fn a_scripted_orbit_logs_its_frames_and_ends_on_the_headless_render() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().unwrap();
    let (shot, log, reference) =
        (dir.path().join("orbit.png"), dir.path().join("frames.jsonl"), dir.path().join("render.png"));
    let (w, h, spp, seed, degrees, turns) = (64u32, 48u32, 3u32, 11u64, 3.0, 5u32);
    let args: Vec<OsString> = [
        ("--width", w.to_string()),
        ("--height", h.to_string()),
        ("--seed", seed.to_string()),
        ("--orbit", degrees.to_string()),
        ("--orbit-frames", turns.to_string()),
        ("--frames", spp.to_string()),
    ]
    .into_iter()
    .flat_map(|(flag, value)| [flag.into(), value.into()])
    .chain([OsString::from("--frame-log"), log.clone().into(), "--screenshot".into(), shot.clone().into()])
    .collect();
    run_preview(&x, dir.path(), &args);

    let lines: Vec<serde_json::Value> = std::fs::read_to_string(&log)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect();
    assert!(lines.len() > turns as usize, "{} frames logged", lines.len());
    for (i, l) in lines.iter().enumerate() {
        assert_eq!(l["frame"], i as u64, "{l}");
        assert!(l["ms"].as_f64().is_some_and(|ms| ms > 0.0), "{l}");
        for key in ["block", "points_traced", "passes", "depth"] {
            assert!(l[key].is_u64(), "{key} in {l}");
        }
        let moved = (1..=turns as usize).contains(&i);
        assert_eq!(l["moved"], moved, "{l}");
        let table = l["eye_table"].as_str().unwrap();
        assert!(["building", "ready"].contains(&table), "{l}");
        if moved {
            // A moving frame traces a whole coarse image of its camera.
            let b = l["block"].as_u64().unwrap() as u32;
            assert!(b >= 2, "{l}");
            assert_eq!(l["points_traced"], (w.div_ceil(b) * h.div_ceil(b)) as u64, "{l}");
        }
    }
    assert_eq!(lines[0]["eye_table"], "ready");
    assert_eq!(lines.last().unwrap()["eye_table"], "ready", "the eye table is swapped in after the orbit");
    assert_eq!(lines.last().unwrap()["passes"], spp);

    // The camera the orbit ends at, rendered headlessly.
    let mut scene = load::showcase().unwrap().scene;
    let mut controller = Controller::new(&scene);
    for _ in 0..turns {
        controller.orbit_degrees(degrees);
    }
    scene.camera = controller.camera().clone();
    let gpu = GpuRenderer::new().expect("a GPU adapter (run `bash .ci/setup`)");
    let o = RenderOptions { spp, seed, ..RenderOptions::new(w, h) };
    let img = gpu.render(&scene, &o, &ProgressBar::hidden()).unwrap().image;
    cuberay::output::write(&img, &reference).unwrap();
    let (a, b) = (rgb8(&reference), rgb8(&shot));
    assert_eq!(a.dimensions(), b.dimensions());
    let differ = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    assert_eq!(
        differ, 0,
        "the screenshot differs from the headless render of the final camera at {differ} pixels"
    );
    let first = b.get_pixel(0, 0);
    assert!(b.pixels().any(|p| p != first), "the screenshot is uniform");
}

#[test]
fn preview_without_a_display_says_how_to_render_headlessly() {
    let out = cuberay()
        .args(["preview", "--width", "16", "--height", "16"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("cuberay render"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn preview_rejects_more_frames_than_samples() {
    let out = cuberay().args(["preview", "--spp", "2", "--frames", "3"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--frames 3"));
}
