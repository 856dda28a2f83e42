//! What the self-hits of a scene are: renders it on the GPU with spawn offsets of 2⁻¹⁶ to
//! 2⁻²⁴ of the magnitude behind each hit point (the default is 2⁻²¹), and prints
//! `rays.self_hits` and the blocked shadow rays of each in one Markdown table.
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
use cuberay::arith::spawn::SpawnPolicy;
use cuberay::gpu::GpuRenderer;
use cuberay::job::RenderOptions;
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
    let exponents = [16, 18, 19, 20, 21, 22, 23, 24];
    let policies: Vec<SpawnPolicy> =
        exponents.iter().map(|&k| SpawnPolicy::Relative(2f32.powi(-k))).collect();
    let gpu = GpuRenderer::new()?;
    println!("{size}×{size}, corners, depth 5; each cell: self-hits / blocked shadow rays\n");
    print!("| scene | spawned rays |");
    for (k, p) in exponents.iter().zip(&policies) {
        let default = if p.rel_abs() == SpawnPolicy::Scaled.rel_abs() { " (default)" } else { "" };
        print!(" 2^-{k}{default} |");
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
            if spawn.rel_abs() == SpawnPolicy::Scaled.rel_abs() {
                spawned = r.shadow + r.reflect + r.refract;
            }
            cells.push(format!("{} / {}", r.self_hits, r.shadow_blocked));
        }
        println!("| {path} | {spawned} | {} |", cells.join(" | "));
    }
    Ok(())
}
