//! `--accel auto`'s per-origin choice: the tables with some origins left without a table
//! (their rays walk the BVH) render the same bytes as every table and as the BVH alone, in
//! f32 and f64, for the eye, a light, or both left out; and `auto` picks the BVH for a small
//! image of a big scene and the tables for a big image of a small one, saying why.

use super::{hidden, showcase, spd};
use crate::common::renderer;
use cuberay::coherence::OriginKey;
use cuberay::gpu::prepare::{prepare, Purpose};
use cuberay::gpu::shaders::Depths;
use cuberay::job::{Accel, Precision, RenderOptions};
use cuberay::scene::Scene;

fn render(scene: &Scene, opts: &RenderOptions) -> Vec<[f32; 4]> {
    let r = renderer().render(scene, opts, &hidden()).unwrap_or_else(|e| panic!("{opts:?}: {e}"));
    r.image.pixels
}

fn same_with_origins_untabled(name: &str, scene: &Scene) {
    for precision in [Precision::F32, Precision::F64] {
        let base = RenderOptions { precision, accel: Accel::Cube, ..RenderOptions::new(40, 30) };
        let whole = render(scene, &base);
        let bvh = render(scene, &RenderOptions { accel: Accel::Bvh, ..base.clone() });
        assert!(whole == bvh, "{name} {precision:?}: the tables and the BVH differ");
        let lights = scene.lights.len();
        for untabled in [
            vec![OriginKey::Eye],
            vec![OriginKey::Light(0)],
            vec![OriginKey::Eye, OriginKey::Light(lights - 1)],
            (0..lights).map(OriginKey::Light).collect(),
        ] {
            let opts = RenderOptions { untabled: untabled.clone(), ..base.clone() };
            // What the kernels are given: no table for those origins, and for the eye's
            // rays the later depths' module at every depth.
            let p = prepare(scene, &opts, &renderer().caps, Purpose::Render, None).unwrap();
            let flat = p.tables.as_ref().expect("tables").flat();
            let eye = untabled.contains(&OriginKey::Eye);
            assert_eq!(flat.eye_origin == u32::MAX, eye, "{name}: {untabled:?}");
            assert_eq!(p.stages.iter().any(|s| s.depths == Depths::Untabled), eye, "{name}: {untabled:?}");
            for &key in &untabled {
                if let OriginKey::Light(i) = key {
                    assert_eq!(flat.light_origin[i], u32::MAX, "{name}: {untabled:?}");
                }
            }
            assert!(
                render(scene, &opts) == whole,
                "{name} {precision:?}: with {untabled:?} untabled the image differs"
            );
        }
    }
}

#[test]
fn untabled_origins_render_the_same_bytes_showcase() {
    same_with_origins_untabled("showcase", &showcase());
}

#[test]
fn untabled_origins_render_the_same_bytes_balls() {
    same_with_origins_untabled("balls_s2", &spd("balls_s2"));
}

#[test]
fn untabled_origins_render_the_same_bytes_tetra() {
    // No mirror: without the eye's table its kernels gain the BVH walk they otherwise lack.
    same_with_origins_untabled("tetra_s3", &spd("tetra_s3"));
}

#[test]
fn auto_weighs_the_build_against_the_rays() {
    let scene = spd("balls_s2");
    let tiny = renderer().render(&scene, &RenderOptions::new(8, 8), &hidden()).unwrap();
    let why = tiny.stats.settings.accel_auto.clone().expect("auto says why");
    assert_eq!(tiny.stats.settings.accel, "bvh", "{why}");
    assert!(why.starts_with("no tables"), "{why}");
    let big = RenderOptions { spp: 16, ..RenderOptions::new(512, 512) };
    let opts = cuberay::gpu::choose(&scene, &big, Some(&renderer().caps)).unwrap();
    let why = opts.auto_accel.as_ref().expect("auto says why").reason();
    assert_eq!(opts.accel, Accel::Cube, "{why}");
    assert!(!opts.untabled.contains(&OriginKey::Eye), "{why}");
    let given = renderer().render(
        &scene,
        &RenderOptions { accel: Accel::Cube, ..RenderOptions::new(8, 8) },
        &hidden(),
    );
    assert_eq!(given.unwrap().stats.settings.accel_auto, None);
}
