//! GPU tests run on whatever adapter wgpu finds (lavapipe in CI). Without one they fail,
//! and the message says how to install lavapipe. Images are small to keep lavapipe fast.
//! Every scene is its own test (a failure names its scene and hides no other), and a
//! failed comparison writes both images and the FLIP map into the tests' scratch folder,
//! naming the files in its message.
//!
//! This module holds what the areas share (the showcase, the SPD scenes, and [`agree`], the
//! GPU-against-CPU check); the tests are in one sub-module per area:
//!
//! - `agreement`: GPU against CPU per scene: the showcase (with its statistics, jittered,
//!   at the corners, far from the origin, its AOVs), the SPD databases, and the self-hits of
//!   a spawn offset too small;
//! - `gltf_samples`: the glTF sample models against the CPU, every map applied;
//! - `closed_forms`: the maps' own scenes (vertex colours, alpha mask and blend, a half-metal
//!   texture, a tilted normal map) against closed forms, pixel by pixel;
//! - `accels`: the tables and the BVH against brute force on the GPU, pixel for pixel, and
//!   against the CPU; BVH walks longer than a step; brute force within lavapipe's loop
//!   limit;
//! - `device`: kernels compiled once per effect set, an uncounted render, memory over a long
//!   render, a lost device, the first dispatch timed apart;
//! - `commands`: `render` and `compare` on the GPU from the command line;
//! - `split`: primitives split over several bindings;
//! - `untabled`: `--accel auto`'s origins without a table, and what it chooses.

use crate::common::renderer;
use cuberay::compare::compare;
use cuberay::job::{RenderOptions, Rendered};
use cuberay::load;
use cuberay::reference;
use cuberay::scene::Scene;
use indicatif::ProgressBar;

mod accels;
mod agreement;
mod closed_forms;
mod commands;
mod device;
mod gltf_samples;
mod split;
mod untabled;

fn hidden() -> ProgressBar {
    ProgressBar::hidden()
}

fn showcase() -> Scene {
    load::showcase().expect("showcase loads").scene
}

fn spd(name: &str) -> Scene {
    let p = crate::common::shared(&format!("spd/nff/{name}.nff"));
    load::load(&p, &Default::default()).unwrap_or_else(|e| panic!("{name}: {e}")).scene
}

/// Renders on both backends and checks agreement: FLIP mean, finite pixels, and ray
/// counts by kind within 2% (where two surfaces cross or lie within f32's error bound of
/// each other, the GPU's tie rule takes the lower id and the CPU's f64 the nearer surface:
/// measured 1.2 % more shadow rays on LightsPunctualLamp).
pub(crate) fn agree(name: &str, scene: &Scene, opts: &RenderOptions, max_flip: f64) -> (Rendered, Rendered) {
    let g = renderer().render(scene, opts, &hidden()).unwrap_or_else(|e| panic!("{name}: {e}"));
    let c = reference::render(scene, opts, &hidden()).unwrap();
    assert!(g.image.is_finite(), "{name}: non-finite GPU pixel");
    let (cmp, heat) = compare(&c.image, &g.image, 2.0 / 255.0);
    eprintln!(
        "{name}: FLIP mean {:.5}, RMSE {:.5}, rays gpu {} cpu {}",
        cmp.flip_mean, cmp.rmse, g.stats.rays.total, c.stats.rays.total
    );
    if cmp.flip_mean > max_flip {
        let files = crate::common::save_failure(
            name,
            &[("gpu", &g.image), ("cpu", &c.image)],
            Some((&heat, opts.width, opts.height)),
        );
        panic!("{name}: FLIP mean {} > {max_flip}; images: {files}", cmp.flip_mean);
    }
    let (gr, cr) = (g.stats.rays, c.stats.rays);
    for (kind, a, b) in [
        ("eye", gr.eye, cr.eye),
        ("shadow", gr.shadow, cr.shadow),
        ("reflect", gr.reflect, cr.reflect),
        ("refract", gr.refract, cr.refract),
    ] {
        let tol = (b as f64 * 0.02).max(1.0);
        assert!((a as f64 - b as f64).abs() <= tol, "{name}: {kind} rays gpu {a} cpu {b}");
    }
    assert_eq!(g.stats.effects, c.stats.effects, "{name}: simulated effects");
    // Self-hits: none with the reference's tiny offsets; on the GPU only rays leaving near
    // where two primitives touch or cross (tangent spheres, a cylinder's end in its joint
    // sphere, overlapping spheres, where the tie rule may take the farther surface within
    // f32's error bound, so that a ray leaving it starts inside the nearer: 3 of 1451 on
    // shells_s2), far fewer than any acne (`a_spawn_offset_too_small_shows_as_self_hits`).
    assert_eq!(cr.self_hits, 0, "{name}: CPU self-hits");
    let spawned = (gr.shadow + gr.reflect + gr.refract).max(1);
    assert!(gr.self_hits * 200 <= spawned, "{name}: {} self-hits of {spawned} spawned rays", gr.self_hits);
    (g, c)
}
