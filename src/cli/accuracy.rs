//! `cuberay accuracy`: sweeps the settings that trade accuracy for time on one scene (see
//! [`cuberay::accuracy`]), prints the table and writes `accuracy.json`, `accuracy.csv`,
//! `accuracy.png` and `accuracy.svg` into `--out-dir`, all only once every row is measured.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::Args;
use serde::Serialize;

use cuberay::accuracy::{self, plot, Parameter, Reference, Row, Settings, Summary};
use cuberay::scene::Scene;

use super::args::{ParameterArg, PrecisionArg};
use cuberay::gpu::GpuRenderer;
use cuberay::output::write_atomically;

use super::render::progress_bar;

#[derive(Args, Debug)]
pub struct AccuracyArgs {
    /// Scene file (.nff, .gltf, .glb).
    pub scene: PathBuf,
    /// Folder for the results and the reference's cache file. Created when missing.
    #[arg(long, default_value = "accuracy")]
    pub out_dir: PathBuf,
    /// Image width (--quick: 64).
    #[arg(long, default_value_t = 256)]
    pub width: u32,
    /// Image height (--quick: 64).
    #[arg(long, default_value_t = 256)]
    pub height: u32,
    /// The parameters to sweep, comma-separated (default: all).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "spp,max-depth,precision,offset,table-resolution,accel"
    )]
    pub params: Vec<ParameterArg>,
    /// Timed runs per row after a warm-up; the median is reported.
    #[arg(long, default_value_t = 3)]
    pub runs: u32,
    /// The FLIP mean the equal-quality summary asks for.
    #[arg(long, default_value_t = 0.01)]
    pub threshold: f64,
    /// 64×64, at most 8 samples per pixel, one timed run: a quick look, not a measurement.
    #[arg(long)]
    pub quick: bool,
    /// glTF: which camera node to look through, counted from 0 in the scene's node order
    /// (default: the first; none: a camera framing the scene).
    #[arg(long)]
    pub camera: Option<usize>,
    /// The base setting's precision (auto: f64 where f32 cannot resolve the scene); the
    /// precision row renders both.
    #[arg(long, value_enum, default_value_t = PrecisionArg::Auto)]
    pub precision: PrecisionArg,
}

#[derive(Serialize)]
struct Report<'a> {
    scene: String,
    adapter: String,
    settings: &'a Settings,
    reference: ReferenceInfo,
    rows: &'a [Row],
    summary: &'a Summary,
}

#[derive(Serialize)]
struct ReferenceInfo {
    renderer: &'static str,
    spp: u32,
    max_depth: u32,
    seconds: f64,
    cache: String,
}

pub fn run(args: AccuracyArgs) -> anyhow::Result<()> {
    check_args(&args)?;
    let loaded = super::load_scene(&args.scene, args.camera, None, &Default::default())?;
    // The folder must take files before minutes of rendering, not after; it is made once the
    // scene has loaded, so that a scene that does not load leaves no folder behind.
    prepare_out_dir(&args.out_dir)?;
    let scene = &loaded.scene;
    let scene_bytes =
        std::fs::read(&args.scene).with_context(|| format!("cannot read {}", args.scene.display()))?;
    let settings = sweep_settings(&args);
    let gpu = GpuRenderer::new()?;
    let adapter = format!("{} ({})", gpu.ctx.info.name, gpu.ctx.info.driver_info);

    let cache = accuracy::reference_cache(&args.out_dir, &scene_bytes, &settings);
    let ref_opts = settings.reference_options();
    let reference = render_reference(scene, &settings, &cache)?;

    let bar = progress_bar("sweep");
    let rows = accuracy::sweep(&gpu, scene, &settings, &reference, &bar)?;
    bar.finish_and_clear();
    let summary = accuracy::summary(&rows, settings.threshold);

    let name = args.scene.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let title = format!("{name}, {}×{}: error against time", settings.width, settings.height);
    let report = Report {
        scene: args.scene.display().to_string(),
        adapter: adapter.clone(),
        settings: &settings,
        reference: ReferenceInfo {
            renderer: "CPU reference, f64",
            spp: ref_opts.spp,
            max_depth: ref_opts.max_depth,
            seconds: reference.seconds,
            cache: cache.display().to_string(),
        },
        rows: &rows,
        summary: &summary,
    };
    write_results(&args.out_dir, &title, &report)?;

    println!(
        "{title} (GPU: {adapter}; reference: CPU f64, {} spp, depth {})\n",
        ref_opts.spp, ref_opts.max_depth
    );
    print!("{}", accuracy::table(&rows, &summary));
    println!(
        "\nwrote accuracy.json, accuracy.csv, accuracy.png and accuracy.svg in {}",
        args.out_dir.display()
    );
    Ok(())
}

/// Ok when the options make a sweep: some parameters, at least one run, a non-negative
/// threshold and a non-empty image; the error names the first option that does not.
fn check_args(args: &AccuracyArgs) -> anyhow::Result<()> {
    if args.params.is_empty() {
        bail!("--params is empty: name at least one of spp, max-depth, precision, offset, table-resolution, accel");
    }
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    if !(args.threshold.is_finite() && args.threshold >= 0.0) {
        bail!("--threshold {} is not a non-negative number", args.threshold);
    }
    if args.width == 0 || args.height == 0 {
        bail!("the image is empty: --width and --height must be at least 1");
    }
    Ok(())
}

/// Ok once `dir` exists (made when missing), is a folder and takes a file; the error says
/// which of these fails.
fn prepare_out_dir(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create --out-dir {}", dir.display()))?;
    if !dir.is_dir() {
        bail!("--out-dir {} is not a folder", dir.display());
    }
    tempfile::tempfile_in(dir).with_context(|| format!("cannot write into --out-dir {}", dir.display()))?;
    Ok(())
}

/// The sweep's settings from the options: the parameters in the order given, each once,
/// and one timed run with --quick.
fn sweep_settings(args: &AccuracyArgs) -> Settings {
    let mut params: Vec<Parameter> = Vec::new();
    for p in args.params.iter().map(|&p| Parameter::from(p)) {
        if !params.contains(&p) {
            params.push(p);
        }
    }
    let mut settings = Settings::new(args.width, args.height, args.quick, params);
    settings.threshold = args.threshold;
    settings.precision = args.precision.into();
    if !args.quick {
        settings.runs = args.runs;
    }
    settings
}

/// The CPU reference for `settings`, read from `cache` or rendered (with a progress bar)
/// and kept there; says on stderr which.
fn render_reference(scene: &Scene, settings: &Settings, cache: &Path) -> anyhow::Result<Reference> {
    let ref_opts = settings.reference_options();
    let bar = progress_bar("reference (CPU, f64)");
    let reference = accuracy::reference(scene, settings, cache, &bar)?;
    bar.finish_and_clear();
    if reference.cached {
        eprintln!("reference: read from {}", cache.display());
    } else {
        eprintln!(
            "reference: {} spp, depth {}, rendered in {:.1} s, kept in {}",
            ref_opts.spp,
            ref_opts.max_depth,
            reference.seconds,
            cache.display()
        );
    }
    Ok(reference)
}

/// Writes `accuracy.json` (the report), `accuracy.csv`, `accuracy.svg` and `accuracy.png`
/// (the plot, titled `title`) into `out_dir`, each whole; everything is drawn and encoded
/// before the first file is written.
fn write_results(out_dir: &Path, title: &str, report: &Report) -> anyhow::Result<()> {
    let (rows, summary) = (report.rows, report.summary);
    let json = serde_json::to_string_pretty(report)?;
    let csv = accuracy::csv(rows);
    let png = plot::png(title, rows, summary)?;
    let svg = plot::svg(title, rows, summary)?;
    let text = |bytes: &[u8], path: &Path| -> anyhow::Result<()> {
        let io = |source| cuberay::Error::Io { path: path.to_owned(), source };
        write_atomically(path, |w| w.write_all(bytes).map_err(io))?;
        Ok(())
    };
    let out = |f: &str| out_dir.join(f);
    text(json.as_bytes(), &out("accuracy.json"))?;
    text(csv.as_bytes(), &out("accuracy.csv"))?;
    text(svg.as_bytes(), &out("accuracy.svg"))?;
    cuberay::output::write_rgb8(png.width(), png.height(), png.into_raw(), &out("accuracy.png"))?;
    Ok(())
}
