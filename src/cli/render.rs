//! `cuberay render`: load a scene, render it with the chosen backend, write the image
//! (or an AOV) atomically and print statistics.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

use cuberay::gpu::prepare::{build_params, Purpose};
use cuberay::gpu::GpuRenderer;
use cuberay::job::{Region, RenderOptions};
use cuberay::load::{self, Loaded};
use cuberay::output::{self, Aov, OutputFormat};
use cuberay::part::{self, PartInfo, SceneId};
use cuberay::reference;
use cuberay::scene::{Tonemap, Transfer};

use super::args::{
    AccelArg, AovArg, DisplayArgs, KernelFormArg, PrecisionArg, SamplingArg, SceneArgs, SurfaceWalkArg,
};
use cuberay::tablefile;

/// Which renderer to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// The f64 reference renderer on the CPU.
    Cpu,
    /// The WGSL compute renderer (wgpu).
    Gpu,
}

/// How `--stats` prints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StatsFormat {
    Text,
    Json,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (.nff, .gltf, .glb). Without one, the built-in showcase
    /// (scenes/showcase.nff: mirrors, glass, shadows, three lights).
    pub scene: Option<PathBuf>,
    /// Output image: .png (clamped, 8 bits, encoded by --transfer), .exr (the values as
    /// rendered, f32; AOVs) or .hdr (the values as rendered, Radiance RGBE).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Renderer: the WGSL kernels (default) or the f64 CPU reference.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    pub backend: Backend,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Write an auxiliary output to the (.exr) output instead of the image.
    #[arg(long, value_enum)]
    pub aov: Option<AovArg>,
    /// Print statistics after the render: text (default) or one JSON object on stdout. The
    /// GPU kernels count rays and tests only then (and for a part), as counting slows them.
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "text")]
    pub stats: Option<StatsFormat>,
    /// Render band I of N (0-based): rows I·⌈H/N⌉ up to (I+1)·⌈H/N⌉. To an .exr, the part
    /// records its window, the image size and the settings for `cuberay merge`.
    #[arg(long, value_parser = parse_tile, conflicts_with = "crop", value_name = "I/N")]
    pub tile: Option<(u32, u32)>,
    /// Render only pixels X0..X1 × Y0..Y1 (ends exclusive) of the image, as --tile does.
    #[arg(long, value_parser = parse_crop, value_name = "X0,Y0,X1,Y1")]
    pub crop: Option<Region>,
    /// Render frames A to B (both included) of a glTF file's animation, sampled at
    /// t = frame / --fps, one file a frame: a run of `#` in the output's name becomes the
    /// frame number (`shot_####.png`), else `_NNNN` goes before the extension.
    #[arg(long, value_parser = parse_frames, value_name = "A..B")]
    pub frames: Option<(u32, u32)>,
    /// Trace the candidate tables stored in this file (`cuberay tables` with the same scene
    /// and options) instead of building them: the tasks of a split render share one build.
    /// GPU backend only; a file built for another scene or other options is refused.
    #[arg(long, value_name = "FILE")]
    pub tables: Option<PathBuf>,
    /// Frames per second of --frames.
    #[arg(long, default_value_t = 24.0, requires = "frames")]
    pub fps: f64,
}

/// `--tile I/N`.
fn parse_tile(s: &str) -> Result<(u32, u32), String> {
    let (i, n) = s.split_once('/').ok_or_else(|| format!("{s:?} is not I/N (for example 0/4)"))?;
    let num = |t: &str| t.trim().parse::<u32>().map_err(|_| format!("{t:?} in {s:?} is not a whole number"));
    let (i, n) = (num(i)?, num(n)?);
    if n == 0 {
        return Err(format!("{s:?}: the tile count must be at least 1"));
    }
    if i >= n {
        return Err(format!("{s:?}: the tile index must be in 0..{n} (tiles count from 0)"));
    }
    Ok((i, n))
}

/// `--crop X0,Y0,X1,Y1`.
fn parse_crop(s: &str) -> Result<Region, String> {
    let v = s
        .split(',')
        .map(|t| t.trim().parse::<u32>().map_err(|_| format!("{t:?} in {s:?} is not a pixel coordinate")))
        .collect::<Result<Vec<_>, _>>()?;
    let [x0, y0, x1, y1] = v[..] else {
        return Err(format!("{s:?} is not X0,Y0,X1,Y1 (four pixel coordinates)"));
    };
    if x0 >= x1 || y0 >= y1 {
        return Err(format!("{s:?}: the window is empty (it needs X0 < X1 and Y0 < Y1)"));
    }
    Ok(Region { x0, y0, x1, y1 })
}

/// The options shared by `render` and `compare`: which scene camera, image size and
/// sampling, depth and acceleration structure.
#[derive(Args, Debug)]
pub struct TraceArgs {
    /// Image width (default: the scene's resolution, else 512 high at the camera's aspect;
    /// given alone, the height follows at that aspect, and likewise the other way).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height.
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel: 1 samples the pixel centre, N > 1 stratified jitter (default 1;
    /// preview: the samples it accumulates, default --frames, else 256).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Seed of the jitter (--spp > 1).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Eye-ray placement: pixel centres, or the SPD procedure's (W+1)×(H+1) pixel corners.
    #[arg(long, value_enum, default_value_t = SamplingArg::Center)]
    pub sampling: SamplingArg,
    /// Maximum ray-tree depth, the eye ray being depth 1.
    #[arg(long, default_value_t = 5)]
    pub max_depth: u32,
    /// Acceleration structure. auto: on the GPU the candidate table of each origin (eye,
    /// light) whose build pays for this render, the BVH for the rest; on the CPU brute
    /// force for tiny scenes, else a BVH. cube: the direction-cube candidate tables for eye and
    /// light rays, for rays leaving surfaces the BVH or ray queries (--surface-walk); bvh: a
    /// bounding volume hierarchy (the baseline); brute: every primitive for every ray;
    /// rayquery (GPU): the platform's ray tracing for every ray.
    #[arg(long, value_enum, default_value_t = AccelArg::Auto)]
    pub accel: AccelArg,
    /// GPU, --accel cube or auto: what rays leaving surfaces take. auto: the platform's ray
    /// queries where the adapter has them, except lavapipe (whose software ones measured
    /// slower than the BVH), else the BVH; `--stats` says which it took.
    #[arg(long, value_enum, default_value_t = SurfaceWalkArg::Auto)]
    pub surface_walk: SurfaceWalkArg,
    /// GPU: how the kernels trace the ray trees. auto: the form measured faster on the
    /// adapter (`cuberay info` says which); wavefront: breadth first over queues of rays, a
    /// kernel per step; tree: depth first, each invocation its point's whole tree (not on
    /// drivers with a loop limit: lavapipe before Mesa 24).
    #[arg(long, value_enum, default_value_t = KernelFormArg::Auto)]
    pub kernel_form: KernelFormArg,
    /// The GPU kernels' intersection arithmetic. auto: f64 where f32 cannot resolve the
    /// scene at this image size (`cuberay info` says which, and why), else f32; f32; f64,
    /// where the adapter has 64-bit floats in shaders (lavapipe has; slower). The CPU
    /// reference is always f64.
    #[arg(long, value_enum, default_value_t = PrecisionArg::Auto)]
    pub precision: PrecisionArg,
    /// Cells per face edge of the eye's direction cube (default: about two pixels a cell):
    /// the tables' time and memory, never the image.
    #[arg(long)]
    pub eye_cells: Option<u32>,
    /// glTF: which camera node to look through, counted from 0 in the scene's node order
    /// (default: the first; none: a camera framing the scene).
    #[arg(long)]
    pub camera: Option<usize>,
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
}

impl TraceArgs {
    /// Loads the scene (the showcase without a path) and turns the options into
    /// validated render options. Returns the name to use in messages too.
    pub fn load(&self, scene: &Option<PathBuf>) -> anyhow::Result<(PathBuf, Loaded, RenderOptions)> {
        self.load_at(scene, None)
    }

    /// [`TraceArgs::load`] with a glTF file's animated nodes posed at `time` seconds.
    pub fn load_at(
        &self,
        scene: &Option<PathBuf>,
        time: Option<f64>,
    ) -> anyhow::Result<(PathBuf, Loaded, RenderOptions)> {
        let scene_name = scene.clone().unwrap_or_else(|| PathBuf::from(load::SHOWCASE_NAME));
        let setup = self.scene.setup();
        let loaded = match scene {
            Some(path) => super::load_scene(path, self.camera, time, &setup)?,
            None => {
                let mut showcase = load::showcase().context("the built-in showcase scene does not load")?;
                load::apply_setup(&mut showcase, std::path::Path::new(load::SHOWCASE_NAME), &setup)?;
                showcase
            }
        };
        let (dw, dh) = loaded.scene.resolution.unwrap_or_else(|| loaded.scene.camera.default_resolution());
        // One of --width and --height alone keeps the default size's aspect.
        let follow =
            |given: u32, of: u32, to: u32| ((given as f64 * to as f64 / of as f64).round() as u32).max(1);
        let (width, height) = match (self.width, self.height) {
            (Some(w), None) => (w, follow(w, dw, dh)),
            (None, Some(h)) => (follow(h, dh, dw), h),
            (w, h) => (w.unwrap_or(dw), h.unwrap_or(dh)),
        };
        let opts = RenderOptions {
            width,
            height,
            spp: self.spp.unwrap_or(1),
            seed: self.seed,
            sampling: self.sampling.into(),
            max_depth: self.max_depth,
            accel: self.accel.into(),
            surface: self.surface_walk.into(),
            form: self.kernel_form.into(),
            precision: self.precision.into(),
            eye_cells: self.eye_cells,
            transfer: self.display.transfer.map(Transfer::from),
            exposure: self.display.exposure,
            tonemap: self.display.tonemap.map(Tonemap::from),
            ..RenderOptions::new(1, 1)
        };
        opts.validate()?;
        Ok((scene_name, loaded, opts))
    }
}

/// A progress bar on a terminal, nothing otherwise.
pub fn progress_bar(message: &'static str) -> ProgressBar {
    if std::io::stderr().is_terminal() {
        let bar = ProgressBar::new(0);
        bar.set_style(
            ProgressStyle::with_template("{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} (eta {eta})")
                .expect("valid progress template"),
        );
        bar.set_message(message);
        bar
    } else {
        ProgressBar::hidden()
    }
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    // Everything that can be checked before the (possibly long) render is checked first.
    let format = OutputFormat::from_path(&args.output)?;
    if args.aov.is_some() && format != OutputFormat::Exr {
        bail!(cuberay::Error::AovNeedsExr { path: args.output.clone() });
    }
    let d = &args.trace.display;
    for (flag, given) in [
        ("--transfer", d.transfer.is_some()),
        ("--tonemap", d.tonemap.is_some()),
        ("--exposure", d.exposure != 0.0),
    ] {
        if given && format != OutputFormat::Png {
            log::warn!(
                "{flag} has no effect on {}: EXR and HDR files store the values as rendered",
                args.output.display()
            );
        }
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        bail!("--fps {} is not a positive number of frames per second", args.fps);
    }
    let frames: Box<dyn Iterator<Item = Option<u32>>> = match args.frames {
        None => Box::new(std::iter::once(None)),
        Some((a, b)) => {
            let is_gltf = args
                .scene
                .as_ref()
                .and_then(|p| p.extension())
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"));
            if !is_gltf {
                bail!("--frames samples a glTF file's animation: give a .gltf or .glb scene");
            }
            frame_path(&args.output, a)?;
            Box::new((a..=b).map(Some))
        }
    };
    // One device (and its compiled kernels) for every frame.
    let gpu = match args.backend {
        Backend::Gpu => Some(GpuRenderer::new()?),
        Backend::Cpu => None,
    };
    // The first frame's time to image counts from the command's start, the others' from
    // their own.
    let mut since = super::started();
    for frame in frames {
        let output = match frame {
            Some(f) => frame_path(&args.output, f)?,
            None => args.output.clone(),
        };
        render_one(&args, gpu.as_ref(), frame, format, &output, since)?;
        since = std::time::Instant::now();
    }
    Ok(())
}

/// `--frames A..B`: both ends included, as animation tools count frames.
fn parse_frames(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s.split_once("..").ok_or_else(|| format!("{s:?} is not A..B (for example 0..47)"))?;
    let num = |t: &str| t.trim().parse::<u32>().map_err(|_| format!("{t:?} in {s:?} is not a frame number"));
    let (a, b) = (num(a)?, num(b)?);
    if a > b {
        return Err(format!("{s:?}: the first frame is after the last"));
    }
    Ok((a, b))
}

/// The file of frame `f`: the run of `#` in the file name replaced by the frame number,
/// zero-padded to the run's length (`shot_####.png` → `shot_0012.png`); without one,
/// `_NNNN` before the extension (`shot.png` → `shot_0012.png`).
pub fn frame_path(path: &std::path::Path, f: u32) -> anyhow::Result<PathBuf> {
    let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
        bail!("{}: --frames needs an output file name in UTF-8, to number the frames", path.display());
    };
    let named = match name.find('#') {
        Some(start) => {
            let run = name[start..].chars().take_while(|&c| c == '#').count();
            format!("{}{f:0run$}{}", &name[..start], &name[start + run..])
        }
        None => {
            let stem = path.file_stem().and_then(|n| n.to_str()).unwrap_or_default();
            let ext = path.extension().and_then(|n| n.to_str()).unwrap_or_default();
            format!("{stem}_{f:04}.{ext}")
        }
    };
    Ok(path.with_file_name(named))
}

/// The identity of the scene file (`None`: the built-in showcase) at `frame`.
pub fn scene_identity(
    scene: &Option<PathBuf>,
    camera: Option<usize>,
    frame: Option<u32>,
    time: Option<f64>,
) -> anyhow::Result<SceneId> {
    Ok(match scene {
        Some(path) => {
            let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
            SceneId { frame, time_s: time, ..SceneId::of(&path.display().to_string(), &bytes, camera) }
        }
        None => SceneId::of(load::SHOWCASE_NAME, load::SHOWCASE_SOURCE.as_bytes(), None),
    })
}

/// Renders one image (one frame of `--frames`, or the only one) to `output`.
fn render_one(
    args: &RenderArgs,
    gpu: Option<&GpuRenderer>,
    frame: Option<u32>,
    format: OutputFormat,
    output: &std::path::Path,
    since: std::time::Instant,
) -> anyhow::Result<()> {
    let time = frame.map(|f| f as f64 / args.fps);
    let load_start = std::time::Instant::now();
    let (scene_name, loaded, mut opts) = args.trace.load_at(&args.scene, time)?;
    let load_s = load_start.elapsed().as_secs_f64();
    opts.region = match (args.tile, args.crop) {
        (Some((i, n)), _) => Some(Region::band(i, n, opts.width, opts.height)?),
        (None, crop) => crop,
    };
    opts.validate()?;
    let part = opts.region.is_some() && format == OutputFormat::Exr;
    if part && opts.region().pixels() > part::MAX_PART_PIXELS {
        bail!(
            "the part has {} pixels, more than a part holds ({}): split the image into more --tile bands",
            opts.region().pixels(),
            part::MAX_PART_PIXELS
        );
    }
    // The kernels count rays and tests only for a report or a part (whose counts `merge`
    // adds up): uncounted they run faster.
    opts.count = args.stats.is_some() || part;
    // A part names its scene by content, so that `merge` can refuse parts of another one.
    let scene_id = match part {
        false => None,
        true => Some(scene_identity(&args.scene, args.trace.camera, frame, time)?),
    };
    let scene = &loaded.scene;
    let read_start = std::time::Instant::now();
    let stored = match (&args.tables, gpu) {
        (None, _) => None,
        (Some(_), None) => {
            bail!("--tables holds tables for the GPU backend; the CPU reference builds its own")
        }
        (Some(path), Some(_)) => {
            let purpose = args.aov.map_or(Purpose::Render, |a| Purpose::Aov(a.into()));
            let params = build_params(scene, &opts, purpose)?.with_context(|| {
                format!("--tables: this render traces no tables (--accel {})", opts.accel.name())
            })?;
            Some(tablefile::read(path, &tablefile::key(scene, &params))?)
        }
    };
    let read_s = read_start.elapsed().as_secs_f64();
    let progress = progress_bar("rendering");
    let rendered = match gpu {
        None => match args.aov.map(Aov::from) {
            Some(aov) => reference::render_aov(scene, &opts, aov, &progress),
            None => reference::render(scene, &opts, &progress),
        }
        .with_context(|| format!("cannot render {}", scene_name.display()))?,
        Some(gpu) => match args.aov.map(Aov::from) {
            Some(aov) => gpu.render_aov_with(scene, &opts, aov, stored, &progress),
            None => gpu.render_with(scene, &opts, stored, &progress),
        }
        .with_context(|| format!("cannot render {} on the GPU", scene_name.display()))?,
    };
    // Reading stored tables is this render's preprocessing.
    let mut rendered = rendered;
    rendered.stats.time.preprocess_s += read_s;
    progress.finish_and_clear();

    if !rendered.image.is_finite() {
        bail!("the render produced a non-finite pixel; nothing written (this is a renderer bug)");
    }
    let output_start = std::time::Instant::now();
    match scene_id.filter(|_| part) {
        Some(id) => {
            let aov = args.aov.and_then(|a| a.to_possible_value()).map(|v| v.get_name().to_string());
            let backend = match gpu {
                Some(g) => format!("{} ({})", g.ctx.info.name, g.ctx.info.driver_info),
                None => "the CPU reference".into(),
            };
            part::write_part(&rendered.image, &PartInfo::new(id, &rendered.stats, aov, &backend), output)?
        }
        None => output::write(&rendered.image, output)?,
    }
    let phases = &mut rendered.stats.time.phases;
    phases.startup_s = gpu.filter(|_| since <= super::started()).map_or(0.0, |g| g.ctx.opened_s);
    phases.load_s = load_s;
    phases.output_s = output_start.elapsed().as_secs_f64();
    phases.total_s = since.elapsed().as_secs_f64();
    match args.stats {
        Some(StatsFormat::Json) => println!("{}", rendered.stats.to_json()),
        Some(StatsFormat::Text) => print!("{}", rendered.stats.to_text()),
        None => {}
    }
    Ok(())
}
