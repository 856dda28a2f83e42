//! `cuberay merge`: assemble the partial EXRs of `--tile` or `--crop` renders into the whole
//! image (PNG or EXR, written atomically) and, with `--stats`, the whole render's statistics.

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;

use cuberay::output::{self, OutputFormat};
use cuberay::part;

use super::render::StatsFormat;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The parts: .exr files written by `cuberay render --tile I/N` or `--crop`.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// The whole image: .png or .exr, byte for byte what one render of it would write.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Print the whole render's statistics (the parts' counts added up): text or JSON.
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "text")]
    pub stats: Option<StatsFormat>,
}

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    OutputFormat::from_path(&args.output)?;
    if let Some(same) = args.parts.iter().find(|p| **p == args.output) {
        bail!("{}: the output would overwrite one of the parts", same.display());
    }
    let parts = args.parts.iter().map(|p| part::read_part(p)).collect::<Result<Vec<_>, _>>()?;
    let merged = part::merge(&parts)?;
    output::write(&merged.image, &args.output)?;
    match args.stats {
        Some(StatsFormat::Json) => println!("{}", merged.stats.to_json()),
        Some(StatsFormat::Text) => print!("{}", merged.stats.to_text()),
        None => {}
    }
    Ok(())
}
