//! Command-line interface: argument parsing (clap) and the subcommands.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};

use cuberay::info::SceneInfo;
use cuberay::load::{self, LoadOptions, Loaded};

mod accuracy;
mod args;
mod bench;
mod compare;
mod merge;
mod preview;
mod render;
mod tables;

#[derive(Parser, Debug)]
#[command(name = "cuberay", version, about = "GPU Whitted ray tracing with direction-cube candidate tables")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print what a scene holds and which effects it calls for.
    Info {
        /// Scene file (.nff, .gltf, .glb).
        scene: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// Also build the direction-cube candidate tables and report their statistics.
        #[arg(long)]
        tables: bool,
        /// glTF: which camera node to look through, counted from 0 in the scene's node order
        /// (default: the first; none: a camera framing the scene).
        #[arg(long)]
        camera: Option<usize>,
        #[command(flatten)]
        scene_args: args::SceneArgs,
    },
    /// Render a scene to an image.
    Render(render::RenderArgs),
    /// Render a scene on the GPU and with the CPU reference and report the differences.
    Compare(compare::CompareArgs),
    /// Open a window that refines the scene progressively (orbit, pan, zoom, fly).
    Preview(preview::PreviewArgs),
    /// Assemble the parts of a render split with --tile or --crop into the whole image.
    Merge(merge::MergeArgs),
    /// Build a GPU render's candidate tables once and store them (render --tables reads them).
    Tables(tables::TablesArgs),
    /// Time accelerators against each other on a set of scenes (default: the SPD canonical
    /// scenes, the tables against the BVH on the GPU).
    Bench(bench::BenchArgs),
    /// Sweep the settings that trade accuracy for time (samples, depth, precision, spawn
    /// offset, table resolution, accelerator) against a converged CPU reference: a table,
    /// JSON, CSV and a plot of error against GPU time.
    Accuracy(accuracy::AccuracyArgs),
}

/// When the command started: its time to an image counts from here.
static STARTED: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();

/// When the command started.
fn started() -> std::time::Instant {
    *STARTED.get_or_init(std::time::Instant::now)
}

pub fn main() -> ExitCode {
    started();
    quiet_device_selection();
    init_logging();
    stop_on_signals();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if let Some(cuberay::Error::Interrupted { signal }) = e.downcast_ref::<cuberay::Error>() {
                eprintln!("interrupted (signal {signal}): nothing was written");
                return ExitCode::from((128 + signal).clamp(0, 255) as u8);
            }
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// What a user sees on stderr: cuberay's warnings as a command-line tool prints them
/// (`warning: …`, each message once, as cargo and ripgrep do) and errors from anywhere,
/// without timestamps or module paths. `RUST_LOG` (e.g. `RUST_LOG=info`,
/// `RUST_LOG=cuberay=debug`) gives env_logger's full records instead.
fn init_logging() {
    if std::env::var_os("RUST_LOG").is_some() {
        env_logger::Builder::from_env(env_logger::Env::default()).init();
        return;
    }
    use std::io::Write;
    let said = std::sync::Mutex::new(std::collections::HashSet::new());
    env_logger::Builder::new()
        .filter_level(log::LevelFilter::Error)
        .filter_module("cuberay", log::LevelFilter::Warn)
        .format(move |out, record| {
            let message = record.args().to_string();
            if !said.lock().map(|mut s| s.insert(message.clone())).unwrap_or(true) {
                return Ok(());
            }
            let level = match record.level() {
                log::Level::Error => "error",
                log::Level::Warn => "warning",
                log::Level::Info => "info",
                log::Level::Debug => "debug",
                log::Level::Trace => "trace",
            };
            writeln!(out, "{level}: {message}")
        })
        .init();
}

/// SIGINT and SIGTERM ask the render to stop ([`cuberay::interrupt`]): it ends within a kernel
/// step, writes nothing and exits with 128 + the signal's number. A second signal ends the
/// process at once.
fn stop_on_signals() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
        log::warn!("cannot install the signal handlers: an interrupted render may leave a temporary file");
        return;
    };
    std::thread::spawn(move || {
        for signal in signals.forever() {
            if cuberay::interrupt::requested().is_some() {
                std::process::exit(128 + signal);
            }
            cuberay::interrupt::request(signal);
        }
    });
}

/// Mesa's Vulkan device-selection layer opens a Wayland connection to learn which GPU drives
/// the display, and libwayland prints "XDG_RUNTIME_DIR is invalid or not set" on every run
/// where that variable is unset. cuberay picks its adapter itself (`WGPU_ADAPTER_NAME`,
/// power preference), so the layer is skipped unless the user set `NODEVICE_SELECT`.
fn quiet_device_selection() {
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: called first in `main`, before any other thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Info { scene, json, camera, tables, scene_args } => {
            let loaded = load_scene(&scene, camera, None, &scene_args.setup())?;
            let info = scene_info(&loaded.scene)?.with_extensions(&scene);
            let stats = match tables {
                true => Some(cuberay::coherence::TableStats::of(&cuberay::coherence::build(
                    &loaded.scene,
                    &Default::default(),
                )?)),
                false => None,
            };
            if json {
                let mut v = serde_json::to_value(&info)?;
                if let Some(s) = &stats {
                    v["tables"] = serde_json::to_value(s)?;
                }
                println!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                print!("{}", info.to_text());
                if let Some(s) = &stats {
                    print!("{}", s.to_text());
                }
            }
            Ok(())
        }
        Command::Render(args) => render::run(args),
        Command::Compare(args) => compare::run(args),
        Command::Preview(args) => preview::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Tables(args) => tables::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Accuracy(args) => accuracy::run(args),
    }
}

/// What `info` says of `scene`: what it holds, and what a render of it at its default size
/// resolves on the adapter a render would open (without one, the choices that depend on it
/// stay `auto`, and the summary says that no adapter was found).
fn scene_info(scene: &cuberay::scene::Scene) -> anyhow::Result<SceneInfo> {
    let (w, h) = scene.resolution.unwrap_or_else(|| scene.camera.default_resolution());
    let opts = cuberay::job::RenderOptions::new(w, h);
    let ctx = cuberay::gpu::GpuContext::new().map_err(|e| log::info!("info without an adapter: {e}")).ok();
    let caps = ctx.as_ref().map(|c| c.capabilities());
    // Where the adapter refuses what the scene asks for (f64 on an adapter without it), the
    // choices are shown as made without it, and the refusal is said.
    let resolved = cuberay::gpu::choose(scene, &opts, caps.as_ref());
    let refusal = match (cuberay::gpu::check(scene, &opts), &resolved) {
        (Err(e), _) => Some(e.to_string()),
        (Ok(()), Err(e)) => Some(e.to_string()),
        (Ok(()), Ok(_)) => None,
    };
    let resolved = match resolved {
        Ok(r) => r,
        Err(_) => cuberay::gpu::choose(scene, &opts, None)?,
    };
    let mut info = SceneInfo::of(scene, &resolved, caps.map(|c| c.adapter));
    info.gpu_refuses = refusal;
    Ok(info)
}

/// Loads a scene, sets it up as the command line says (camera, environment), and reports the
/// loader's warnings on stderr.
fn load_scene(
    path: &std::path::Path,
    camera: Option<usize>,
    time: Option<f64>,
    setup: &load::Setup,
) -> anyhow::Result<Loaded> {
    let mut loaded = load::load(path, &LoadOptions { camera, time }).context("cannot load the scene")?;
    load::apply_setup(&mut loaded, path, setup).context("cannot set the scene up")?;
    for w in &loaded.warnings {
        log::warn!("{}: {w}", path.display());
    }
    Ok(loaded)
}
