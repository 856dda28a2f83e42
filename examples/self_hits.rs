//! What the self-hits of a scene are: renders it on the GPU with the default spawn offset and
//! with fixed offsets from 4e-4 down by factors of 4, and prints `rays.self_hits` and the
//! blocked shadow rays of each in one Markdown table.
//!
//! Self-hits that fall with the offset while the blocked shadow rays stay put are rays
//! meeting a neighbour that touches their surface (tangent spheres, a cylinder's end in its
//! joint sphere, a concave crease): the zone where that neighbour lies within 4 offsets
//! shrinks with the offset. Self-hits that rise as the offset falls, with more rays blocked,
//! are acne: the offset is below the rounding error of the hit points.
//!
//! `cargo run --release --example self_hits -- [--size N] SCENE...` (SPD procedure: corner
//! sampling, depth 5, 256×256 unless `--size N`).

use anyhow::{bail, Context};
use cuberay::gpu::GpuRenderer;
use cuberay::job::RenderOptions;
use cuberay::kernel::spawn::SpawnPolicy;
use cuberay::load::{self, LoadOptions};
use cuberay::sampling::Sampling;
use indicatif::ProgressBar;

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut size = 256;
    if let Some(i) = args.iter().position(|a| a == "--size") {
        size = args.get(i + 1).context("--size needs a number")?.parse().context("--size")?;
        args.drain(i..i + 2);
    }
    if args.is_empty() {
        bail!("usage: self_hits [--size N] SCENE...");
    }
    let mut policies = vec![SpawnPolicy::Scaled];
    policies.extend((0..7).map(|k| SpawnPolicy::Fixed(4e-4 / 4f32.powi(k))));
    let gpu = GpuRenderer::new()?;
    println!("{size}×{size}, corners, depth 5; each cell: self-hits / blocked shadow rays\n");
    print!("| scene | spawned rays |");
    for p in &policies {
        match p {
            SpawnPolicy::Scaled => print!(" default (2⁻¹⁶·scale) |"),
            SpawnPolicy::Fixed(e) => print!(" {e:.2e} |"),
        }
    }
    println!("\n|---|---|{}", "---|".repeat(policies.len()));
    let hidden = ProgressBar::hidden();
    for path in &args {
        let scene = load::load(path.as_ref(), &LoadOptions::default())?.scene;
        let mut cells = Vec::new();
        let mut spawned = 0;
        for &spawn in &policies {
            let opts = RenderOptions { spawn, sampling: Sampling::Corners, ..RenderOptions::new(size, size) };
            let r = gpu.render(&scene, &opts, &hidden)?.stats.rays;
            if spawn == SpawnPolicy::Scaled {
                spawned = r.shadow + r.reflect + r.refract;
            }
            cells.push(format!("{} / {}", r.self_hits, r.shadow_blocked));
        }
        println!("| {path} | {spawned} | {} |", cells.join(" | "));
    }
    Ok(())
}
