//! The command line as a user meets it: `info` on real scenes, errors on bad input.

use crate::common::{cuberay, renderer, shared};

fn info_json(path: &std::path::Path) -> serde_json::Value {
    let out = cuberay().arg("info").arg("--json").arg(path).output().unwrap();
    assert!(
        out.status.success(),
        "info failed on {}: {}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("info --json prints one JSON object")
}

#[test]
fn info_json_on_an_spd_scene() {
    let v = info_json(&shared("spd/nff/balls_s1.nff"));
    // balls_s1: 10 spheres, one ground polygon (a quad: two triangles), three lights.
    assert_eq!(v["spheres"], 10);
    assert_eq!(v["triangles"], 2);
    assert_eq!(v["cylinders"], 0);
    assert_eq!(v["lights"], 3);
    assert_eq!(v["materials"], 2);
    let effects: Vec<&str> = v["effects"].as_array().unwrap().iter().map(|e| e.as_str().unwrap()).collect();
    assert_eq!(effects, ["shadows", "reflection"]);
    // The ground quad spans ±12 in x and y at z = -0.5; the spheres stay above it.
    let b = &v["bounds"];
    assert_eq!(b[0][0], -12.0);
    assert_eq!(b[1][1], 12.0);
    assert_eq!(b[0][2], -0.5);
}

#[test]
fn info_json_on_a_gltf_scene() {
    let v = info_json(&shared("gltf/Box/Box.gltf"));
    assert_eq!(v["triangles"], 12);
    assert_eq!(v["spheres"], 0);
    // Box has no light: the built-in studio environment lights it (its lights are not the
    // file's), and no headlight.
    assert_eq!(v["lights"], 0);
    assert_eq!(v["default_light"], false);
    assert_eq!(v["environment"]["name"], "studio");
    assert_eq!(v["environment"]["lights"], 16);
    // With --env none, the default headlight instead.
    let out = cuberay()
        .args(["info", "--json", "--env", "none"])
        .arg(shared("gltf/Box/Box.gltf"))
        .output()
        .unwrap();
    let none: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((none["default_light"].as_bool(), none["environment"].is_null()), (Some(true), true));
    let b = &v["bounds"];
    for axis in 0..3 {
        let (lo, hi) = (b[0][axis].as_f64().unwrap(), b[1][axis].as_f64().unwrap());
        assert!((lo + 0.5).abs() < 1e-6 && (hi - 0.5).abs() < 1e-6, "axis {axis}: {lo}..{hi}");
    }
}

#[test]
fn info_text_names_the_effects() {
    let out = cuberay().arg("info").arg(shared("spd/nff/balls_s1.nff")).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("effects:    shadows, reflection"), "{text}");
}

#[test]
fn bad_input_exits_non_zero_with_file_and_line() {
    let dir = std::env::temp_dir().join(format!("cuberay-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.nff");
    std::fs::write(&bad, "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 8 8\nq 1 2 3\n")
        .unwrap();
    let out = cuberay().arg("info").arg(&bad).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("bad.nff:8"), "the error names file and line: {err}");
    assert!(!err.contains("panicked"), "{err}");

    let out = cuberay().arg("info").arg(dir.join("missing.nff")).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("missing.nff"), "the error names the file: {err}");
    assert_eq!(err.matches("No such file").count(), 1, "the cause is said once: {err}");
    let out = cuberay().arg("info").arg(dir.join("scene.obj")).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown scene format"));
    std::fs::remove_dir_all(&dir).ok();
}

/// What a user of `render` and `compare` expects at the edges: one of `--width` and
/// `--height` alone keeps the scene's aspect (the SPD files are square: a copy of tetra_s1
/// at 64×32 is made here), `--camera` on an NFF file is refused rather than ignored, a missing output folder
/// is named as such, and `compare` on a scene that does not load leaves no `--out-dir`.
#[test]
fn size_camera_and_folder_edges() {
    let dir = tempfile::tempdir().unwrap();
    let wide = dir.path().join("wide.nff");
    let text = std::fs::read_to_string(shared("spd/nff/tetra_s1.nff")).unwrap();
    let text: String = text
        .lines()
        .map(|l| if l.starts_with("resolution") { "resolution 64 32" } else { l })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&wide, text).unwrap();
    let size = |args: &[&str]| {
        let out = cuberay()
            .arg("render")
            .arg(&wide)
            .args(args)
            .args(["--stats", "json", "-o"])
            .arg(dir.path().join("out.png"))
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (v["settings"]["size"][0].as_u64().unwrap(), v["settings"]["size"][1].as_u64().unwrap())
    };
    assert_eq!(size(&[]), (64, 32));
    assert_eq!(size(&["--width", "20"]), (20, 10));
    assert_eq!(size(&["--height", "7"]), (14, 7));
    assert_eq!(size(&["--width", "9", "--height", "9"]), (9, 9));

    let out = cuberay()
        .arg("render")
        .arg(&wide)
        .args(["--camera", "1", "-o"])
        .arg(dir.path().join("c.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("--camera 1") && err.contains("NFF"), "{err}");

    let out = cuberay()
        .arg("render")
        .arg(&wide)
        .arg("-o")
        .arg(dir.path().join("nowhere/out.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("nowhere: no such folder"), "{err}");

    let out_dir = dir.path().join("cmp");
    let out = cuberay()
        .arg("compare")
        .arg(dir.path().join("missing.nff"))
        .arg("--out-dir")
        .arg(&out_dir)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(!out_dir.exists(), "a failed compare left --out-dir behind");
}

/// Runs `cuberay render ARGS -o DIR/out.png`, sends `signal` once it has rendered for a
/// while, and checks that it stops within a second with exit status `code` (128 + the
/// signal's number) and leaves the output folder empty: no image, no temporary file.
fn interrupted_render_writes_nothing(signal: &str, code: i32, args: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let mut child = cuberay()
        .arg("render")
        .args(args)
        .arg("-o")
        .arg(dir.path().join("out.png"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(child.try_wait().unwrap().is_none(), "the render ended before the signal: make it longer");
    let start = std::time::Instant::now();
    // The signal is sent with kill(2), not an external `kill`: a minimal system has none.
    let number = match signal {
        "INT" => libc::SIGINT,
        "TERM" => libc::SIGTERM,
        other => panic!("no signal SIG{other} in this test"),
    };
    let pid = libc::pid_t::try_from(child.id()).expect("a pid fits pid_t");
    // SAFETY: kill(2) takes any pid and signal number and touches no memory of ours.
    let sent = unsafe { libc::kill(pid, number) };
    assert_eq!(sent, 0, "kill(2) failed: {}", std::io::Error::last_os_error());
    let out = child.wait_with_output().unwrap();
    let took = start.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("SIG{signal}: stopped after {:.0} ms; {}", took.as_secs_f64() * 1e3, stderr.trim());
    assert!(took.as_secs_f64() < 1.0, "SIG{signal}: the render took {took:?} to stop");
    assert_eq!(out.status.code(), Some(code), "SIG{signal}: {stderr}");
    assert!(stderr.contains("nothing was written"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.is_empty(), "SIG{signal} left files behind: {left:?}");
}

#[test]
fn sigint_stops_a_gpu_render_and_writes_nothing() {
    // balls_s4 at 2048² renders for about 8 s here (tetra_s6, used before, ended in 1.3 s
    // once the kernels grew faster, before the signal was sent).
    let scene = shared("spd/nff/balls_s4.nff");
    let scene = scene.to_str().unwrap();
    // Compile the kernel first: lavapipe compiles at the first dispatch, which no signal
    // interrupts.
    let dir = tempfile::tempdir().unwrap();
    let warm = cuberay()
        .args(["render", scene, "--sampling", "corners", "--width", "8", "--height", "8", "-o"])
        .arg(dir.path().join("warm.png"))
        .output()
        .unwrap();
    assert!(warm.status.success(), "{}", String::from_utf8_lossy(&warm.stderr));
    interrupted_render_writes_nothing(
        "INT",
        130,
        &[scene, "--sampling", "corners", "--width", "2048", "--height", "2048"],
    );
}

#[test]
fn sigterm_stops_a_cpu_render_and_writes_nothing() {
    let scene = shared("spd/nff/balls_s4.nff");
    let args = [
        scene.to_str().unwrap(),
        "--backend",
        "cpu",
        "--accel",
        "brute",
        "--width",
        "512",
        "--height",
        "512",
    ];
    interrupted_render_writes_nothing("TERM", 143, &args);
}

/// The first render of a kernel on a machine says on stderr that the kernel is being compiled
/// (lavapipe on Mesa 25.0 takes about 6 s over the four kernels); after that a headless GPU
/// render prints nothing on stderr, even where XDG_RUNTIME_DIR is unset (Mesa's device-selection layer made
/// libwayland complain about it on every run).
#[test]
fn a_first_compile_is_announced_once_and_a_headless_render_is_otherwise_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    // Mesa keeps its own cache where it was, so that only cuberay's marker is new.
    let home_cache = std::env::var_os("HOME").map(|h| std::path::Path::new(&h).join(".cache"));
    let mesa_cache = std::env::var_os("XDG_CACHE_HOME").map(Into::into).or(home_cache).unwrap();
    let render = |name: &str| {
        let out = cuberay()
            .args(["render", "--width", "16", "--height", "12", "-o"])
            .arg(dir.path().join(name))
            .env("XDG_CACHE_HOME", &cache)
            .env("MESA_SHADER_CACHE_DIR", &mesa_cache)
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("NODEVICE_SELECT")
            .env_remove("RUST_LOG")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{stderr}");
        stderr
    };
    let first = render("first.png");
    assert!(
        first.contains("compiling the nearest, shade, shadow, resolve kernels for")
            && first.lines().count() == 1,
        "stderr of a first render: {first}"
    );
    assert_eq!(render("second.png"), "", "stderr of a later render");
}

/// `cuberay bench` (on the CPU, small): a row per accelerator over the same rays, the BVH's
/// own ratio exactly 1 in every round, the tables' median ratio inside its rounds' range, the
/// rays leaving surfaces tested alike (both trace them with the BVH), and a clear error for
/// no timed runs.
#[test]
fn bench_prints_a_row_per_accelerator_with_ratios_taken_round_by_round() {
    let scene = shared("spd/nff/balls_s1.nff");
    let small = ["--backend", "cpu", "--accel", "cube,bvh", "--width", "24", "--height", "24"];
    let out =
        cuberay().arg("bench").args(small).args(["--runs", "3", "--json"]).arg(&scene).output().unwrap();
    assert!(out.status.success(), "bench failed: {}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("bench --json prints one JSON object");
    assert_eq!(v["runs"], 3);
    assert_eq!(v["max_depth"], 5);
    let rows = v["rows"].as_array().unwrap();
    let accels: Vec<&str> = rows.iter().map(|r| r["accel"].as_str().unwrap()).collect();
    assert_eq!(accels, ["cube", "bvh"]);
    let (cube, bvh) = (&rows[0], &rows[1]);
    for r in rows {
        assert_eq!(r["scene"], "balls_s1");
        assert_eq!(r["backend"], "cpu");
        assert!(r["kernel_s"].as_f64().unwrap() > 0.0, "{r}");
        // 25² corner rays at least, and the same ray trees under both.
        assert!(r["rays"].as_u64().unwrap() >= 25 * 25, "{r}");
        assert!(r["longest_dispatch_s"].is_null(), "no dispatches on the CPU: {r}");
        assert!(r["load_s"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["surface_shade_share"].is_null(), "no kernels on the CPU: {r}");
    }
    assert_eq!(cube["rays"], bvh["rays"]);
    assert_eq!(cube["tests_per_ray"]["reflect"], bvh["tests_per_ray"]["reflect"]);
    assert_eq!(bvh["ratio_to_bvh"].as_f64(), Some(1.0));
    assert_eq!(bvh["ratio_range"], serde_json::json!([1.0, 1.0]));
    let ratio = cube["ratio_to_bvh"].as_f64().unwrap();
    let range = cube["ratio_range"].as_array().unwrap();
    let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
    assert!(0.0 < lo && lo <= ratio && ratio <= hi, "{cube}");

    let out = cuberay().arg("bench").args(small).args(["--runs", "1"]).arg(&scene).output().unwrap();
    assert!(out.status.success(), "bench failed: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("median of 1 rounds") && text.contains("| × BVH"), "{text}");
    assert!(
        text.contains("| balls_s1 | cube | cpu |") && text.contains("| balls_s1 | bvh | cpu |"),
        "{text}"
    );

    let out = cuberay().arg("bench").args(small).args(["--runs", "0"]).arg(&scene).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--runs must be at least 1"));
}

/// `cuberay bench` on the GPU: the per-depth kernel times add up to the depths' figures,
/// and `shade`'s share of the depths past the eye's is a share.
#[test]
fn bench_on_the_gpu_splits_the_kernel_time_by_depth() {
    let _ = renderer(); // fails with how to install lavapipe where there is no adapter
    let scene = shared("spd/nff/balls_s1.nff");
    let args = ["--backend", "gpu", "--accel", "cube", "--width", "32", "--height", "32", "--runs", "1"];
    let out = cuberay().arg("bench").args(args).arg("--json").arg(&scene).output().unwrap();
    assert!(out.status.success(), "bench failed: {}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let r = &v["rows"][0];
    let depths: Vec<f64> =
        r["depth_kernel_s"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    assert_eq!(depths.len(), 5, "{r}");
    let later: f64 = depths[1..].iter().sum();
    assert!((r["surface_depths_s"].as_f64().unwrap() - later).abs() <= 1e-12 * later.max(1.0), "{r}");
    let share = r["surface_shade_share"].as_f64().unwrap();
    assert!(0.0 < share && share < 1.0, "{r}");
    assert!(r["surface_ray_us"].as_f64().unwrap() > 0.0 && r["eye_ray_us"].as_f64().unwrap() > 0.0, "{r}");
}
