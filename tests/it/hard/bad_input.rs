//! Hard cases of bad input: degenerate triangles (10), NaN and Inf in every input field of
//! NFF and glTF (11).

use crate::common::{hard, renderer};
use cuberay::arith::geometry::{make_ray, Prim32};
use cuberay::arith::FAR;
use cuberay::job::RenderOptions;
use cuberay::load::{self};
use cuberay::output::Aov;
use cuberay::reference;
use glam::DVec3;

use super::{hidden, load_case, run, run_file};

// ---------------------------------------------------------------------------------------------
// 10. Degenerate triangles

/// Six triangles without area are dropped with one warning naming the first one's line; the
/// four good ones and the tiny well-shaped one are kept (the GPU gets it as a triangle with
/// repeated vertices, once re-centred on the eye in f32) and render without NaN.
#[test]
fn degenerate_triangles() {
    let loaded = load_case("degenerate_triangles.nff");
    assert_eq!(loaded.scene.counts().triangles, 5, "four good triangles and the tiny one");
    assert!(
        loaded.warnings.iter().any(|w| w.contains("dropped 6 degenerate") && w.contains("line 21")),
        "the loader says what it dropped: {:?}",
        loaded.warnings
    );
    let c = run_file("degenerate_triangles.nff", 0.01, 0);
    assert!(c.gpu.stats.rays.eye_hit > 500);
    // Primitive 1 is the tiny triangle (file order, after the first good one). A ray
    // through its corner, by the kernels' f32 test, misses it without NaN.
    let prims = Prim32::from_scene(&c.scene, c.scene.camera.eye);
    let corner = DVec3::new(0.0, -0.5, 0.0) - c.scene.camera.eye;
    let h = prims[1].intersect(&make_ray(DVec3::ZERO.as_vec3(), corner.as_vec3()), FAR);
    assert!(!h.ok && !h.t.is_nan(), "the f32 test of the tiny triangle: {h:?}");
}

// ---------------------------------------------------------------------------------------------
// 11. NaN and Inf in every input field

/// Every number of `every_field.nff` replaced in turn by nan, inf and -inf: the loader
/// refuses the file, naming it and the line, without panicking; a valid file renders.
#[test]
fn nan_and_inf_in_every_input_field() {
    let path = hard("every_field.nff");
    let text = std::fs::read_to_string(&path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut refused = 0;
    for (ln, line) in text.lines().enumerate() {
        if line.starts_with('#') {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        for (k, word) in words.iter().enumerate() {
            if word.parse::<f64>().is_err() {
                continue;
            }
            for bad in ["nan", "inf", "-inf"] {
                let mut w = words.clone();
                w[k] = bad;
                let edited: String = text
                    .lines()
                    .enumerate()
                    .map(|(i, l)| if i == ln { w.join(" ") } else { l.to_string() } + "\n")
                    .collect();
                let p = dir.path().join("every_field.nff");
                std::fs::write(&p, &edited).unwrap();
                let err = match load::load(&p, &Default::default()) {
                    Ok(_) => panic!("line {}: `{}` with {bad} accepted", ln + 1, w.join(" ")),
                    Err(e) => format!("{e}"),
                };
                assert!(
                    err.contains(&format!("every_field.nff:{}:", ln + 1)),
                    "line {} with {bad}: the message names neither file nor line: {err}",
                    ln + 1
                );
                refused += 1;
            }
        }
    }
    eprintln!("hard-case every_field: {refused} edited files refused, each naming its line");
    assert!(refused > 100);
    let c = run_file("every_field.nff", 0.01, 2);
    assert!(c.gpu.stats.rays.shadow > 0);
}

/// glTF: NaN or Inf in positions and in the camera are refused; NaN, Inf and zero normals
/// become the triangle's geometric normal, as the normal AOV shows on both backends.
#[test]
fn nan_and_inf_in_gltf_fields() {
    for (file, words) in [
        ("bad/nan_position.gltf", &["POSITION", "not finite"][..]),
        ("bad/inf_position.gltf", &["POSITION", "not finite"]),
        ("bad/inf_camera.gltf", &["JSON", "number out of range at line"]),
    ] {
        let p = hard(file);
        let err = format!(
            "{}",
            load::load(&p, &Default::default()).err().unwrap_or_else(|| panic!("{file} loaded"))
        );
        assert!(err.contains(p.file_name().unwrap().to_str().unwrap()), "{file}: {err}");
        for w in words {
            assert!(err.contains(w), "{file}: `{w}` missing from: {err}");
        }
    }
    // From the command line: a non-zero exit, the message, and no image file.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.png");
    let st = crate::common::cuberay()
        .arg("render")
        .arg(hard("bad/nan_position.gltf"))
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&st.stderr);
    assert!(!st.status.success() && stderr.contains("position 1 is not finite"), "{stderr}");
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none(), "a refused render left a file");

    let loaded = load_case("bad_normals.gltf");
    assert!(loaded.warnings.iter().any(|w| w.contains("normals")), "{:?}", loaded.warnings);
    let scene = loaded.scene;
    let opts = RenderOptions::new(32, 32);
    for (backend, img) in [
        ("GPU", renderer().render_aov(&scene, &opts, Aov::Normal, &hidden()).unwrap().image),
        ("CPU", reference::render_aov(&scene, &opts, Aov::Normal, &hidden()).unwrap().image),
    ] {
        assert!(img.is_finite(), "{backend}: a non-finite normal");
        for p in img.pixels.iter().filter(|p| p[3] > 0.0) {
            let n = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            assert!((n.length() - 1.0).abs() < 1e-3 && n.z.abs() > 0.999, "{backend}: normal {n}");
        }
    }
    run("bad_normals.gltf", scene, opts, 0.01, 0);
}
