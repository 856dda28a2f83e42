//! Measures what the preview redoes when the eye moves, on scene files:
//! - `pack_ms`: packing the geometry relative to the new eye (what the brute-force GPU
//!   renderer needs today; the preview then uploads it);
//! - `eye_build_ms`: `coherence::build` of the scene without lights and without mirrors or
//!   glass, i.e. only the eye's table (plus the per-build targets and BVH, which do not
//!   depend on the eye: an upper bound for rebuilding the eye table alone), for the image
//!   size given.
//!
//! Each figure is the median of `--repeat` runs (default 5), the eye orbited by a few
//! degrees between runs as the preview's mouse would.
//!
//! `cargo run --release --example eye_rebuild -- [--size WxH] [--repeat K] SCENE...` prints
//! one JSON object per scene.

use std::time::Instant;

use cuberay::coherence::{self, BuildParams};
use cuberay::gpu::layout;
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
        let scene = load::load(path.as_ref(), &LoadOptions::default())?.scene;
        // The eye's table only: no light origins, no surface origins.
        let mut eye_only = scene.clone();
        eye_only.lights.clear();
        for m in &mut eye_only.materials {
            m.mirror = glam::DVec3::ZERO;
            m.transmittance = 0.0;
        }
        let params = BuildParams { image: Some((w, h)), ..BuildParams::default() };
        let mut controller = Controller::new(&scene);
        let (mut pack, mut build) = (Vec::new(), Vec::new());
        let mut eye_n = 0;
        for _ in 0..repeat.max(1) {
            controller.orbit(20.0, 5.0);
            let mut moved = scene.clone();
            moved.camera = controller.camera().clone();
            let textures = std::mem::take(&mut moved.textures);
            let start = Instant::now();
            let packed = layout::pack(&moved, w, h);
            pack.push(start.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(packed);
            moved.textures = textures;
            eye_only.camera = controller.camera().clone();
            let start = Instant::now();
            let tables = coherence::build(&eye_only, &params)?;
            build.push(start.elapsed().as_secs_f64() * 1e3);
            eye_n = tables.defs.first().map_or(0, |d| d.n);
        }
        println!(
            "{}",
            serde_json::json!({
                "scene": path,
                "primitives": scene.primitives.len(),
                "image": [w, h],
                "eye_n": eye_n,
                "pack_ms": median(pack),
                "eye_build_ms": median(build),
            })
        );
    }
    Ok(())
}
