//! The bounding volume hierarchies of `--accel bvh` and of the rays leaving surfaces, built by
//! the `obvhs` crate (PLOC with reinsertion) over boxes rounded outward to f32, so that every
//! f32 box contains its primitive: a binary tree ([`build`], leaves of up to 8 primitives
//! collapsed by SAH) that the CPU reference traverses in f64 with a stack, and the compressed
//! 8-wide tree of Ylitie, Karras and Laine (2017) that the GPU walks ([`build_wide`], leaves
//! of up to 3 primitives; [`crate::layout::bvh`] re-quantises its boxes conservatively).
//!
//! This is the baseline every speed claim of the candidate tables is a ratio against: what a
//! user would pick instead of them.

use glam::{DVec3, Vec3A};
use obvhs::{aabb::Aabb as ObvhsAabb, bvh2::Bvh2, Boundable, BvhBuildParams};

use crate::scene::Aabb;

/// The most primitives one leaf holds.
pub const MAX_LEAF: u32 = 8;

/// One node: its box, and either two children (`count` 0: the children are nodes `first` and
/// `first + 1`) or `count` primitives (`order[first..first + count]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeNode {
    pub min: [f32; 3],
    pub max: [f32; 3],
    pub count: u32,
    pub first: u32,
}

impl TreeNode {
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// A binary BVH over primitives `0..n`; node 0 is the root. Empty for no primitives.
#[derive(Clone, Debug, Default)]
pub struct BvhTree {
    pub nodes: Vec<TreeNode>,
    /// Primitive ids in leaf order.
    pub order: Vec<u32>,
}

/// A primitive's box for the builder.
struct PrimBox(ObvhsAabb);

impl Boundable for PrimBox {
    fn aabb(&self) -> ObvhsAabb {
        self.0
    }
}

/// The neighbouring f32 of a finite `f` towards +∞ (`up`) or −∞.
fn f32_step(f: f32, up: bool) -> f32 {
    if f == 0.0 {
        let tiny = f32::from_bits(1);
        return if up { tiny } else { -tiny };
    }
    let bits = f.to_bits();
    // Moving away from zero increases the magnitude bits.
    f32::from_bits(if (f > 0.0) == up { bits + 1 } else { bits - 1 })
}

/// The largest f32 not above `x`.
pub fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        f32_step(f, false)
    } else {
        f
    }
}

/// The smallest f32 not below `x`.
pub fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f32_step(f, true)
    } else {
        f
    }
}

/// `b` grown by `pad` on every side and rounded outward to f32.
pub fn outward_box(b: &Aabb, pad: f64) -> ([f32; 3], [f32; 3]) {
    let lo = b.min - DVec3::splat(pad);
    let hi = b.max + DVec3::splat(pad);
    ([f32_down(lo.x), f32_down(lo.y), f32_down(lo.z)], [f32_up(hi.x), f32_up(hi.y), f32_up(hi.z)])
}

/// obvhs's boxes of boxes (`min`, `max`).
fn prim_boxes(boxes: &[([f32; 3], [f32; 3])]) -> Vec<PrimBox> {
    boxes.iter().map(|(lo, hi)| PrimBox(ObvhsAabb { min: Vec3A::from(*lo), max: Vec3A::from(*hi) })).collect()
}

/// Builds the BVH of boxes (`min`, `max`), one per primitive, already in f32 (see
/// [`outward_box`]).
pub fn build(boxes: &[([f32; 3], [f32; 3])]) -> BvhTree {
    if boxes.is_empty() {
        return BvhTree::default();
    }
    let prims = prim_boxes(boxes);
    let params = BvhBuildParams { max_prims_per_leaf: MAX_LEAF, ..BvhBuildParams::medium_build() };
    let bvh: Bvh2 = obvhs::bvh2::builder::build_bvh2(&prims, params, &mut Default::default());
    let nodes = bvh
        .nodes
        .iter()
        .map(|n| TreeNode {
            min: n.aabb.min.to_array(),
            max: n.aabb.max.to_array(),
            count: n.prim_count,
            first: n.first_index,
        })
        .collect();
    BvhTree { nodes, order: bvh.primitive_indices }
}

/// The most primitives one leaf of the wide BVH holds (obvhs's CWBVH: 3), and one node of it
/// in all (its eight children's leaves: 24).
pub const WIDE_LEAF: u32 = 3;
pub const WIDE_NODE_PRIMS: u32 = 8 * WIDE_LEAF;

/// Builds the compressed 8-wide BVH of boxes (`min`, `max`), one per primitive, already in
/// f32 (see [`outward_box`]): obvhs's CWBVH (a binary PLOC tree with reinsertion, collapsed
/// to eight children a node by the paper's SAH decisions, children in slots by direction
/// octant). Its quantised child boxes are not conservative as obvhs builds them; callers
/// quantise them again from the boxes ([`crate::layout::bvh`]). Empty for no primitives.
pub fn build_wide(boxes: &[([f32; 3], [f32; 3])]) -> obvhs::cwbvh::CwBvh {
    if boxes.is_empty() {
        return Default::default();
    }
    let prims = prim_boxes(boxes);
    let params = BvhBuildParams { max_prims_per_leaf: WIDE_LEAF, ..BvhBuildParams::medium_build() };
    obvhs::cwbvh::builder::build_cwbvh(&prims, params, &mut Default::default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outward_rounding_to_f32() {
        for x in [0.1f64, -0.1, 1e-30, -1e-30, 0.0, 3.0, -7.25, 1e7 + 0.3] {
            assert!((f32_down(x) as f64) <= x && (f32_up(x) as f64) >= x, "{x}");
            assert!(f32_up(x) as f64 - f32_down(x) as f64 <= (x.abs() * 2.5e-7).max(1e-44), "{x}");
        }
    }

    #[test]
    fn every_primitive_is_in_one_leaf_inside_every_box_above_it() {
        let boxes: Vec<_> = (0..300)
            .map(|i| {
                let c = DVec3::new((i % 7) as f64, (i / 7 % 5) as f64 * 1.5, (i as f64 * 0.37).sin() * 4.0);
                outward_box(&Aabb { min: c, max: c + DVec3::splat(0.3) }, 0.0)
            })
            .collect();
        let t = build(&boxes);
        let mut seen = vec![0u32; boxes.len()];
        // (node, the boxes of its ancestors)
        let mut stack = vec![(0usize, Vec::<usize>::new())];
        while let Some((i, above)) = stack.pop() {
            let n = t.nodes[i];
            let mut path = above.clone();
            path.push(i);
            if n.is_leaf() {
                assert!(n.count <= MAX_LEAF);
                for &p in &t.order[n.first as usize..(n.first + n.count) as usize] {
                    seen[p as usize] += 1;
                    let (lo, hi) = boxes[p as usize];
                    for &a in &path {
                        let b = t.nodes[a];
                        assert!(
                            (0..3).all(|k| b.min[k] <= lo[k] && hi[k] <= b.max[k]),
                            "{p} outside node {a}"
                        );
                    }
                }
            } else {
                stack.push((n.first as usize, path.clone()));
                stack.push((n.first as usize + 1, path));
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "each primitive in exactly one leaf");
    }
}
