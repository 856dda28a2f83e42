//! `cuberay accuracy`: the sweep measures what it claims. Quick sweeps (64×64, at most 8
//! samples per pixel) on small scenes, each against its CPU f64 reference:
//!
//! - the rows that must not change the image (table resolution, accelerator) render it
//!   byte for byte like the base;
//! - more samples lower the error; f64 lowers the hit-distance error where f32 is at its
//!   limits (a grazing sphere);
//! - spawn offsets below the rounding error show acne (self-hits), the scaled one none, and
//!   a large fixed one changes the image;
//! - the reference is cached and read back equal; the command writes its four files, and
//!   on bad input writes none.

use std::path::Path;

use cuberay::accuracy::{self, Parameter, Reference, Row, Settings};
use cuberay::load;
use cuberay::scene::Scene;
use indicatif::ProgressBar;

use crate::common::{cuberay, hard, renderer, shared};

fn load(path: &Path) -> Scene {
    load::load(path, &Default::default()).unwrap_or_else(|e| panic!("{}: {e}", path.display())).scene
}

/// A quick sweep of `params` over the scene at `path`, with its reference cached in a
/// fresh folder.
fn sweep(path: &Path, params: &[Parameter]) -> (Vec<Row>, Reference) {
    let scene = load(path);
    let settings = Settings::new(64, 64, true, params.to_vec());
    let dir = tempfile::tempdir().unwrap();
    let cache = accuracy::reference_cache(dir.path(), &std::fs::read(path).unwrap(), &settings);
    let reference = accuracy::reference(&scene, &settings, &cache, &ProgressBar::hidden()).unwrap();
    let rows = accuracy::sweep(renderer(), &scene, &settings, &reference, &ProgressBar::hidden()).unwrap();
    (rows, reference)
}

fn row<'a>(rows: &'a [Row], p: Parameter, value: &str) -> &'a Row {
    rows.iter()
        .find(|r| r.parameter == p && r.value == value)
        .unwrap_or_else(|| panic!("no row {} = {value}", p.name()))
}

#[test]
fn table_resolution_and_accelerator_never_change_the_image() {
    let (rows, _) = sweep(&shared("spd/nff/balls_s1.nff"), &[Parameter::TableResolution, Parameter::Accel]);
    let base = rows.iter().find(|r| r.base).expect("a base row");
    assert_eq!(
        rows.len(),
        7,
        "4 resolutions and 3 accelerators: {:?}",
        rows.iter().map(|r| &r.value).collect::<Vec<_>>()
    );
    for r in &rows {
        assert!(
            r.image.pixels == base.image.pixels,
            "{} = {} renders another image than the base",
            r.parameter.name(),
            r.value
        );
        assert_eq!(r.error, base.error, "{} = {}", r.parameter.name(), r.value);
        assert_eq!(r.self_hits, 0, "{} = {}", r.parameter.name(), r.value);
    }
    // A finer eye table costs more bytes.
    let sizes: Vec<u64> =
        rows.iter().filter(|r| r.parameter == Parameter::TableResolution).map(|r| r.table_bytes).collect();
    assert!(
        sizes.windows(2).all(|w| w[0] <= w[1]) && sizes[0] < sizes[3],
        "table bytes by resolution: {sizes:?}"
    );
    // The reference is another renderer: the base is near it, not equal.
    assert!(
        base.error.flip_mean > 0.0 && base.error.flip_mean < 0.05,
        "base FLIP mean {}",
        base.error.flip_mean
    );
    assert_eq!(base.hits.id_disagreement, 0.0);
}

#[test]
fn more_samples_and_depth_lower_the_error() {
    let (rows, _) = sweep(&shared("spd/nff/balls_s1.nff"), &[Parameter::Spp, Parameter::MaxDepth]);
    let spp: Vec<&Row> = rows.iter().filter(|r| r.parameter == Parameter::Spp).collect();
    assert_eq!(spp.iter().map(|r| r.value.as_str()).collect::<Vec<_>>(), ["1", "2", "4", "8"]);
    let rmse: Vec<f64> = spp.iter().map(|r| r.error.rmse).collect();
    eprintln!("accuracy balls_s1 RMSE by spp 1, 2, 4, 8: {rmse:?}");
    assert!(rmse.windows(2).all(|w| w[1] < w[0]), "RMSE does not fall with the samples: {rmse:?}");
    assert!(rmse[3] < 0.5 * rmse[0], "8 spp is not twice as close as 1: {rmse:?}");
    assert!(spp[3].error.flip_mean < spp[0].error.flip_mean);
    // Depth 1 has no reflections; balls_s1's spheres are mirrors.
    let d1 = row(&rows, Parameter::MaxDepth, "1");
    let d5 = row(&rows, Parameter::MaxDepth, "5");
    assert!(d1.error.rmse > 3.0 * d5.error.rmse, "depth 1 {} vs 5 {}", d1.error.rmse, d5.error.rmse);
}

/// The full `spp` series (1 to 64, not the quick sweep's 1 to 8) at 32², one timed run a row:
/// each doubling of the samples brings the image nearer the reference.
#[test]
fn error_falls_from_1_to_64_spp() {
    let path = shared("spd/nff/balls_s1.nff");
    let scene = load(&path);
    let mut settings = Settings::new(32, 32, false, vec![Parameter::Spp]);
    settings.runs = 1;
    let dir = tempfile::tempdir().unwrap();
    let cache = accuracy::reference_cache(dir.path(), &std::fs::read(&path).unwrap(), &settings);
    let reference = accuracy::reference(&scene, &settings, &cache, &ProgressBar::hidden()).unwrap();
    let rows = accuracy::sweep(renderer(), &scene, &settings, &reference, &ProgressBar::hidden()).unwrap();
    let values: Vec<&str> = rows.iter().map(|r| r.value.as_str()).collect();
    assert_eq!(values, ["1", "2", "4", "8", "16", "32", "64"]);
    let rmse: Vec<f64> = rows.iter().map(|r| r.error.rmse).collect();
    eprintln!("accuracy balls_s1 32² RMSE by spp 1…64: {rmse:?}");
    assert!(rmse.windows(2).all(|w| w[1] < w[0]), "RMSE does not fall with the samples: {rmse:?}");
    assert!(rmse[6] < 0.25 * rmse[0], "64 spp is not four times as close as 1: {rmse:?}");
    assert!(rows[6].error.flip_mean < rows[0].error.flip_mean);
}

#[test]
fn f64_removes_the_grazing_errors_of_f32() {
    assert!(
        renderer().ctx.f64,
        "the adapter has no SHADER_F64: the precision rows need it (lavapipe has it)"
    );
    let (rows, _) = sweep(&hard("grazing_sphere.nff"), &[Parameter::Precision]);
    let (f32_, f64_) = (row(&rows, Parameter::Precision, "f32"), row(&rows, Parameter::Precision, "f64"));
    eprintln!(
        "accuracy grazing_sphere: ids differ f32 {} f64 {}, max Δt/size f32 {:e} f64 {:e}",
        f32_.hits.id_disagreement, f64_.hits.id_disagreement, f32_.hits.max_t_error, f64_.hits.max_t_error
    );
    assert!(f64_.hits.id_disagreement <= f32_.hits.id_disagreement);
    assert!(
        f64_.hits.max_t_error < 0.1 * f32_.hits.max_t_error,
        "f64 {:e} vs f32 {:e}",
        f64_.hits.max_t_error,
        f32_.hits.max_t_error
    );
    assert!(f64_.error.flip_mean <= f32_.error.flip_mean);
}

#[test]
fn small_offsets_show_acne_and_a_large_one_changes_the_image() {
    let (rows, _) = sweep(&hard("self_intersection.nff"), &[Parameter::Offset]);
    let show: Vec<_> =
        rows.iter().map(|r| (r.value.as_str(), r.self_hits, r.blocked_share, r.error.flip_mean)).collect();
    eprintln!("accuracy self_intersection (value, self-hits, blocked, FLIP): {show:?}");
    let scaled = row(&rows, Parameter::Offset, "scaled");
    assert!(scaled.base);
    assert_eq!(scaled.self_hits, 0);
    for tiny in ["rel 2^-24", "fixed 1e-8·size"] {
        assert!(row(&rows, Parameter::Offset, tiny).self_hits > 0, "{tiny} shows no acne");
    }
    let large = row(&rows, Parameter::Offset, "fixed 1e-2·size");
    assert!(
        large.error.flip_mean > 2.0 * scaled.error.flip_mean,
        "{} vs {}",
        large.error.flip_mean,
        scaled.error.flip_mean
    );
    assert!((large.blocked_share - scaled.blocked_share).abs() > 0.005);
}

#[test]
fn the_reference_is_cached_and_read_back_equal() {
    let path = hard("tiny_sphere.nff");
    let scene = load(&path);
    let settings = Settings::new(64, 64, true, vec![Parameter::Spp]);
    let dir = tempfile::tempdir().unwrap();
    let cache = accuracy::reference_cache(dir.path(), &std::fs::read(&path).unwrap(), &settings);
    let a = accuracy::reference(&scene, &settings, &cache, &ProgressBar::hidden()).unwrap();
    let b = accuracy::reference(&scene, &settings, &cache, &ProgressBar::hidden()).unwrap();
    assert!(!a.cached && b.cached);
    assert_eq!((a.image, a.id, a.depth), (b.image, b.id, b.depth));
    // Another scene file is another cache.
    let other = accuracy::reference_cache(dir.path(), b"# another scene", &settings);
    assert_ne!(cache, other);
}

#[test]
fn the_command_writes_its_four_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = cuberay()
        .args(["accuracy", "--quick", "--params", "spp,accel", "--out-dir"])
        .arg(dir.path())
        .arg(hard("tiny_sphere.nff"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("| spp | 4 (base)") && text.contains("equal time"), "{text}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("accuracy.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 4 + 3);
    assert!(json["rows"][0]["flip_mean"].as_f64().unwrap() > 0.0);
    let csv = std::fs::read_to_string(dir.path().join("accuracy.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 7);
    let png = image::open(dir.path().join("accuracy.png")).unwrap();
    assert_eq!((png.width(), png.height()), accuracy::plot::SIZE);
    let svg = std::fs::read_to_string(dir.path().join("accuracy.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("Pareto"));
}

/// Runs `cuberay accuracy` with `args` in a fresh folder: it must fail, say `expect`, and
/// leave no results.
fn fails(args: &[&str], expect: &str) {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("out");
    let out =
        cuberay().arg("accuracy").arg("--quick").arg("--out-dir").arg(&out_dir).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} succeeded");
    assert!(err.contains(expect), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    for f in ["accuracy.json", "accuracy.csv", "accuracy.png", "accuracy.svg"] {
        assert!(!out_dir.join(f).exists(), "{args:?} left {f}");
    }
}

#[test]
fn bad_input_is_refused_and_writes_nothing() {
    let scene = hard("tiny_sphere.nff");
    let scene = scene.to_str().unwrap();
    fails(&["--params", "spp,colour", scene], "invalid value 'colour'");
    fails(&["--params", "", scene], "a value is required for '--params");
    fails(&["--runs", "0", scene], "--runs must be at least 1");
    fails(&["--threshold", "NaN", scene], "--threshold NaN");
    let bad = tempfile::Builder::new().suffix(".nff").tempfile().unwrap();
    std::fs::write(
        bad.path(),
        "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0.1\nresolution 8 8\ns 0 0\n",
    )
    .unwrap();
    fails(&[bad.path().to_str().unwrap()], "cannot load the scene");
    // An --out-dir under a file cannot be made: refused before anything is rendered.
    let file = tempfile::NamedTempFile::new().unwrap();
    let out = cuberay()
        .args(["accuracy", "--quick", "--out-dir"])
        .arg(file.path().join("out"))
        .arg(scene)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("cannot create --out-dir"), "{err}");
    assert!(!err.contains("reference"), "it rendered before checking the folder: {err}");
}
