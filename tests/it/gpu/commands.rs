//! `render` and `compare` from the command line, on the GPU.

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
