//! `cuberay compare`: render one scene on the GPU and with the CPU reference, print the
//! differences (see [`cuberay::compare`]) and write both images and a FLIP heat map.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;

use cuberay::compare::compare;
use cuberay::gpu::GpuRenderer;
use cuberay::job::{Accel, RenderOptions};
use cuberay::output;
use cuberay::reference;

use super::render::{progress_bar, TraceArgs};

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Scene file (.nff, .gltf, .glb); without one, the built-in showcase.
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Folder for the images: NAME.gpu.png, NAME.cpu.png and NAME.flip.png (the FLIP
    /// heat map), NAME being the scene file's stem.
    /// Created when missing.
    #[arg(long, default_value = ".")]
    pub out_dir: PathBuf,
    /// Print one JSON object (rmse, psnr, flip_mean, max_abs, over_tolerance...).
    #[arg(long)]
    pub json: bool,
    /// Exit non-zero when the FLIP mean exceeds this.
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Per-channel difference (displayed values in [0, 1]) above which a pixel counts as
    /// differing.
    #[arg(long, default_value_t = 2.0 / 255.0)]
    pub tolerance: f64,
}

pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    if let Some(t) = args.threshold {
        if !(t.is_finite() && t >= 0.0) {
            bail!("--threshold {t} is not a non-negative number");
        }
    }
    if !(args.tolerance.is_finite() && args.tolerance >= 0.0) {
        bail!("--tolerance {} is not a non-negative number", args.tolerance);
    }
    let (scene_name, loaded, opts) = args.trace.load(&args.scene)?;
    // Made once the scene has loaded: a scene that does not load leaves no folder behind.
    if !args.out_dir.exists() {
        std::fs::create_dir_all(&args.out_dir)
            .with_context(|| format!("cannot create --out-dir {}", args.out_dir.display()))?;
    }
    if !args.out_dir.is_dir() {
        bail!("--out-dir {} is not a folder", args.out_dir.display());
    }
    // The images are compared, not the counts: the kernels need not count.
    let opts = RenderOptions { count: false, ..opts };
    let scene = &loaded.scene;
    let stem = scene_name.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());

    let gpu = GpuRenderer::new()?;
    let progress = progress_bar("GPU");
    let g = gpu
        .render(scene, &opts, &progress)
        .with_context(|| format!("cannot render {} on the GPU", scene_name.display()))?;
    progress.finish_and_clear();
    let progress = progress_bar("CPU");
    // The yardstick stays independent: the GPU's tables and ray queries are compared against
    // the reference's own choice (brute force or its BVH), which every accelerator's image
    // equals; `bvh` and `brute` name accelerators the reference has too.
    let own = match opts.accel {
        Accel::Bvh | Accel::Brute => opts.accel,
        Accel::Auto | Accel::Cube | Accel::RayQuery => Accel::Auto,
    };
    let cpu_opts = RenderOptions { accel: own, ..opts.clone() };
    let c = reference::render(scene, &cpu_opts, &progress)
        .with_context(|| format!("cannot render {}", scene_name.display()))?;
    progress.finish_and_clear();

    let (cmp, heat) = compare(&c.image, &g.image, args.tolerance);
    output::write(&g.image, &args.out_dir.join(format!("{stem}.gpu.png")))?;
    output::write(&c.image, &args.out_dir.join(format!("{stem}.cpu.png")))?;
    output::write_rgb8(opts.width, opts.height, heat, &args.out_dir.join(format!("{stem}.flip.png")))?;
    if args.json {
        println!("{}", serde_json::to_string(&cmp)?);
    } else {
        print!("{}", cmp.to_text());
    }
    if cmp.non_finite > 0 {
        bail!("{} pixels are not finite", cmp.non_finite);
    }
    if let Some(t) = args.threshold {
        if cmp.flip_mean > t {
            bail!("FLIP mean {:.6} exceeds the threshold {t}", cmp.flip_mean);
        }
    }
    Ok(())
}
