//! `cuberay tables`: build the candidate tables a GPU render with the same scene and
//! options would build, and store them (`render --tables FILE` reads them), so that the
//! tasks of a split render share one build.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::args::AovArg;
use cuberay::coherence::{self, TableStats};
use cuberay::gpu::prepare::{build_params, Purpose};
use cuberay::tablefile;

use super::render::TraceArgs;

#[derive(Args, Debug)]
pub struct TablesArgs {
    /// Scene file (.nff, .gltf, .glb); without one, the built-in showcase.
    pub scene: Option<PathBuf>,
    /// The tables file to write.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The render's options (the tables depend on the image size, depth, accelerator,
    /// camera): give the ones the renders that read the file will use.
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Build the tables of an auxiliary-output render (`render --aov`), which traces eye
    /// rays only.
    #[arg(long, value_enum)]
    pub aov: Option<AovArg>,
    /// Build the tables of this frame of a glTF animation (`render --frames F..F`).
    #[arg(long)]
    pub frame: Option<u32>,
    /// Frames per second of --frame.
    #[arg(long, default_value_t = 24.0, requires = "frame")]
    pub fps: f64,
}

pub fn run(args: TablesArgs) -> anyhow::Result<()> {
    if !(args.fps.is_finite() && args.fps > 0.0) {
        anyhow::bail!("--fps {} is not a positive number of frames per second", args.fps);
    }
    let time = args.frame.map(|f| f as f64 / args.fps);
    let (scene_name, loaded, opts) = args.trace.load_at(&args.scene, time)?;
    let scene = &loaded.scene;
    let purpose = args.aov.map_or(Purpose::Render, |a| Purpose::Aov(a.into()));
    let params = build_params(scene, &opts, purpose)?.with_context(|| {
        format!("--accel {} traces no tables: there is nothing to build", opts.accel.name())
    })?;
    let t = coherence::build(scene, &params)
        .with_context(|| format!("cannot build the tables of {}", scene_name.display()))?;
    let key = tablefile::key(scene, &params);
    tablefile::write(&args.output, &key, &scene_name.display().to_string(), &t.flat)?;
    let stats = TableStats::of(&t);
    eprintln!(
        "{}: {} origins, {} entries, {:.1} MiB, built in {:.2} s",
        args.output.display(),
        t.flat.origins.len(),
        t.flat.entries.len(),
        t.flat.bytes() as f64 / (1u64 << 20) as f64,
        t.build_s
    );
    log::info!("{}", stats.to_text());
    Ok(())
}
