//! Primitives split over several bindings, as a scene too large for one binding has them
//! (lavapipe's holds 128 MiB: two million primitives in f32): an adapter said to hold only a
//! few dozen primitives a binding renders the same bytes as one that holds them all, with
//! every accelerator, in f32 and in f64, and a scene past four such bindings is refused
//! before anything is built, naming the limit.

use super::{hidden, spd};
use cuberay::gpu::GpuRenderer;
use cuberay::job::{Accel, Precision, RenderOptions};
use cuberay::layout::{Prim, Prim64};

/// A renderer of its own whose bindings hold `bytes`.
fn narrow(bytes: u64) -> GpuRenderer {
    let mut r = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    r.caps.max_binding = bytes;
    r
}

#[test]
fn primitives_split_over_bindings_render_the_same_bytes() {
    let scene = spd("balls_s2");
    let n = scene.primitives.len() as u64;
    let wide = crate::common::renderer();
    for (precision, size) in [(Precision::F32, size_of::<Prim>()), (Precision::F64, size_of::<Prim64>())] {
        // Four bindings, the last one partly full.
        let per = n.div_ceil(4) + 1;
        let r = narrow(per * size as u64);
        for accel in Accel::GPU.into_iter().filter(|&a| a != Accel::RayQuery || r.caps.ray_queries) {
            let opts = RenderOptions { accel, precision, ..RenderOptions::new(40, 30) };
            let split = r.render(&scene, &opts, &hidden()).unwrap_or_else(|e| panic!("{accel:?}: {e}"));
            let whole = wide.render(&scene, &opts, &hidden()).unwrap();
            assert!(
                split.image.pixels == whole.image.pixels,
                "{accel:?} {precision:?}: the split primitives render other pixels"
            );
        }
    }
}

#[test]
fn primitives_past_four_bindings_are_refused_before_a_build() {
    let scene = spd("balls_s2");
    let n = scene.primitives.len() as u64;
    let r = narrow((n / 5) * size_of::<Prim>() as u64);
    let opts = RenderOptions { precision: Precision::F32, ..RenderOptions::new(8, 8) };
    let e = r.render(&scene, &opts, &hidden()).err().expect("refused").to_string();
    assert!(e.contains("more than 4 bindings") && e.contains("--backend cpu"), "{e}");
}
