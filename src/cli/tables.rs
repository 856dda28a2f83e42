//! `cuberay tables`: build the candidate tables a GPU render with the same scene and
//! options would build, and store them (`render --tables FILE` reads them), so that the
//! tasks of a split render share one build.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use cuberay::coherence::{self, TableStats};
use cuberay::gpu::GpuRenderer;
use cuberay::output::Aov;
use cuberay::tablefile;

use super::render::{scene_identity, TraceArgs};

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
    pub aov: Option<Aov>,
}

pub fn run(args: TablesArgs) -> anyhow::Result<()> {
    let (scene_name, loaded, opts) = args.trace.load(&args.scene)?;
    let scene = &loaded.scene;
    let params = GpuRenderer::build_params(scene, &opts, args.aov.is_some())
        .context("--accel brute traces no tables: there is nothing to build")?;
    let id = scene_identity(&args.scene, args.trace.camera, None, None)?;
    let t = coherence::build(scene, &params)
        .with_context(|| format!("cannot build the tables of {}", scene_name.display()))?;
    let key = tablefile::key(&id.fingerprint(), &params);
    tablefile::write(&args.output, &key, &id.name, &t.flat, &t.walks)?;
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
