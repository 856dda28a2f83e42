//! `cuberay preview`: the interactive window (see [`cuberay::preview`]) with the render
//! options of `cuberay render`, plus `--frames` and `--screenshot` for automation.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;

use cuberay::output::OutputFormat;
use cuberay::preview::{self, Config, Orbit};

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
    /// Scripted motion: turn the camera by DEG degrees about the look-at point every frame,
    /// as a left drag would, from the second frame on, for --orbit-frames frames; then the
    /// camera rests (and --frames counts the samples accumulated after that).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub orbit: Option<f64>,
    /// Frames the --orbit turns the camera on.
    #[arg(long, value_name = "N", default_value_t = 30, requires = "orbit")]
    pub orbit_frames: u32,
    /// Write one JSON object per frame to this file: frame, ms, moved, points_traced,
    /// passes, depth, eye_table ("building", "ready" or "none").
    #[arg(long, value_name = "FILE")]
    pub frame_log: Option<PathBuf>,
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
    if let Some(deg) = args.orbit {
        if !deg.is_finite() || deg.abs() > 360.0 {
            bail!("--orbit {deg}: give the degrees per frame as a number from -360 to 360");
        }
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
        orbit: args.orbit.map(|degrees| Orbit { degrees, frames: args.orbit_frames }),
        frame_log: args.frame_log,
    };
    preview::run(config).with_context(|| format!("cannot preview {}", scene_name.display()))
}
