//! Every accelerator in every command, on a driver with ray queries (Mesa 25.0's lavapipe
//! in CI, from `target/lavapipe-rq`, as the ray-query tests use it): `render`, `compare`,
//! `bench` and `preview` (under Xvfb) with `cube`, `bvh`, `brute` and `rayquery`, `tables`
//! with `render --tables`, and `accuracy`'s accelerator rows. Where a command writes an
//! image, every accelerator writes the same bytes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common::cuberay;
use crate::preview::Xvfb;
use crate::rayquery::ray_query_driver;

const ACCELS: [&str; 4] = ["cube", "bvh", "brute", "rayquery"];

/// `cuberay ARGS` on the ray-query driver (and on Xvfb display `x`, if any), which must
/// succeed without a panic.
fn run(args: &[&str], x: Option<(&Xvfb, &Path)>) -> Output {
    let (env, vars) = ray_query_driver();
    let mut c: Command = cuberay();
    c.args(args).envs(vars);
    if let Some((x, runtime)) = x {
        c.env("DISPLAY", &x.display).env_remove("WAYLAND_DISPLAY").env("XDG_RUNTIME_DIR", runtime);
    }
    let out = c.output().expect("cuberay runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !stderr.contains("panicked"),
        "cuberay {} (driver variables from {}) failed: {stderr}",
        args.join(" "),
        env.display()
    );
    out
}

fn pixels(path: &Path) -> Vec<u8> {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).into_rgb8().into_raw()
}

fn showcase() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/showcase.nff").display().to_string()
}

#[test]
fn every_accelerator_in_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| -> PathBuf { dir.path().join(name) };
    let s = |p: &PathBuf| p.display().to_string();
    let scene = showcase();
    let size = ["--width", "32", "--height", "24"];
    let x = Xvfb::start();
    let (mut renders, mut previews) = (Vec::new(), Vec::new());
    for accel in ACCELS {
        let png = d(&format!("render-{accel}.png"));
        run(&[&["render", &scene, "-o", &s(&png), "--accel", accel][..], &size].concat(), None);
        renders.push((accel, pixels(&png)));

        let out = d(&format!("compare-{accel}"));
        let out_s = s(&out);
        run(
            &[&["compare", &scene, "--accel", accel, "--out-dir", &out_s, "--json"][..], &size].concat(),
            None,
        );
        renders.push((accel, pixels(&out.join("showcase.gpu.png"))));

        let b = run(
            &["bench", &scene, "--accel", accel, "--width", "16", "--height", "12", "--runs", "1", "--json"],
            None,
        );
        let json: serde_json::Value = serde_json::from_slice(&b.stdout).expect("bench --json prints JSON");
        assert_eq!(json["rows"][0]["accel"], accel, "bench --accel {accel}: {json}");

        let shot = d(&format!("preview-{accel}.png"));
        let shot_s = s(&shot);
        let p = [&["preview", &scene, "--accel", accel, "--frames", "2", "--screenshot", &shot_s][..], &size]
            .concat();
        run(&p, Some((&x, dir.path())));
        previews.push((accel, pixels(&shot)));
    }
    let tables = d("showcase.tables");
    run(&[&["tables", &scene, "-o", &s(&tables)][..], &size].concat(), None);
    let stored = d("render-stored.png");
    run(&[&["render", &scene, "-o", &s(&stored), "--tables", &s(&tables)][..], &size].concat(), None);
    renders.push(("cube, stored tables", pixels(&stored)));

    // The preview's two frames are a 2-sample image: compared among themselves.
    for images in [&renders, &previews] {
        let (name, want) = &images[0];
        for (other, got) in &images[1..] {
            assert!(got == want, "{other} and {name} wrote different pixels");
        }
    }

    let acc = d("accuracy");
    run(&["accuracy", &scene, "--params", "accel", "--quick", "--out-dir", &s(&acc)], None);
    let text: String = std::fs::read_dir(&acc)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
        .map(|e| std::fs::read_to_string(e.path()).unwrap())
        .collect();
    for accel in ACCELS {
        assert!(text.contains(&format!("\"{accel}\"")), "accuracy's accelerator rows lack {accel}: {text}");
    }
}
