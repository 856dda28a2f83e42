//! `cuberay bench`: renders a set of scenes with each chosen accelerator and backend, a
//! counted run and a warm-up of each, and then `--runs` uncounted rounds in which every
//! accelerator renders once, in turn, and prints what each costs (medians over the rounds):
//! the time to an image by phase ([`cuberay::phases`]: the GPU's start-up, the scene's load,
//! the build of the tables and the BVH, the upload, the kernels' first compilation, the
//! kernels) and in all, bytes of the acceleration structure, kernel time, rays per second,
//! tests and bound tests per ray by kind, the whole time's and the kernel time's ratios to
//! the BVH's and the kernel time's to the ray queries' (taken within each round, so that a
//! drift of the machine's speed between rounds cancels out; with the rounds' range), and the
//! longest single dispatch. Speed targets are checked with this command, never with timed
//! tests.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;
use serde::Serialize;

use cuberay::gpu::GpuRenderer;
use cuberay::job::{Accel, RenderOptions, Rendered};
use cuberay::layout::MAX_DEPTH;
use cuberay::phases::Phases;
use cuberay::reference;
use cuberay::stats::{Stats, TestsPerRay};

use super::args::{AccelArg, KernelFormArg, PrecisionArg, SamplingArg, SceneArgs, SurfaceWalkArg};
use super::render::progress_bar;

/// The SPD canonical scenes (Haines' sizes of 1987), the default set.
const CANONICAL: [&str; 7] =
    ["balls_s4", "gears_s4", "mount_s6", "rings_s7", "teapot_s12", "tetra_s6", "tree_s11"];

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchBackend {
    Gpu,
    Cpu,
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene files; default: the seven SPD canonical scenes under --spd-dir.
    pub scenes: Vec<PathBuf>,
    /// Where the SPD databases are (`NAME.nff`), for the default set.
    #[arg(long, default_value = "../shared/scenes/spd/nff")]
    pub spd_dir: PathBuf,
    /// Accelerators to compare, comma-separated; the ratio columns need `bvh` and `rayquery`
    /// (GPU, an adapter with ray queries) among them.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "cube,bvh")]
    pub accel: Vec<AccelArg>,
    /// What rays leaving surfaces take under `cube` (auto: ray queries where the adapter has
    /// them, except lavapipe, else the BVH).
    #[arg(long, value_enum, default_value_t = SurfaceWalkArg::Auto)]
    pub surface_walk: SurfaceWalkArg,
    /// How the GPU kernels trace the ray trees (auto: the form measured faster on the
    /// adapter).
    #[arg(long, value_enum, default_value_t = KernelFormArg::Auto)]
    pub kernel_form: KernelFormArg,
    /// Backends, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "gpu")]
    pub backend: Vec<BenchBackend>,
    /// Timed rounds after the warm-up (each accelerator renders once a round); the medians
    /// are reported.
    #[arg(long, default_value_t = 3)]
    pub runs: u32,
    /// Image width and height (the SPD procedure: 512, traced at 513×513 pixel corners).
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Eye-ray placement (default: the SPD procedure's pixel corners).
    #[arg(long, value_enum, default_value_t = SamplingArg::Corners)]
    pub sampling: SamplingArg,
    /// Maximum ray-tree depth (SPD: 5).
    #[arg(long, default_value_t = 5)]
    pub max_depth: u32,
    #[command(flatten)]
    pub scene_args: SceneArgs,
    /// The GPU kernels' precision (auto: f64 where f32 cannot resolve the scene, else f32).
    #[arg(long, value_enum, default_value_t = PrecisionArg::Auto)]
    pub precision: PrecisionArg,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// One scene, accelerator and backend: medians over the timed runs.
#[derive(Serialize, Debug)]
struct Row {
    scene: String,
    accel: String,
    backend: &'static str,
    /// The kernels' precision (`f32` or `f64`; what `--precision auto` chose); the CPU
    /// reference's is always `f64`.
    precision: String,
    /// Seconds to load and validate the scene file (once per scene, before any render).
    load_s: f64,
    preprocess_s: f64,
    /// The time to an image by phase: the GPU's start-up (once per process), the load, then
    /// medians over the timed runs, but for `compile_s`, the kernels' first use (the warm-up
    /// run, which a `render` command pays); `total_s` is their sum.
    phases: Phases,
    /// `phases.total_s` over the BVH's in the same round, the median over the rounds, and
    /// their range.
    whole_ratio_to_bvh: Option<f64>,
    whole_range: Option<(f64, f64)>,
    accel_bytes: u64,
    /// GPU: the kernel time from timestamp queries; CPU: the trace time.
    kernel_s: f64,
    /// Rays, and tests per ray below, as the counted run counted them (the timed runs,
    /// which trace the same rays, do not count).
    rays: u64,
    mrays_per_s: f64,
    tests_per_ray: TestsPerRay,
    bound_tests_per_ray: TestsPerRay,
    /// The median over the rounds of `kernel_s` over the BVH's in the same round (same
    /// scene and backend); `null` without a BVH row.
    ratio_to_bvh: Option<f64>,
    /// The smallest and largest of those ratios: how far one round's ratio may be trusted.
    ratio_range: Option<(f64, f64)>,
    /// The same over `--accel rayquery`'s kernel time (the platform's ray tracing for every
    /// ray); `null` without a `rayquery` row.
    ratio_to_rayquery: Option<f64>,
    rayquery_range: Option<(f64, f64)>,
    /// With `cube` on the GPU, what the rays leaving surfaces took (`bvh` or `rayquery`);
    /// `null` where none left a surface, and for the other accelerators.
    surface_walk: Option<String>,
    /// GPU: how the kernels traced the ray trees (`wavefront` or `tree`); `null` on the CPU.
    kernel_form: Option<String>,
    /// GPU: the longest single dispatch over the timed runs (`null` on the CPU).
    longest_dispatch_s: Option<f64>,
    /// GPU: the kernel time by depth (index depth − 1; nearest, shade and shadow passes of
    /// that depth), medians over the timed runs; empty on the CPU.
    depth_kernel_s: Vec<f64>,
    /// GPU: the kernel time of depths 2 and deeper (the rays leaving surfaces, their
    /// shading and shadows), the median over the timed runs; `null` where no ray left a
    /// surface (a scene without mirrors or glass runs depth 1 only).
    surface_depths_s: Option<f64>,
    /// GPU: the `shade` kernel's share of those depths' time (shading, spawning, the inline
    /// shadow walks): the part a cheaper walk of rays leaving surfaces cannot remove.
    surface_shade_share: Option<f64>,
    /// GPU: microseconds of `nearest` kernel time per eye ray (depth 1) and per ray leaving
    /// a surface (reflection and refraction, depths 2 and deeper): what a walk costs.
    eye_ray_us: Option<f64>,
    surface_ray_us: Option<f64>,
    /// GPU: the lane coherence of the counted run ([`cuberay::stats::LaneStats`]).
    lanes: Option<cuberay::stats::LaneStats>,
}

#[derive(Serialize)]
struct Report<'a> {
    size: [u32; 2],
    sampling: String,
    max_depth: u32,
    runs: u32,
    adapter: Option<String>,
    rows: &'a [Row],
    auto: &'a [AutoCheck],
}

/// `--accel auto`'s cost model ([`cuberay::cost`]) beside what it predicts, for a scene
/// benched with both `cube` and `bvh` on the GPU: the tables' build summed over the origins
/// and the kernel time they save, predicted, and as measured (the `cube` row's tables, the
/// `bvh` row's kernel time less the `cube` row's). What the constants are calibrated on.
#[derive(Serialize, Debug)]
struct AutoCheck {
    scene: String,
    /// What auto chose, and why.
    chose: String,
    predicted_build_s: f64,
    predicted_saved_s: f64,
    measured_build_s: f64,
    measured_saved_s: f64,
}

impl AutoCheck {
    /// The check of `scene` from its GPU rows, if it has a `cube` and a `bvh` row.
    fn of(
        scene: &cuberay::scene::Scene,
        opts: &RenderOptions,
        gpu: &GpuRenderer,
        rows: &[Row],
    ) -> Option<AutoCheck> {
        let row = |a: &str| rows.iter().find(|r| r.backend == "gpu" && r.accel == a);
        let (cube, bvh) = (row("cube")?, row("bvh")?);
        let auto_opts = RenderOptions { accel: Accel::Auto, ..opts.clone() };
        let chosen = cuberay::gpu::choose(scene, &auto_opts, Some(&gpu.caps)).ok()?;
        let auto = chosen.auto_accel?;
        Some(AutoCheck {
            scene: cube.scene.clone(),
            chose: format!("{}: {}", chosen.accel.name(), auto.reason()),
            predicted_build_s: auto.origins.iter().map(|o| o.build_s).sum(),
            predicted_saved_s: auto.origins.iter().map(|o| o.saved_s).sum(),
            measured_build_s: cube.phases.tables_s,
            measured_saved_s: bvh.kernel_s - cube.kernel_s,
        })
    }
}

/// What one timed run cost.
#[derive(Clone, Copy, Debug)]
struct Timed {
    kernel_s: f64,
    preprocess_s: f64,
    phases: Phases,
    longest_dispatch_s: Option<f64>,
    /// Kernel time by depth: all kernels, `nearest` alone and `shade` alone.
    depths: [(f64, f64, f64); MAX_DEPTH as usize],
}

impl Timed {
    fn of(r: &Rendered, backend: BenchBackend) -> Timed {
        let t = &r.stats.time;
        Timed {
            // GPU: the timestamped kernels (the trace time where the adapter has no
            // timestamps); CPU: the trace time.
            kernel_s: match backend {
                BenchBackend::Gpu => t.gpu_s.unwrap_or(t.trace_s),
                BenchBackend::Cpu => t.trace_s,
            },
            preprocess_s: t.preprocess_s,
            phases: match backend {
                BenchBackend::Gpu => t.phases,
                // The reference has no GPU phases: its preprocessing and its trace.
                BenchBackend::Cpu => {
                    Phases { build_s: t.preprocess_s, trace_s: t.trace_s, ..Phases::default() }
                }
            },
            longest_dispatch_s: t.longest_dispatch_s,
            depths: {
                let mut d = [(0.0, 0.0, 0.0); MAX_DEPTH as usize];
                for k in t.gpu_depth_s.iter().flatten() {
                    d[k.depth as usize - 1] = (k.all, k.nearest, k.shade);
                }
                d
            },
        }
    }
}

/// Accelerator `k`'s kernel time over a baseline's (`kernels[base]`: the BVH's, or the ray
/// queries'), round by round (`kernels[a][i]`: accelerator `a` in round `i`); empty without
/// the baseline.
fn round_ratios(kernels: &[Vec<f64>], k: usize, base: Option<usize>) -> Vec<f64> {
    match base {
        Some(b) => kernels[k].iter().zip(&kernels[b]).map(|(t, b)| t / b).collect(),
        None => Vec::new(),
    }
}

/// The median of `ratios` and their range (`None` for none).
fn median_and_range(ratios: &[f64]) -> (Option<f64>, Option<(f64, f64)>) {
    let range = ratios.iter().copied().reduce(f64::min).zip(ratios.iter().copied().reduce(f64::max));
    ((!ratios.is_empty()).then(|| median(ratios.to_vec())), range)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    if args.accel.is_empty() || args.backend.is_empty() {
        bail!("nothing to run: give at least one --accel and one --backend");
    }
    let scenes = scene_paths(&args)?;
    let gpu = if args.backend.contains(&BenchBackend::Gpu) { Some(GpuRenderer::new()?) } else { None };
    let (mut rows, mut checks) = (Vec::new(), Vec::new());
    let progress = progress_bar("bench");
    for path in &scenes {
        let load_start = std::time::Instant::now();
        let loaded = super::load_scene(path, None, None, &args.scene_args.setup())?;
        let load_s = load_start.elapsed().as_secs_f64();
        let name =
            path.file_stem().map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into());
        for &backend in &args.backend {
            let bench =
                Bench { args: &args, gpu: gpu.as_ref(), scene: &loaded.scene, name: &name, backend, load_s };
            let scene_rows = bench.rows(&progress)?;
            if let (BenchBackend::Gpu, Some(g)) = (backend, gpu.as_ref()) {
                checks.extend(AutoCheck::of(
                    &loaded.scene,
                    &bench.options(Accel::Auto, false),
                    g,
                    &scene_rows,
                ));
            }
            rows.extend(scene_rows);
        }
        progress.inc(1);
    }
    progress.finish_and_clear();
    let adapter = gpu.as_ref().map(|g| format!("{} ({})", g.ctx.info.name, g.ctx.info.driver_info));
    if args.json {
        let report = Report {
            size: [args.width, args.height],
            sampling: format!("{:?}", args.sampling).to_lowercase(),
            max_depth: args.max_depth,
            runs: args.runs,
            adapter,
            rows: &rows,
            auto: &checks,
        };
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", table(&rows, &args, adapter.as_deref()));
        for c in &checks {
            println!(
                "\nauto on {}: predicted build {:.3} s, saved {:.3} s; measured build {:.3} s, saved {:.3} s; chose {}",
                c.scene, c.predicted_build_s, c.predicted_saved_s, c.measured_build_s, c.measured_saved_s, c.chose
            );
        }
    }
    Ok(())
}

/// The scene files to run: those given, else the SPD canonical scenes under `--spd-dir`.
fn scene_paths(args: &BenchArgs) -> anyhow::Result<Vec<PathBuf>> {
    if !args.scenes.is_empty() {
        return Ok(args.scenes.clone());
    }
    let paths: Vec<PathBuf> = CANONICAL.iter().map(|n| args.spd_dir.join(format!("{n}.nff"))).collect();
    if let Some(missing) = paths.iter().find(|p| !p.is_file()) {
        bail!(
            "the SPD canonical scenes are not there ({} is missing): give scene files, or --spd-dir",
            missing.display()
        );
    }
    Ok(paths)
}

/// One scene on one backend, every accelerator.
struct Bench<'a> {
    args: &'a BenchArgs,
    gpu: Option<&'a GpuRenderer>,
    scene: &'a cuberay::scene::Scene,
    name: &'a str,
    backend: BenchBackend,
    load_s: f64,
}

impl Bench<'_> {
    /// The options of a render with `accel`, counted or not.
    fn options(&self, accel: Accel, count: bool) -> RenderOptions {
        let args = self.args;
        RenderOptions {
            sampling: args.sampling.into(),
            max_depth: args.max_depth,
            accel,
            surface: args.surface_walk.into(),
            form: args.kernel_form.into(),
            count,
            precision: args.precision.into(),
            ..RenderOptions::new(args.width, args.height)
        }
    }

    /// A render with `accel`, counted or not.
    fn render(
        &self,
        accel: Accel,
        count: bool,
        progress: &indicatif::ProgressBar,
    ) -> anyhow::Result<Rendered> {
        let opts = self.options(accel, count);
        let what =
            format!("{}, --accel {} --backend {:?}", self.name, accel.name(), self.backend).to_lowercase();
        progress.set_message(what.clone());
        let hidden = indicatif::ProgressBar::hidden();
        let rendered = match self.backend {
            BenchBackend::Gpu => self.gpu.expect("opened for a GPU bench").render(self.scene, &opts, &hidden),
            BenchBackend::Cpu => reference::render(self.scene, &opts, &hidden),
        };
        rendered.with_context(|| format!("cannot render {what}"))
    }

    /// The rows of every accelerator: each renders once counted and once as a warm-up, then
    /// once a round for `--runs` rounds.
    fn rows(&self, progress: &indicatif::ProgressBar) -> anyhow::Result<Vec<Row>> {
        let accels: Vec<Accel> = self.args.accel.iter().map(|&a| a.into()).collect();
        // Two untimed runs of each: one that counts the rays and tests, and a warm-up of the
        // kernels the timed runs use, which count nothing, as a render without `--stats` (on
        // lavapipe counting costs the kernels 5–22 % of their time). The warm-up compiles them
        // and fills the caches, so that no timed run pays for it; its compilation is what a
        // `render` command pays at its first use of the kernels.
        let mut counted: Vec<(Stats, f64)> = Vec::new();
        for &accel in &accels {
            let stats = self.render(accel, true, progress)?.stats;
            let compile_s = self.render(accel, false, progress)?.stats.time.phases.compile_s;
            counted.push((stats, compile_s));
        }
        // The timed runs go in rounds, each accelerator once a round, so that a drift of the
        // machine's speed meets them alike; the ratios are taken within a round.
        let mut runs: Vec<Vec<Timed>> = vec![Vec::new(); accels.len()];
        for _ in 0..self.args.runs {
            for (k, &accel) in accels.iter().enumerate() {
                runs[k].push(Timed::of(&self.render(accel, false, progress)?, self.backend));
            }
        }
        let startup_s =
            self.gpu.filter(|_| self.backend == BenchBackend::Gpu).map_or(0.0, |g| g.ctx.opened_s);
        for (k, r) in runs.iter_mut().enumerate() {
            for t in r.iter_mut() {
                let p = &mut t.phases;
                (p.startup_s, p.load_s, p.compile_s) = (startup_s, self.load_s, counted[k].1);
                p.total_s = 0.0;
                p.total_s = p.whole();
            }
        }
        // The BVH's row by what the render ran (`auto` may resolve to it on the CPU).
        let bvh = counted.iter().position(|(s, _)| s.settings.accel == "bvh");
        let rayquery = counted.iter().position(|(s, _)| s.settings.accel == "rayquery");
        let series = |f: fn(&Timed) -> f64| -> Vec<Vec<f64>> {
            runs.iter().map(|r| r.iter().map(f).collect()).collect()
        };
        let kernels = series(|t| t.kernel_s);
        let wholes = series(|t| t.phases.total_s);
        Ok(counted
            .into_iter()
            .enumerate()
            .map(|(k, (s, _))| {
                let mut row = self.row(s, &runs[k]);
                (row.ratio_to_bvh, row.ratio_range) = median_and_range(&round_ratios(&kernels, k, bvh));
                (row.ratio_to_rayquery, row.rayquery_range) =
                    median_and_range(&round_ratios(&kernels, k, rayquery));
                (row.whole_ratio_to_bvh, row.whole_range) = median_and_range(&round_ratios(&wholes, k, bvh));
                row
            })
            .collect())
    }

    /// The row of the accelerator whose counted run gave `s` and whose timed runs are `timed`
    /// (the ratios left for the caller).
    fn row(&self, s: Stats, timed: &[Timed]) -> Row {
        let gpu = self.backend == BenchBackend::Gpu && s.time.gpu_s.is_some();
        let med = |f: &dyn Fn(&Timed) -> f64| median(timed.iter().map(f).collect());
        let kernel_s = med(&|t| t.kernel_s);
        let ran = s.time.gpu_depth_s.as_ref().map_or(0, |d| d.len());
        let depth_kernel_s: Vec<f64> = (0..ran).map(|d| med(&|t: &Timed| t.depths[d].0)).collect();
        let surface_depths_s = (gpu && ran > 1).then(|| depth_kernel_s.iter().skip(1).sum::<f64>());
        let eye_nearest = med(&|t| t.depths[0].1);
        let surface_nearest = med(&|t| t.depths[1..].iter().map(|d| d.1).sum());
        let surface_shade = med(&|t| t.depths[1..].iter().map(|d| d.2).sum());
        // The tree form times no depth apart: it has no per-depth or per-ray-kind figures.
        let per = |secs: f64, rays: u64| (gpu && ran > 0 && rays > 0).then(|| secs * 1e6 / rays as f64);
        let first = timed[0].phases;
        let phases = Phases {
            build_s: med(&|t| t.phases.build_s),
            tables_s: med(&|t| t.phases.tables_s),
            bvh_s: med(&|t| t.phases.bvh_s),
            upload_s: med(&|t| t.phases.upload_s),
            trace_s: med(&|t| t.phases.trace_s),
            total_s: med(&|t| t.phases.total_s),
            ..first
        };
        Row {
            scene: self.name.to_string(),
            accel: s.settings.accel.clone(),
            backend: match self.backend {
                BenchBackend::Gpu => "gpu",
                BenchBackend::Cpu => "cpu",
            },
            precision: s.settings.precision.clone(),
            load_s: self.load_s,
            preprocess_s: med(&|t| t.preprocess_s),
            phases,
            whole_ratio_to_bvh: None,
            whole_range: None,
            accel_bytes: s.accel_bytes,
            kernel_s,
            rays: s.rays.total,
            mrays_per_s: s.rays.total as f64 / kernel_s.max(1e-9) / 1e6,
            tests_per_ray: s.tests_per_ray,
            bound_tests_per_ray: s.bound_tests_per_ray,
            ratio_to_bvh: None,
            ratio_range: None,
            ratio_to_rayquery: None,
            rayquery_range: None,
            surface_walk: s.settings.surface_walk.clone(),
            kernel_form: s.settings.kernel_form.clone(),
            longest_dispatch_s: timed.iter().filter_map(|t| t.longest_dispatch_s).reduce(f64::max),
            depth_kernel_s,
            surface_depths_s,
            surface_shade_share: surface_depths_s.filter(|&s| s > 0.0).map(|s| surface_shade / s),
            eye_ray_us: per(eye_nearest, s.rays.eye),
            surface_ray_us: per(surface_nearest, s.rays.reflect + s.rays.refract),
            lanes: gpu.then(|| s.lanes.clone()),
        }
    }
}

/// The rows as a Markdown table.
fn table(rows: &[Row], args: &BenchArgs, adapter: Option<&str>) -> String {
    let mut out = format!(
        "{}x{} {}, depth {}, median of {} rounds (each accelerator once a round) after a warm-up{}\n\n",
        args.width,
        args.height,
        clap::ValueEnum::to_possible_value(&args.sampling)
            .map_or_else(String::new, |v| v.get_name().to_owned()),
        args.max_depth,
        args.runs,
        adapter.map(|a| format!(", GPU: {a}")).unwrap_or_default()
    );
    out += "| scene | accel | backend | to image s | × BVH | build s (tables, bvh) | upload s | compile s | MiB | kernel s | × BVH (rounds' range) | × rayquery | depths 2+ s | µs/eye ray | µs/surface ray | M rays/s | tests/ray eye | shadow | reflect | refract | all | bound/ray all | longest dispatch ms |\n";
    out += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for r in rows {
        let t = &r.tests_per_ray;
        // `cube`'s rays leaving surfaces go to the BVH or to ray queries: say which,
        // and in which kernel form the GPU traced.
        let accel = match (&r.surface_walk, &r.kernel_form) {
            (Some(w), Some(f)) => format!("{} ({w}, {f})", r.accel),
            (Some(w), None) => format!("{} ({w})", r.accel),
            (None, Some(f)) => format!("{} ({f})", r.accel),
            (None, None) => r.accel.clone(),
        };
        let p = &r.phases;
        out += &format!(
            "| {} | {} | {} | {:.3} | {} | {:.3} ({:.3}, {:.3}) | {:.3} | {:.3} | {:.1} | {:.3} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} |\n",
            r.scene,
            accel,
            if r.backend == "gpu" && r.precision == "f64" { "gpu f64" } else { r.backend },
            p.total_s,
            ratio_cell(r.whole_ratio_to_bvh, r.whole_range),
            p.build_s,
            p.tables_s,
            p.bvh_s,
            p.upload_s,
            p.compile_s,
            r.accel_bytes as f64 / (1u64 << 20) as f64,
            r.kernel_s,
            ratio_cell(r.ratio_to_bvh, r.ratio_range),
            ratio_cell(r.ratio_to_rayquery, r.rayquery_range),
            r.surface_depths_s.map_or("–".into(), |x| format!("{x:.3}")),
            r.eye_ray_us.map_or("–".into(), |x| format!("{x:.3}")),
            r.surface_ray_us.map_or("–".into(), |x| format!("{x:.3}")),
            r.mrays_per_s,
            t.eye,
            t.shadow,
            t.reflect,
            t.refract,
            t.all,
            r.bound_tests_per_ray.all,
            r.longest_dispatch_s.map_or("–".into(), |x| format!("{:.1}", x * 1e3)),
        );
    }
    out
}

/// A `× BVH` or `× rayquery` cell: the median ratio, and the range over the rounds when they
/// differ.
fn ratio_cell(ratio: Option<f64>, range: Option<(f64, f64)>) -> String {
    match (ratio, range) {
        (Some(x), Some((lo, hi))) if format!("{lo:.2}") != format!("{hi:.2}") => {
            format!("{x:.2} ({lo:.2}–{hi:.2})")
        }
        (Some(x), _) => format!("{x:.2}"),
        (None, _) => "–".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::{median, ratio_cell, round_ratios};

    /// Rounds in which the machine's speed drifts: the ratio is taken within each round, so
    /// it stays what it is while a ratio of medians would not.
    #[test]
    fn ratios_are_taken_within_each_round() {
        let kernels = vec![vec![1.0, 2.0, 4.0], vec![2.0, 4.0, 8.0], vec![1.0, 1.0, 1.0]];
        assert_eq!(round_ratios(&kernels, 0, Some(1)), [0.5, 0.5, 0.5]);
        assert_eq!(round_ratios(&kernels, 1, Some(1)), [1.0, 1.0, 1.0]);
        assert_eq!(round_ratios(&kernels, 2, Some(1)), [0.5, 0.25, 0.125]);
        // Paired round by round, not sorted: the rounds' order matters.
        assert_eq!(round_ratios(&[vec![3.0, 1.0], vec![1.0, 3.0]], 0, Some(1)), [3.0, 1.0 / 3.0]);
        assert!(round_ratios(&kernels, 0, None).is_empty());
    }

    #[test]
    fn the_ratio_cell_shows_the_range_when_the_rounds_disagree() {
        assert_eq!(ratio_cell(Some(0.52), Some((0.48, 0.77))), "0.52 (0.48–0.77)");
        assert_eq!(ratio_cell(Some(1.0), Some((1.0, 1.0))), "1.00");
        assert_eq!(ratio_cell(Some(0.5), Some((0.501, 0.504))), "0.50");
        assert_eq!(ratio_cell(None, None), "–");
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(vec![7.0]), 7.0);
    }
}
