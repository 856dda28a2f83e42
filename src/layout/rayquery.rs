//! What the platform's ray queries are built over (`--accel rayquery`, and the rays leaving
//! surfaces under `cube` where the adapter has ray queries; `shaders/shared/rayquery.wgsl`):
//! one box per primitive, in primitive order, so that a candidate's primitive index is the
//! primitive's id. The driver builds and walks its own structure over them and only culls;
//! the kernels test each candidate themselves.
//!
//! **Conservative boxes.** The driver's box test is its own arithmetic, with no slack the
//! kernels could add, and a box it misses hides its primitive. So each box is the BVH's
//! ([`super::bvh::eye_boxes`]: grown by `BVH_PAD_REL` and rounded out to f32) grown once more
//! by [`RQ_PAD_REL`] of the largest coordinate of any box, which bounds where a ray can
//! start: that covers what the BVH walk adds at each test (`BVH_SLACK` of the ray origin's
//! magnitude), an f64 origin rounded to f32, and the rounding of the driver's slab
//! distances. The kernels hand the driver limits grown by `RQ_COMMIT_REL` (2⁻¹²) of
//! themselves.

use bytemuck::{Pod, Zeroable};

use super::bvh::eye_boxes;
use crate::coherence::reach::WalkBounds;
use crate::scene::Scene;

/// Boxes grow by this much of the largest coordinate of any box (eye-relative) on top of the
/// BVH's padding, as the BVH walk grows them by `BVH_SLACK` of the ray origin's.
pub const RQ_PAD_REL: f64 = 1e-5;

/// The limits the kernels hand the driver (a ray's t_max, and each narrower limit a
/// nearest-hit query commits) grow by this much of themselves, 2⁻¹² (WGSL `RQ_COMMIT_REL`).
pub const RQ_COMMIT_REL: f32 = 1.0 / 4096.0;

/// The largest t the kernels hand the driver (WGSL `RQ_T_MAX`): a query's limits must be
/// finite, and a ray's t_max may be `FAR`.
pub const RQ_T_MAX: f32 = 1e37;

/// One box as the driver reads it (`VkAabbPositionsKHR`: six f32, min then max), 24 bytes,
/// the least stride wgpu allows (`AABB_GEOMETRY_MIN_STRIDE`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RqBox {
    pub min: [f32; 3],
    pub max: [f32; 3],
}

/// The boxes of `scene`'s primitives re-centred on its eye (as [`super::pack()`] packs
/// them), padded for the driver's box test (see the module doc).
pub fn rq_boxes(scene: &Scene) -> Vec<RqBox> {
    let boxes = eye_boxes(scene);
    let reach =
        boxes.iter().flat_map(|(lo, hi)| lo.iter().chain(hi).map(|v| v.abs() as f64)).fold(0.0f64, f64::max);
    let pad = RQ_PAD_REL * reach;
    boxes
        .iter()
        .map(|(lo, hi)| {
            let b = crate::scene::Aabb {
                min: glam::DVec3::from_array(lo.map(f64::from)),
                max: glam::DVec3::from_array(hi.map(f64::from)),
            };
            let (min, max) = crate::bvh::outward_box(&b, pad);
            RqBox { min, max }
        })
        .collect()
}

/// Bounds on the ray queries' walks, for the tile size and the wave plan: each is one
/// query, done in the pass that starts it. Its candidates are the driver's to find, a few
/// per level of its tree; a query may in principle hand over every box, `worst` says so.
/// (lavapipe's loop limit, which the other walks keep to, did not cut a ray query in Mesa
/// 25.0, the first lavapipe with them: docs/drivers-and-faults.md.)
pub fn walk_bounds(boxes: &[RqBox]) -> WalkBounds {
    let n = boxes.len().max(1) as u64;
    let mean_list = 2.0 * (n as f64).log2().max(1.0) + 4.0;
    WalkBounds {
        worst_closest: n,
        worst_eye: n,
        worst_shadow: n,
        mean_list,
        planned: 1,
        fallback_reachable: false,
        eye_untabled: false,
        mixed: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_contain_the_bvh_boxes_by_the_padding() {
        let scene = crate::load::nff::parse(
            "v\nfrom 0 0 -10\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\n\
             f 1 0 0 1 0 1 0 1\ns 0 0 0 1\ns 100 0 0 0.5\n",
            std::path::Path::new("two.nff"),
        )
        .unwrap()
        .scene;
        let bvh = eye_boxes(&scene);
        let rq = rq_boxes(&scene);
        assert_eq!(rq.len(), 2);
        let pad = RQ_PAD_REL * 100.5;
        for (b, r) in bvh.iter().zip(&rq) {
            for k in 0..3 {
                assert!(f64::from(r.min[k]) <= f64::from(b.0[k]) - pad, "{r:?} {b:?}");
                assert!(f64::from(r.max[k]) >= f64::from(b.1[k]) + pad, "{r:?} {b:?}");
            }
        }
        assert_eq!(std::mem::size_of::<RqBox>(), 24);
    }
}
