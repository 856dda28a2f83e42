//! Measures what the preview redoes when the eye moves, on scene files:
//! - `pack_ms`: packing the geometry relative to the new eye (uploaded with the tables);
//! - `rebuild_ms`: [`Tables::rebuild_eye`](cuberay::coherence::Tables::rebuild_eye) with the
//!   GPU's parameters for the image size given: the eye's table rebuilt and the tables
//!   flattened again, the light and surface tables kept (`eye_only` counts the moves where
//!   that held; the others rebuilt everything);
//! - `full_ms`: building all tables, for comparison.
//!
//! The eye is orbited by a few degrees before each of `--repeat` runs (default 5), as the
//! preview's mouse would; the figures are medians.
//!
//! `cargo run --release --example eye_rebuild -- [--size WxH] [--repeat K] SCENE...` prints
//! one JSON object per scene.

use std::time::Instant;

use cuberay::arith::spawn::SpawnPolicy;
use cuberay::coherence;
use cuberay::layout;
use cuberay::load::{self, LoadOptions};
use cuberay::preview::controls::Controller;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut value = |name: &str| -> Option<String> {
        let i = args.iter().position(|a| a == name)?;
        let v = args.remove(i + 1);
        args.remove(i);
        Some(v)
    };
    let size = value("--size").unwrap_or_else(|| "512x512".into());
    let (w, h) = size.split_once('x').ok_or_else(|| anyhow::anyhow!("--size WxH"))?;
    let (w, h): (u32, u32) = (w.parse()?, h.parse()?);
    let repeat: usize = value("--repeat").map(|v| v.parse()).transpose()?.unwrap_or(5);
    for path in &args {
        let mut scene = load::load(path.as_ref(), &LoadOptions::default())?.scene;
        let params = |s: &cuberay::scene::Scene| {
            layout::budget::table_params(s, w, h, s.effects(), SpawnPolicy::Scaled)
        };
        let start = Instant::now();
        let mut tables = coherence::build(&scene, &params(&scene))?;
        let full_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut controller = Controller::new(&scene);
        let (mut pack, mut rebuild) = (Vec::new(), Vec::new());
        let mut eye_only = 0;
        for _ in 0..repeat.max(1) {
            controller.orbit(20.0, 5.0);
            scene.camera = controller.camera().clone();
            let textures = std::mem::take(&mut scene.textures);
            let start = Instant::now();
            let packed = layout::pack(&scene, w, h, SpawnPolicy::Scaled);
            pack.push(start.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(packed);
            scene.textures = textures;
            let start = Instant::now();
            eye_only += tables.rebuild_eye(&scene, &params(&scene))? as usize;
            rebuild.push(start.elapsed().as_secs_f64() * 1e3);
        }
        println!(
            "{}",
            serde_json::json!({
                "scene": path,
                "primitives": scene.primitives.len(),
                "image": [w, h],
                "eye_n": tables.defs.first().map_or(0, |d| d.n),
                "pack_ms": median(pack),
                "rebuild_ms": median(rebuild),
                "eye_only": eye_only,
                "moves": repeat.max(1),
                "full_ms": full_ms,
            })
        );
    }
    Ok(())
}
