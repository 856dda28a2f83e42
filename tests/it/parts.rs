//! Renders split into parts (`--tile`, `--crop`), merged back (`cuberay merge`), and
//! animation frames (`--frames`): a merged image must equal the single render byte for
//! byte and its counts add up to the single render's exactly, on both backends; bad parts
//! get a clear error and no output.
//!
//! GPU tests run on lavapipe in CI and fail with an install hint without an adapter.

use std::path::{Path, PathBuf};

use cuberay::job::{Region, RenderOptions, Rendered};
use cuberay::load;
use cuberay::output::Aov;
use cuberay::part::{self, PartInfo, SceneId};
use cuberay::reference;
use cuberay::sampling::Sampling;
use cuberay::scene::Scene;
use indicatif::ProgressBar;

use crate::common::{cuberay, renderer, shared};

#[derive(Clone, Copy, Debug)]
enum Backend {
    Gpu,
    Cpu,
}

fn render(backend: Backend, scene: &Scene, opts: &RenderOptions, aov: Option<Aov>) -> Rendered {
    let p = ProgressBar::hidden();
    let r = match (backend, aov) {
        (Backend::Gpu, None) => renderer().render(scene, opts, &p),
        (Backend::Gpu, Some(a)) => renderer().render_aov(scene, opts, a, &p),
        (Backend::Cpu, None) => reference::render(scene, opts, &p),
        (Backend::Cpu, Some(a)) => reference::render_aov(scene, opts, a, &p),
    };
    r.unwrap_or_else(|e| panic!("{backend:?} render failed: {e}"))
}

/// Renders `windows` of the image as parts through the EXR files `cuberay merge` reads,
/// merges them, and checks the result against the whole render: every pixel bit for bit,
/// every count exactly.
fn check_split(
    name: &str,
    backend: Backend,
    scene: &Scene,
    opts: &RenderOptions,
    aov: Option<Aov>,
    windows: &[Region],
) {
    let whole = render(backend, scene, opts, aov);
    let dir = tempfile::tempdir().unwrap();
    let id = SceneId::of(name, name.as_bytes(), None);
    let aov_name = aov.map(|a| format!("{a:?}").to_lowercase());
    let parts: Vec<part::Part> = windows
        .iter()
        .enumerate()
        .map(|(k, w)| {
            let o = RenderOptions { region: Some(*w), ..opts.clone() };
            let r = render(backend, scene, &o, aov);
            assert_eq!((r.image.width, r.image.height), (w.width(), w.height()), "{name}: part {w}");
            let path = dir.path().join(format!("part{k}.exr"));
            part::write_part(
                &r.image,
                &PartInfo::new(id.clone(), &r.stats, aov_name.clone(), &format!("{backend:?}")),
                &path,
            )
            .unwrap();
            part::read_part(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
        })
        .collect();
    let merged = part::merge(&parts).unwrap_or_else(|e| panic!("{name}: {e}"));
    let (a, b) = (&whole.image, &merged.image);
    assert_eq!((a.width, a.height, a.has_alpha), (b.width, b.height, b.has_alpha));
    if let Some(i) =
        (0..a.pixels.len()).find(|&i| a.pixels[i].map(f32::to_bits) != b.pixels[i].map(f32::to_bits))
    {
        panic!(
            "{name} ({backend:?}): merged pixel ({}, {}) is {:?}, the whole render's {:?}",
            i as u32 % a.width,
            i as u32 / a.width,
            b.pixels[i],
            a.pixels[i]
        );
    }
    assert_eq!(merged.stats.rays, whole.stats.rays, "{name} ({backend:?}): rays");
    assert_eq!(merged.stats.tests, whole.stats.tests, "{name} ({backend:?}): tests");
    assert_eq!(merged.stats.settings, whole.stats.settings, "{name} ({backend:?}): settings");
    assert_eq!(merged.stats.effects, whole.stats.effects);
}

fn bands(n: u32, w: u32, h: u32) -> Vec<Region> {
    (0..n).map(|i| Region::band(i, n, w, h).unwrap()).collect()
}

/// A 2×2 split at an uneven point, so that parts meet in both directions.
fn quarters(w: u32, h: u32) -> Vec<Region> {
    let (x, y) = (w * 3 / 7, h * 4 / 9);
    vec![
        Region { x0: 0, y0: 0, x1: x, y1: y },
        Region { x0: x, y0: 0, x1: w, y1: y },
        Region { x0: 0, y0: y, x1: x, y1: h },
        Region { x0: x, y0: y, x1: w, y1: h },
    ]
}

fn spd(name: &str) -> Scene {
    load::load(&shared(&format!("spd/nff/{name}.nff")), &Default::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .scene
}

/// The seven SPD kinds, at size 1, with the SPD procedure (corner rays, depth 5): bands and
/// quarters, on both backends.
macro_rules! spd_split_tests {
    ($($test:ident: $scene:literal,)*) => {$(
        #[test]
        fn $test() {
            let scene = spd($scene);
            let (w, h) = (45, 37);
            let opts = RenderOptions { sampling: Sampling::Corners, ..RenderOptions::new(w, h) };
            for backend in [Backend::Gpu, Backend::Cpu] {
                check_split($scene, backend, &scene, &opts, None, &bands(3, w, h));
                check_split($scene, backend, &scene, &opts, None, &quarters(w, h));
            }
        }
    )*};
}

spd_split_tests! {
    balls_parts_equal_the_whole: "balls_s1",
    gears_parts_equal_the_whole: "gears_s1",
    mount_parts_equal_the_whole: "mount_s1",
    rings_parts_equal_the_whole: "rings_s1",
    teapot_parts_equal_the_whole: "teapot_s1",
    tetra_parts_equal_the_whole: "tetra_s1",
    tree_parts_equal_the_whole: "tree_s1",
}

#[test]
fn jittered_samples_and_aovs_split_too() {
    let scene = load::showcase().unwrap().scene;
    let (w, h) = (40, 30);
    let opts = RenderOptions { spp: 3, seed: 7, ..RenderOptions::new(w, h) };
    for backend in [Backend::Gpu, Backend::Cpu] {
        check_split("showcase", backend, &scene, &opts, None, &quarters(w, h));
        check_split("showcase", backend, &scene, &opts, Some(Aov::Depth), &bands(4, w, h));
    }
}

#[test]
fn parts_whose_record_does_not_fit_their_image_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load::showcase().unwrap().scene;
    let opts =
        RenderOptions { region: Some(Region { x0: 0, y0: 0, x1: 8, y1: 4 }), ..RenderOptions::new(8, 8) };
    let r = render(Backend::Cpu, &scene, &opts, None);
    let id = SceneId::of("showcase", b"showcase", None);
    let good = PartInfo::new(id, &r.stats, None, "cpu");
    // A window that reaches past the image (it would wrap into the next row when merged).
    let mut past = good.clone();
    past.settings.window = Some(Region { x0: 4, y0: 0, x1: 12, y1: 4 });
    let path = dir.path().join("past.exr");
    part::write_part(&r.image, &past, &path).unwrap();
    let err = part::read_part(&path).err().expect("a window past the image is refused").to_string();
    assert!(err.contains("not a non-empty part of its 8x8 image"), "{err}");
    // A digest that is not one.
    let mut digest = good.clone();
    digest.scene.sha256 = "short".into();
    part::write_part(&r.image, &digest, &path).unwrap();
    assert!(part::read_part(&path).err().unwrap().to_string().contains("not a SHA-256"));
    // Parts of two renderers are not merged.
    let mut other = good.clone();
    other.renderer = "cuberay 0.0.0 on something else".into();
    other.settings.window = Some(Region { x0: 0, y0: 4, x1: 8, y1: 8 });
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    part::write_part(&r.image, &good, &a).unwrap();
    part::write_part(&r.image, &other, &b).unwrap();
    let parts = [part::read_part(&a).unwrap(), part::read_part(&b).unwrap()];
    let err = part::merge(&parts).err().expect("parts of two renderers").to_string();
    assert!(err.contains("it was rendered by cuberay 0.0.0 on something else"), "{err}");
}

#[test]
fn frames_between_keyframes_follow_the_channels() {
    // scenes/orbit.gltf at t = 0.5 s: the rig has turned 45° of its LINEAR 90°-a-second
    // rotation, and the camera has moved a quarter of the way along its CUBICSPLINE dolly
    // from (0, 1.5, 6) to (0, 1.2, 4.5) with zero tangents: h01(¼) = 0.15625 of it.
    let orbit = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/orbit.gltf");
    let opts = load::LoadOptions { camera: None, time: Some(0.5) };
    let cam = load::load(&orbit, &opts).unwrap().scene.camera;
    let along = 6.0 - 0.15625 * 1.5;
    let height = 1.5 - 0.15625 * 0.3;
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let expect = glam::DVec3::new(along * s, height, along * s);
    assert!((cam.eye - expect).length() < 1e-6, "eye {:?}, expected {expect:?}", cam.eye);
    // The red box (object ids 2 and 3 are its first triangles) turns in STEPs of 30° a
    // second: at 1.5 s it shows the 30° key, at 2 s the 60° one.
    let tri = |t: f64| match &load::load(&orbit, &load::LoadOptions { camera: None, time: Some(t) })
        .unwrap()
        .scene
        .primitives[2]
    {
        cuberay::scene::Primitive::Triangle(tr) => tr.p[0],
        p => panic!("not a triangle: {p:?}"),
    };
    assert_eq!(tri(1.0), tri(1.5), "STEP holds its key until the next");
    assert_ne!(tri(1.5), tri(2.0));
}

#[test]
fn bands_cover_the_rows_once() {
    for (n, h) in [(1, 1), (3, 37), (4, 40), (4, 8), (5, 513)] {
        let b = bands(n, 10, h);
        assert_eq!(b.len(), n as usize);
        assert_eq!(b[0].y0, 0);
        assert_eq!(b.last().unwrap().y1, h);
        for pair in b.windows(2) {
            assert_eq!(pair[0].y1, pair[1].y0, "{n} bands of {h}");
        }
        let rows = h.div_ceil(n);
        assert!(b.iter().all(|w| w.height() <= rows && w.height() > 0), "{n} bands of {h}: {b:?}");
    }
    // More bands than rows, bands of ⌈8/7⌉ = 2 rows of which the last three would be empty,
    // and an index out of range.
    assert!(Region::band(0, 9, 10, 8).is_err());
    let err = Region::band(0, 7, 10, 8).unwrap_err().to_string();
    assert!(err.contains("4 or 8 would not"), "{err}");
    // 6 bands of 10 rows: 2 rows each, band 5 empty; every index is refused.
    assert!((0..6).all(|i| Region::band(i, 6, 10, 10).is_err()));
    assert!(Region::band(3, 3, 10, 8).is_err());
    // 4 bands of 10 rows: 3, 3, 3, 1.
    assert_eq!(Region::band(3, 4, 10, 10).unwrap(), Region { x0: 0, y0: 9, x1: 10, y1: 10 });
}

// ---- The command line: render parts, merge, bad parts. ----

fn run(args: &[&str], dir: &Path) -> std::process::Output {
    cuberay().args(args).current_dir(dir).output().unwrap()
}

fn args(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

fn ok(args: &[&str], dir: &Path) -> String {
    let out = run(args, dir);
    assert!(out.status.success(), "cuberay {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn fails(args: &[&str], dir: &Path, says: &str) {
    let out = run(args, dir);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "cuberay {args:?} should fail");
    assert!(err.contains(says), "cuberay {args:?}: expected {says:?} in: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// The options the command-line renders on the CPU below share.
const CPU_COMMON: [&str; 8] =
    ["--backend", "cpu", "--width", "50", "--height", "41", "--sampling", "corners"];

/// The options the command-line renders on the GPU below share.
const GPU_COMMON: [&str; 6] = ["--width", "50", "--height", "41", "--sampling", "corners"];

/// The arguments of `cuberay render` of `scene` with `common`, then `extra`.
fn render_args(scene: &str, common: &[&str], extra: &[&str]) -> Vec<String> {
    ["render", scene].iter().chain(common.iter()).chain(extra.iter()).map(|s| s.to_string()).collect()
}

#[test]
fn merged_tiles_are_the_render_byte_for_byte_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = shared("spd/nff/rings_s1.nff");
    let scene = scene.to_str().unwrap();
    merge_cpu_tiles(d, scene);
    merge_refuses_bad_parts(d, scene);
    gpu_tiles_read_stored_tables(d, scene);
    render_refuses_bad_tiles_and_crops(d, scene);
}

/// Renders `scene` whole and in three tiles on the CPU (to PNG and EXR, in `d`), merges
/// the tiles in two orders and checks the merged images are the whole render's byte for
/// byte, with its statistics, and that a tile is the EXR of its window.
fn merge_cpu_tiles(d: &Path, scene: &str) {
    let with = |extra: &[&str]| render_args(scene, &CPU_COMMON, extra);
    let whole = with(&["-o", "whole.png", "--stats", "json"]);
    let whole_stats: serde_json::Value = serde_json::from_str(&ok(&args(&whole), d)).unwrap();
    ok(&args(&with(&["-o", "whole.exr"])), d);
    for i in 0..3 {
        let tile = format!("{i}/3");
        let out = format!("t{i}.exr");
        ok(&args(&with(&["--tile", &tile, "-o", &out])), d);
    }
    let merged: serde_json::Value = serde_json::from_str(&ok(
        &["merge", "t0.exr", "t1.exr", "t2.exr", "-o", "merged.png", "--stats", "json"],
        d,
    ))
    .unwrap();
    ok(&["merge", "t2.exr", "t0.exr", "t1.exr", "-o", "merged.exr"], d);
    let read = |f: &str| std::fs::read(d.join(f)).unwrap();
    assert!(read("whole.png") == read("merged.png"), "the merged PNG differs from the whole render's");
    assert!(read("whole.exr") == read("merged.exr"), "the merged EXR differs from the whole render's");
    for key in ["rays", "tests", "settings", "effects"] {
        assert_eq!(merged[key], whole_stats[key], "{key}");
    }
    // The part is an EXR of its window (rows 14..28, ⌈41/3⌉ = 14 a band), placed in the whole
    // image (read_part checks the data and display windows against its record).
    let t1 = part::read_part(&d.join("t1.exr")).unwrap();
    assert_eq!(t1.info.settings.window, Some(Region { x0: 0, y0: 14, x1: 50, y1: 28 }));
    assert_eq!(t1.info.settings.size, [50, 41]);
    assert_eq!((t1.image.width, t1.image.height), (50, 14));
    assert!(t1.info.renderer.contains("CPU reference"), "{}", t1.info.renderer);
}

/// Checks that `cuberay merge` refuses bad parts (a gap, an overlap, other settings, another
/// scene, a whole render, a missing or unreadable file, an unknown output format) with the
/// part's name, and writes nothing. Needs the files of [`merge_cpu_tiles`] in `d`.
fn merge_refuses_bad_parts(d: &Path, scene: &str) {
    // Bad parts: each refused with the part's name, and nothing written.
    let with = |extra: &[&str]| render_args(scene, &CPU_COMMON, extra);
    ok(&args(&with(&["--crop", "0,0,30,14", "-o", "c0.exr"])), d);
    ok(&args(&with(&["--crop", "0,0,50,14", "--max-depth", "2", "-o", "depth2.exr"])), d);
    let other: Vec<String> = ["render", shared("spd/nff/balls_s1.nff").to_str().unwrap()]
        .iter()
        .map(|s| s.to_string())
        .chain(CPU_COMMON.iter().map(|s| s.to_string()))
        .chain(["--tile", "0/3", "-o", "other.exr"].iter().map(|s| s.to_string()))
        .collect();
    ok(&args(&other), d);
    fails(&["merge", "t0.exr", "t1.exr", "-o", "bad.png"], d, "pixel (0, 28) is in none of them");
    fails(&["merge", "t0.exr", "t1.exr", "t2.exr", "c0.exr", "-o", "bad.png"], d, "overlap");
    fails(
        &["merge", "depth2.exr", "t1.exr", "t2.exr", "-o", "bad.png"],
        d,
        "t1.exr: it was rendered with other settings: max_depth 5",
    );
    fails(&["merge", "other.exr", "t1.exr", "t2.exr", "-o", "bad.png"], d, "t1.exr: it shows");
    fails(&["merge", "whole.exr", "-o", "bad.png"], d, "whole.exr: not a cuberay part");
    fails(&["merge", "t0.exr", "t1.exr", "t2.exr", "-o", "bad.jpg"], d, "unknown image format");
    fails(&["merge", "t0.exr", "missing.exr", "-o", "bad.png"], d, "missing.exr: no such file");
    std::fs::write(d.join("junk.exr"), b"not an image").unwrap();
    fails(&["merge", "junk.exr", "-o", "bad.png"], d, "junk.exr: not a readable RGB EXR file");
    assert!(!d.join("bad.png").exists() && !d.join("bad.jpg").exists());
    let leftovers: Vec<PathBuf> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_str().unwrap().starts_with(".cuberay-"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

/// Checks that GPU tiles traced with tables built once merge into the whole GPU render,
/// and that tables built with other options, given to the CPU or not tables at all are
/// refused. Needs `whole.png` of [`merge_cpu_tiles`] in `d`.
fn gpu_tiles_read_stored_tables(d: &Path, scene: &str) {
    // Tables built once and read by the tiles (the GPU backend): the same image, and tables
    // built with other options, or given to the CPU, are refused.
    let with = |extra: &[&str]| render_args(scene, &CPU_COMMON, extra);
    let gpu_with = |extra: &[&str]| render_args(scene, &GPU_COMMON, extra);
    let read = |f: &str| std::fs::read(d.join(f)).unwrap();
    let mut build = vec!["tables", scene];
    build.extend_from_slice(&GPU_COMMON);
    build.extend_from_slice(&["-o", "rings.tables"]);
    ok(&build, d);
    ok(&args(&gpu_with(&["-o", "gpu_whole.png"])), d);
    for i in 0..2 {
        let (tile, out) = (format!("{i}/2"), format!("g{i}.exr"));
        ok(&args(&gpu_with(&["--tables", "rings.tables", "--tile", &tile, "-o", &out])), d);
    }
    ok(&["merge", "g0.exr", "g1.exr", "-o", "gpu_merged.png"], d);
    assert!(read("gpu_whole.png") == read("gpu_merged.png"), "tiles traced with stored tables differ");
    fails(
        &args(&gpu_with(&["--max-depth", "1", "--tables", "rings.tables", "-o", "x.png"])),
        d,
        "another scene or other settings",
    );
    fails(&args(&with(&["--tables", "rings.tables", "-o", "x.png"])), d, "the CPU reference builds its own");
    fails(&args(&gpu_with(&["--tables", "whole.png", "-o", "x.png"])), d, "not a cuberay tables file");
    assert!(!d.join("x.png").exists());
}

/// Checks that `cuberay render` refuses a tile index out of range, more tiles than rows and
/// crops outside the image, empty or malformed, each with its message.
fn render_refuses_bad_tiles_and_crops(d: &Path, scene: &str) {
    // Bad tile and crop options.
    let with = |extra: &[&str]| render_args(scene, &CPU_COMMON, extra);
    fails(&args(&with(&["--tile", "3/3", "-o", "x.exr"])), d, "the tile index must be in 0..3");
    fails(
        &args(&with(&["--tile", "0/50", "-o", "x.exr"])),
        d,
        "would leave the last ones of the 41-row image empty",
    );
    fails(
        &args(&with(&["--crop", "0,0,60,10", "-o", "x.exr"])),
        d,
        "is not a non-empty part of the 50x41 image",
    );
    fails(&args(&with(&["--crop", "5,5,5,9", "-o", "x.exr"])), d, "the window is empty");
    fails(&args(&with(&["--crop", "1,2,3", "-o", "x.exr"])), d, "is not X0,Y0,X1,Y1");
}

#[test]
fn frames_sample_the_animation_one_file_each() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let orbit = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/orbit.gltf");
    let orbit = orbit.to_str().unwrap();
    let size = ["--backend", "cpu", "--width", "40", "--height", "30"];
    let render = |extra: &[&str]| {
        let mut a = vec!["render", orbit];
        a.extend_from_slice(&size);
        a.extend_from_slice(extra);
        ok(&a, d)
    };
    render(&["--frames", "0..2", "--fps", "1", "-o", "f_###.png"]);
    render(&["-o", "rest.png"]);
    render(&["--frames", "2..2", "--fps", "2", "-o", "half.png"]);
    let read = |f: &str| std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    // At t = 0 every channel is at its first keyframe, which is the rest pose.
    assert!(read("f_000.png") == read("rest.png"), "frame 0 is not the rest pose");
    // Frame 2 at 2 fps is t = 1 s, frame 1 at 1 fps: the same pose.
    assert!(read("f_001.png") == read("half_0002.png"), "frames of the same time differ");
    // The camera has turned half a circle by frame 2.
    let differ = |a: &str, b: &str| {
        let (a, b) =
            (image::open(d.join(a)).unwrap().into_rgb8(), image::open(d.join(b)).unwrap().into_rgb8());
        a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
    };
    assert!(differ("f_000.png", "f_002.png") > 40 * 30 / 4, "the animation does not move the camera");
    assert!(!d.join("f_003.png").exists());

    // One frame's tables, on the GPU: the same image as building them in place; another
    // frame's pose has another key.
    let gpu = ["--width", "40", "--height", "30"];
    let mut build = vec!["tables", orbit, "--frame", "2", "--fps", "1", "-o", "f2.tables"];
    build.extend_from_slice(&gpu);
    ok(&build, d);
    let gpu_frame = |extra: &[&str]| {
        let mut a = vec!["render", orbit, "--fps", "1"];
        a.extend_from_slice(&gpu);
        a.extend_from_slice(extra);
        a.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    ok(&args(&gpu_frame(&["--frames", "2..2", "-o", "g_#.exr"])), d);
    ok(&args(&gpu_frame(&["--frames", "2..2", "--tables", "f2.tables", "-o", "s_#.exr"])), d);
    assert!(read("g_2.exr") == read("s_2.exr"), "a frame traced on its stored tables differs");
    fails(
        &args(&gpu_frame(&["--frames", "1..1", "--tables", "f2.tables", "-o", "s_#.exr"])),
        d,
        "another scene or other settings",
    );
    assert!(!d.join("s_1.exr").exists());

    // Frames of a file that has no animation, or is not glTF, are refused.
    let bx = shared("gltf/Box/Box.gltf");
    fails(&["render", bx.to_str().unwrap(), "--frames", "0..1", "-o", "b.png"], d, "has no animations");
    let nff = shared("spd/nff/balls_s1.nff");
    fails(
        &["render", nff.to_str().unwrap(), "--frames", "0..1", "-o", "b.png"],
        d,
        "give a .gltf or .glb scene",
    );
    fails(&["render", orbit, "--frames", "3..1", "-o", "b.png"], d, "the first frame is after the last");
    fails(&["render", orbit, "--frames", "0..1", "--fps", "0", "-o", "b.png"], d, "is not a positive number");
}
