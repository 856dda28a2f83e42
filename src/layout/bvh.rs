//! The BVH as the GPU walks it (`--accel bvh`, `shaders/shared/bvh.wgsl`): the shared tree
//! ([`crate::bvh`]) over the scene re-centred on the eye, flattened into six *threaded*
//! orders, one per major direction axis and sign (Hachisuka's multiple-threaded BVH). Each
//! order lists the nodes depth first, the child nearer along its axis first, and gives every
//! node the index to go on at when its box is missed (`skip`, past its subtree); a hit box
//! goes on at the next node, or past a leaf once its primitives are tested. So a walk is one
//! index, with no stack, and a walk interrupted between kernel passes keeps only that (and a
//! leaf's primitives left).
//!
//! Boxes are grown so that the f32 box test is conservative against the f32 primitive tests:
//! by [`BVH_PAD_REL`] of the box's size and distance from the eye here, and in the kernel by
//! `BVH_SLACK` of the ray origin's distance from the eye.

use bytemuck::{Pod, Zeroable};

use crate::bvh::{self, BvhTree};
use crate::coherence::reach::WalkBounds;
use crate::scene::{Aabb, Scene};

/// One node of a threaded order (WGSL `BvhNode`, keep in sync with `shaders/shared/bvh.wgsl`).
/// `leaf` is 0 for an inner node, and `first << BVH_LEAF_SHIFT | count` for a leaf of
/// `count` primitives at `bvh_prims[first..first + count]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub lo: [f32; 3],
    /// Where the walk goes on when this box is missed (the order's length: the end).
    pub skip: u32,
    pub hi: [f32; 3],
    pub leaf: u32,
}

/// Bits of [`BvhNode::leaf`] that hold the count (WGSL `BVH_LEAF_SHIFT`).
pub const BVH_LEAF_SHIFT: u32 = 4;

/// The kernel grows a box by this much of the ray origin's largest coordinate (WGSL
/// `BVH_SLACK`): the f32 primitive tests err by a few ulps of the distances involved.
pub const BVH_SLACK: f32 = 1e-5;

/// Boxes are grown by this much of their size plus their largest coordinate (eye-relative)
/// before rounding outward to f32: it covers the f32 rounding of the packed primitives.
pub const BVH_PAD_REL: f64 = 1e-5;

/// A ray ready for box tests (WGSL `BoxRay`, twin of `box_ray` in
/// `shaders/shared/bvh.wgsl`: keep them in sync): its reciprocal direction (components below
/// 1e-20 in size taken as 1e-20, so that nothing divides by zero), the growth of the boxes,
/// and where its order starts in the nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxRay {
    pub o: [f32; 3],
    pub inv: [f32; 3],
    pub pad: f32,
    pub base: u32,
}

/// The box-test form of the ray from `o` along unit `d`, whose threaded order starts every
/// `stride` nodes (WGSL `box_ray`).
pub fn box_ray(o: [f32; 3], d: [f32; 3], stride: u32) -> BoxRay {
    let a = d.map(f32::abs);
    let axis = if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    };
    let order = 2 * axis as u32 + u32::from(d[axis] < 0.0);
    // WGSL `select(ray.d, vec3(1e-20), a < vec3(1e-20))`, per component.
    let inv = std::array::from_fn(|k| 1.0 / if a[k] < 1e-20 { 1e-20 } else { d[k] });
    let pad = BVH_SLACK * o.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    BoxRay { o, inv, pad, base: order * stride }
}

/// Whether the ray meets node `n`'s box, grown by `r.pad`, at some t in [0, t_far] (WGSL
/// `box_hit`, operation for operation).
pub fn box_hit(n: &BvhNode, r: &BoxRay, t_far: f32) -> bool {
    let slab = |k: usize| {
        let a = (n.lo[k] - r.pad - r.o[k]) * r.inv[k];
        let b = (n.hi[k] + r.pad - r.o[k]) * r.inv[k];
        (a.min(b), a.max(b))
    };
    let (near, far): (Vec<f32>, Vec<f32>) = (0..3).map(slab).unzip();
    let t0 = near[0].max(near[1]).max(near[2].max(0.0));
    let t1 = far[0].min(far[1]).min(far[2]) * (1.0 + BVH_SLACK);
    t0 <= t1.min(t_far)
}

/// The threaded orders a BVH is flattened into: one per major direction axis and sign.
pub const BVH_ORDERS: usize = 6;

/// The BVH flattened for the GPU: `BVH_ORDERS · stride` nodes (order `k` at `k · stride`;
/// the preview leaves room after them), and the primitive ids the leaves point into.
#[derive(Clone, Debug, Default)]
pub struct GpuBvh {
    pub nodes: Vec<BvhNode>,
    pub prims: Vec<u32>,
    pub stride: u32,
}

impl GpuBvh {
    /// Bytes on the GPU.
    pub fn bytes(&self) -> u64 {
        (std::mem::size_of_val(self.nodes.as_slice()) + std::mem::size_of_val(self.prims.as_slice())) as u64
    }

    /// Bounds on the kernels' walks, for the loop budget and the tile size: a walk visits each
    /// node and tests each primitive at most once, which lavapipe's loop limit counts as up to
    /// twice as many iterations (see [`super::budget::bvh_shadow_inline`]); a typical walk
    /// takes about the depth of the tree twice over and a few leaves. The waves are planned
    /// for a walk of sixteen typical ones, not for the worst, which no ray of a real scene
    /// comes near (gears_s4: 13 retry passes a depth for walks of about 60 iterations, and
    /// those empty passes took a third of its kernel time on lavapipe).
    pub fn walk_bounds(&self) -> WalkBounds {
        let worst = 2 * (self.stride as u64 + self.prims.len() as u64);
        let depth = (self.prims.len().max(2) as f64).log2();
        let mean_list = 4.0 * depth + 2.0 * bvh::MAX_LEAF as f64;
        WalkBounds {
            worst_closest: worst,
            worst_eye: worst,
            worst_shadow: worst,
            mean_list,
            planned: worst.min(16 * mean_list as u64),
            fallback_reachable: false,
            mixed: false,
        }
    }
}

/// The box of a primitive relative to `eye`, grown by [`BVH_PAD_REL`] and rounded out.
fn eye_box(b: &Aabb, eye: glam::DVec3) -> ([f32; 3], [f32; 3]) {
    let rel = Aabb { min: b.min - eye, max: b.max - eye };
    let size = (rel.max - rel.min).max_element();
    let far = rel.min.abs().max(rel.max.abs()).max_element();
    bvh::outward_box(&rel, BVH_PAD_REL * (size + far))
}

/// Builds the BVH of `scene` re-centred on its eye (as [`super::pack()`] packs it) and
/// flattens it into six threaded orders.
pub fn pack_bvh(scene: &Scene) -> GpuBvh {
    let eye = scene.camera.eye;
    let boxes: Vec<_> = scene.primitives.iter().map(|p| eye_box(&p.bounds(), eye)).collect();
    flatten(&bvh::build(&boxes))
}

/// The six threaded orders of `tree`: order `2·axis + (direction negative)`.
pub fn flatten(tree: &BvhTree) -> GpuBvh {
    let n = tree.nodes.len();
    if n == 0 {
        return GpuBvh::default();
    }
    // Nodes in each subtree, children after parents in the tree's own order or not: counted
    // from a depth-first list.
    let mut pre = Vec::with_capacity(n);
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        pre.push(i);
        let node = &tree.nodes[i];
        if !node.is_leaf() {
            stack.push(node.first as usize);
            stack.push(node.first as usize + 1);
        }
    }
    let mut size = vec![1u32; n];
    for &i in pre.iter().rev() {
        let node = &tree.nodes[i];
        if !node.is_leaf() {
            size[i] = 1 + size[node.first as usize] + size[node.first as usize + 1];
        }
    }
    let mut nodes = Vec::with_capacity(BVH_ORDERS * n);
    for order in 0..6 {
        let axis = order / 2;
        let negative = order % 2 == 1;
        let start = nodes.len();
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &tree.nodes[i];
            let at = (nodes.len() - start) as u32;
            let leaf = if node.is_leaf() { node.first << BVH_LEAF_SHIFT | node.count } else { 0 };
            nodes.push(BvhNode { lo: node.min, hi: node.max, skip: at + size[i], leaf });
            if !node.is_leaf() {
                let (a, b) = (node.first as usize, node.first as usize + 1);
                let centre = |c: usize| tree.nodes[c].min[axis] + tree.nodes[c].max[axis];
                // The child nearer along the order's direction first: pushed last.
                let a_first = (centre(a) <= centre(b)) != negative;
                let (near, far) = if a_first { (a, b) } else { (b, a) };
                stack.push(far);
                stack.push(near);
            }
        }
    }
    debug_assert!(tree.order.len() < (1usize << (32 - BVH_LEAF_SHIFT)));
    GpuBvh { nodes, prims: tree.order.clone(), stride: n as u32 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn tree() -> BvhTree {
        let boxes: Vec<_> = (0..200)
            .map(|i| {
                let c = DVec3::new((i % 9) as f64 * 2.0, (i / 9 % 4) as f64, (i as f64 * 0.71).cos() * 3.0);
                bvh::outward_box(&Aabb { min: c, max: c + DVec3::splat(0.5) }, 0.0)
            })
            .collect();
        bvh::build(&boxes)
    }

    #[test]
    fn every_order_visits_every_node_once_and_skips_whole_subtrees() {
        let t = tree();
        let g = flatten(&t);
        let n = g.stride as usize;
        assert_eq!(g.nodes.len(), BVH_ORDERS * n);
        for order in 0..6 {
            let nodes = &g.nodes[order * n..(order + 1) * n];
            // Following every hit link visits the whole order, every leaf's primitives once.
            let mut seen = vec![0u32; t.order.len()];
            let mut i = 0usize;
            let mut visited = 0;
            while i < n {
                visited += 1;
                let node = nodes[i];
                if node.leaf != 0 {
                    let first = (node.leaf >> BVH_LEAF_SHIFT) as usize;
                    let count = (node.leaf & ((1 << BVH_LEAF_SHIFT) - 1)) as usize;
                    for &p in &g.prims[first..first + count] {
                        seen[p as usize] += 1;
                    }
                    assert_eq!(node.skip as usize, i + 1, "a leaf's skip is the next node");
                    i = node.skip as usize;
                } else {
                    i += 1;
                }
            }
            assert_eq!(visited, n);
            assert!(seen.iter().all(|&s| s == 1));
            // A skip lands past the subtree: every node in between lies inside this box.
            for (k, node) in nodes.iter().enumerate() {
                assert!(node.skip as usize > k && node.skip as usize <= n);
                for inner in &nodes[k + 1..node.skip as usize] {
                    assert!((0..3).all(|a| node.lo[a] <= inner.lo[a] && inner.hi[a] <= node.hi[a]));
                }
            }
        }
    }

    #[test]
    fn each_order_puts_the_nearer_child_first() {
        let g = flatten(&tree());
        let n = g.stride as usize;
        for order in 0..6 {
            let (axis, negative) = (order / 2, order % 2 == 1);
            let nodes = &g.nodes[order * n..(order + 1) * n];
            for (k, node) in nodes.iter().enumerate() {
                if node.leaf == 0 {
                    let first = nodes[k + 1];
                    let second = nodes[first.skip as usize];
                    let c = |b: &BvhNode| b.lo[axis] + b.hi[axis];
                    assert!((c(&first) <= c(&second)) != negative || c(&first) == c(&second));
                }
            }
        }
    }
}
