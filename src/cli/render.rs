//! `cuberay render`: load a scene, render it with the chosen backend, write the image
//! (or an AOV) atomically and print statistics.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

use cuberay::gpu::GpuRenderer;
use cuberay::job::{AccelKind, RenderOptions};
use cuberay::load::{self, Loaded};
use cuberay::output::{self, Aov, OutputFormat};
use cuberay::reference;
use cuberay::sampling::Sampling;
use cuberay::scene::Transfer;

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
    /// Output image: .png (clamped, sRGB-encoded) or .exr (linear radiance; AOVs).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Renderer: the WGSL kernels (default) or the f64 CPU reference.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    pub backend: Backend,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Write an auxiliary output to the (.exr) output instead of the image.
    #[arg(long, value_enum)]
    pub aov: Option<Aov>,
    /// Print statistics after the render: text (default) or one JSON object on stdout.
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "text")]
    pub stats: Option<StatsFormat>,
}

/// The options shared by `render` and `compare`: which scene camera, image size and
/// sampling, depth and acceleration structure.
#[derive(Args, Debug)]
pub struct TraceArgs {
    /// Image width (default: the scene's resolution, else 512 high at the camera's aspect).
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
    #[arg(long, value_enum, default_value_t = Sampling::Center)]
    pub sampling: Sampling,
    /// Maximum ray-tree depth, the eye ray being depth 1.
    #[arg(long, default_value_t = 5)]
    pub max_depth: u32,
    /// Acceleration structure. auto: the candidate tables (cube) on the GPU; on the CPU brute
    /// force for tiny scenes, else a BVH. cube: the direction-cube candidate tables (both
    /// backends); bvh: CPU only.
    #[arg(long, value_enum, default_value_t = AccelKind::Auto)]
    pub accel: AccelKind,
    /// glTF: index of the camera to use.
    #[arg(long)]
    pub camera: Option<usize>,
    /// How a PNG (and the preview window) encodes the values: srgb (linear radiance,
    /// sRGB-encoded) or display (the values as they are). Default: display for NFF, whose
    /// colours are display values, srgb for glTF.
    #[arg(long, value_enum)]
    pub transfer: Option<Transfer>,
}

impl TraceArgs {
    /// Loads the scene (the showcase without a path) and turns the options into
    /// validated render options. Returns the name to use in messages too.
    pub fn load(&self, scene: &Option<PathBuf>) -> anyhow::Result<(PathBuf, Loaded, RenderOptions)> {
        let scene_name = scene.clone().unwrap_or_else(|| PathBuf::from(load::SHOWCASE_NAME));
        let loaded = match scene {
            Some(path) => super::load_scene(path, self.camera)?,
            None => load::showcase().context("the built-in showcase scene does not load")?,
        };
        let (dw, dh) = loaded.scene.resolution.unwrap_or_else(|| loaded.scene.camera.default_resolution());
        let opts = RenderOptions {
            width: self.width.unwrap_or(dw),
            height: self.height.unwrap_or(dh),
            spp: self.spp.unwrap_or(1),
            seed: self.seed,
            sampling: self.sampling,
            max_depth: self.max_depth,
            accel: self.accel,
            transfer: self.transfer,
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
    let (scene_name, loaded, opts) = args.trace.load(&args.scene)?;
    let scene = &loaded.scene;
    let progress = progress_bar("rendering");
    let rendered = match args.backend {
        Backend::Cpu => match args.aov {
            Some(aov) => reference::render_aov(scene, &opts, aov, &progress),
            None => reference::render(scene, &opts, &progress),
        }
        .with_context(|| format!("cannot render {}", scene_name.display()))?,
        Backend::Gpu => {
            let gpu = GpuRenderer::new()?;
            match args.aov {
                Some(aov) => gpu.render_aov(scene, &opts, aov, &progress),
                None => gpu.render(scene, &opts, &progress),
            }
            .with_context(|| format!("cannot render {} on the GPU", scene_name.display()))?
        }
    };
    progress.finish_and_clear();

    if !rendered.image.is_finite() {
        bail!("the render produced a non-finite pixel; nothing written (this is a renderer bug)");
    }
    output::write(&rendered.image, &args.output)?;
    match args.stats {
        Some(StatsFormat::Json) => println!("{}", rendered.stats.to_json()),
        Some(StatsFormat::Text) => print!("{}", rendered.stats.to_text()),
        None => {}
    }
    Ok(())
}
