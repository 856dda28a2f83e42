//! Times the GPU renderer on the seven canonical SPD scenes (balls_s4, gears_s4, mount_s6,
//! rings_s7, teapot_s12, tetra_s6, tree_s11) by the SPD procedure: corner sampling, depth 5,
//! 512×512 unless `--size N`. Each scene is first rendered at 32×32 with the same kernel (the
//! warm-up: compilation, caches), then timed; `--cpu` also times the f64 CPU reference in the
//! same run, as the baseline.
//!
//! `cargo run --release --example spd_times -- [--size N] [--cpu] [SCENE_DIR]` prints one
//! Markdown table: the times of `--stats` (`time.*`), the rays traced, the self-hits
//! (`rays.self_hits`) and the process's peak memory so far. SCENE_DIR defaults to `../shared/scenes/spd/nff`.

use std::path::PathBuf;

use anyhow::{bail, Context};
use cuberay::gpu::GpuRenderer;
use cuberay::job::RenderOptions;
use cuberay::load::{self, LoadOptions};
use cuberay::sampling::Sampling;
use indicatif::ProgressBar;

const SCENES: [&str; 7] =
    ["balls_s4", "gears_s4", "mount_s6", "rings_s7", "teapot_s12", "tetra_s6", "tree_s11"];

/// The process's peak resident memory (MiB), from `/proc/self/status`.
fn peak_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn opt(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{v:.3}"))
}

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let cpu = match args.iter().position(|a| a == "--cpu") {
        Some(i) => {
            args.remove(i);
            true
        }
        None => false,
    };
    let mut size = 512;
    if let Some(i) = args.iter().position(|a| a == "--size") {
        size = args.get(i + 1).context("--size needs a number")?.parse().context("--size")?;
        args.drain(i..i + 2);
    }
    let dir = PathBuf::from(args.first().map_or("../shared/scenes/spd/nff", |s| s.as_str()));
    if !dir.is_dir() {
        bail!("{} is missing: the SPD scenes live in ../shared/scenes beside the repository", dir.display());
    }
    let gpu = GpuRenderer::new()?;
    let info = &gpu.ctx.info;
    println!("GPU: {}, {}; {size}×{size}, corners, depth 5\n", info.name, info.driver_info);
    print!("| scene | prims | preprocess s | warm-up compile s | gpu s | trace s | longest submit ms | rays | self-hits | peak MiB |");
    println!("{}", if cpu { " cpu trace s | cpu / gpu trace |" } else { "" });
    println!("|---|---|---|---|---|---|---|---|---|---|{}", if cpu { "---|---|" } else { "" });
    let hidden = ProgressBar::hidden();
    for name in SCENES {
        let path = dir.join(format!("{name}.nff"));
        let scene = load::load(&path, &LoadOptions::default())?.scene;
        let opts =
            |s| RenderOptions { sampling: Sampling::Corners, max_depth: 5, ..RenderOptions::new(s, s) };
        let warm = gpu.render(&scene, &opts(32), &hidden)?.stats.time;
        let t = gpu.render(&scene, &opts(size), &hidden)?.stats;
        let time = &t.time;
        print!(
            "| {name} | {} | {:.3} | {} | {} | {:.3} | {:.1} | {} | {} | {:.0} |",
            scene.primitives.len(),
            time.preprocess_s,
            opt(warm.compile_s),
            opt(time.gpu_s),
            time.trace_s,
            time.longest_submit_s.unwrap_or(0.0) * 1e3,
            t.rays.total,
            t.rays.self_hits,
            peak_mib().unwrap_or(f64::NAN),
        );
        if cpu {
            let c = cuberay::reference::render(&scene, &opts(size), &hidden)?.stats.time;
            print!(" {:.3} | {:.2} |", c.trace_s, c.trace_s / time.trace_s);
        }
        println!();
    }
    Ok(())
}
