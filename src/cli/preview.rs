//! `cuberay preview`: the interactive window (see [`cuberay::preview`]) with the render
//! options of `cuberay render`, plus `--frames` and `--screenshot` for automation.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;

use cuberay::output::OutputFormat;
use cuberay::preview::{self, Config};

use super::render::TraceArgs;

/// Samples the preview accumulates when neither --spp nor --frames says.
const DEFAULT_SPP: u32 = 256;

#[derive(Args, Debug)]
pub struct PreviewArgs {
    /// Scene file (.nff, .gltf, .glb). Without one, the built-in showcase.
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Exit after N accumulated frames (one sample per pixel each); with --spp N (the
    /// default) the last frame equals `cuberay render --spp N`.
    #[arg(long)]
    pub frames: Option<u32>,
    /// Save the last frame to this PNG file when the preview exits (written atomically).
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
}

pub fn run(args: PreviewArgs) -> anyhow::Result<()> {
    if let Some(path) = &args.screenshot {
        if OutputFormat::from_path(path)? != OutputFormat::Png {
            bail!("{}: --screenshot writes a PNG (.png) file", path.display());
        }
    }
    if args.frames == Some(0) {
        bail!("--frames must be at least 1");
    }
    let (scene_name, loaded, mut opts) = args.trace.load(&args.scene)?;
    if args.trace.spp.is_none() && opts.sampling != cuberay::sampling::Sampling::Corners {
        opts.spp = args.frames.unwrap_or(DEFAULT_SPP);
    }
    if let Some(frames) = args.frames {
        if frames > opts.spp {
            bail!(
                "--frames {frames} is more than the {} samples per pixel the preview accumulates (--spp)",
                opts.spp
            );
        }
    }
    let config = Config {
        scene: loaded.scene,
        name: scene_name.display().to_string(),
        opts,
        frames: args.frames,
        screenshot: args.screenshot,
    };
    preview::run(config).with_context(|| format!("cannot preview {}", scene_name.display()))
}
