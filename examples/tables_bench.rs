//! Measures the candidate tables on scene files: build statistics and, with `--trace`, the
//! mean number of primitive tests per ray by kind over the SPD corner sampling at 512×512
//! (513² eye rays) and the ray trees they spawn (depth 5), in f32 with the table walker (rays
//! leaving surfaces have no table: the walker takes the fallback origin, every primitive, for
//! them, where the GPU walks its BVH; their figures count brute force).
//!
//! `cargo run --release --example tables_bench -- [--trace] [--verify K] [--size W]
//!  [--budget-mib M] [--eye-n N] [--light-cells C] [--fixed-offset K] SCENE...` prints one JSON
//!  object per scene. `--fixed-offset K` builds for a fixed spawn offset of K times the scene's
//!  bounding diagonal (as `cuberay accuracy`'s offset rows do).

use cuberay::coherence::{self, audit, BuildParams, TableStats};
use cuberay::load::{self, LoadOptions};

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut flag = |name: &str| -> bool {
        let found = args.iter().position(|a| a == name);
        if let Some(i) = found {
            args.remove(i);
        }
        found.is_some()
    };
    let trace = flag("--trace");
    let mut value = |name: &str| -> Option<String> {
        let i = args.iter().position(|a| a == name)?;
        let v = args.remove(i + 1);
        args.remove(i);
        Some(v)
    };
    let verify: u32 = value("--verify").map(|v| v.parse()).transpose()?.unwrap_or(0);
    let size: u32 = value("--size").map(|v| v.parse()).transpose()?.unwrap_or(512);
    let eye_n: Option<u32> = value("--eye-n").map(|v| v.parse()).transpose()?;
    let light_cells: Option<usize> = value("--light-cells").map(|v| v.parse()).transpose()?;
    let fixed_offset: Option<f64> = value("--fixed-offset").map(|v| v.parse()).transpose()?;
    for path in &args {
        let loaded = load::load(path.as_ref(), &LoadOptions::default())?;
        let scene = loaded.scene;
        let mut params = BuildParams { image: Some((size, size)), eye_n, ..BuildParams::default() };
        if let Some(c) = light_cells {
            params.light_cells = c;
        }
        if let Some(k) = fixed_offset {
            params.spawn = cuberay::arith::spawn::SpawnPolicy::Fixed((k * scene.bounds().diagonal()) as f32);
        }
        let tables = coherence::build(&scene, &params)?;
        tables.flat.check(scene.primitives.len()).map_err(anyhow::Error::msg)?;
        let stats = TableStats::of(&tables);
        let mut out =
            serde_json::json!({ "scene": path, "primitives": scene.primitives.len(), "tables": stats });
        if trace {
            let b = audit::trace_counts(
                &scene,
                &tables,
                audit::AuditParams {
                    width: size,
                    height: size,
                    corners: true,
                    max_depth: 5,
                    verify_every: verify,
                },
            );
            out["trace"] = serde_json::to_value(&b)?;
        }
        println!("{}", serde_json::to_string(&out)?);
    }
    Ok(())
}
