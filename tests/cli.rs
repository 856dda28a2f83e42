//! The command line as a user meets it: `info` on real scenes, errors on bad input.

mod common;

use common::{cuberay, shared};

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
    // Box has no light: the default light is used but not counted.
    assert_eq!(v["lights"], 0);
    assert_eq!(v["default_light"], true);
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
    let out = cuberay().arg("info").arg(dir.join("scene.obj")).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown scene format"));
    std::fs::remove_dir_all(&dir).ok();
}
