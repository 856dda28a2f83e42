//! The shared BVH ([`crate::bvh`]) traversed in f64, nearest child first.

use glam::DVec3;

use super::accel::{
    count, nearest_by_rule, test_closest, Hittable, Intersector, NearestHit, OriginKey, ShadowQuery,
};
use super::geometry::Ray;
use crate::bvh::{build, outward_box};
use crate::scene::{Primitive, Scene};
use crate::stats::TestCounts;

/// A primitive's box for the shared build: the f64 bounds are computed with a few roundings
/// (cylinders take square roots), so they are padded by a relative 1e-9 before rounding
/// outward to f32.
fn prim_box(p: &Primitive) -> ([f32; 3], [f32; 3]) {
    let b = p.bounds();
    let pad = (b.max - b.min).max_element().max(b.min.abs().max(b.max.abs()).max_element()) * 1e-9;
    outward_box(&b, pad)
}

/// One BVH node in f64, copied from the crate's f32 node (the conversion is exact).
#[derive(Clone, Copy, Debug)]
struct Node {
    min: DVec3,
    max: DVec3,
    /// Inner node: 0. Leaf: number of primitives.
    count: u32,
    /// Inner node: index of the first of two consecutive children. Leaf: index of the
    /// first primitive in `order`.
    first: u32,
}

/// A binary BVH: built by `obvhs` (PLOC with reinsertion, leaves collapsed by SAH),
/// traversed here in f64, nearest child first.
pub struct BvhAccel<'a> {
    prims: Hittable<'a>,
    nodes: Vec<Node>,
    /// Primitive ids in leaf order.
    order: Vec<u32>,
}

/// The ray's reciprocal direction, for slab tests.
struct SlabRay {
    origin: DVec3,
    inv: DVec3,
}

/// Slack on the far slab distance (Ize 2013): the f64 slab arithmetic may round the exit
/// distance down by a few ulps; growing it keeps the box test conservative.
const SLAB_SLACK: f64 = 1.0 + 8.0 * f64::EPSILON;

impl SlabRay {
    fn new(ray: &Ray) -> SlabRay {
        SlabRay { origin: ray.origin, inv: ray.dir.recip() }
    }

    /// Entry distance of the ray into the box within [0, t_max], or `None`.
    #[inline]
    fn enter(&self, n: &Node, t_max: f64) -> Option<f64> {
        let mut t0 = 0.0f64;
        let mut t1 = t_max;
        for i in 0..3 {
            let inv = self.inv[i];
            if inv.is_infinite() {
                // Parallel to the slab: inside it or never.
                if self.origin[i] < n.min[i] || self.origin[i] > n.max[i] {
                    return None;
                }
                continue;
            }
            let a = (n.min[i] - self.origin[i]) * inv;
            let b = (n.max[i] - self.origin[i]) * inv;
            let (near, far) = if a <= b { (a, b) } else { (b, a) };
            t0 = t0.max(near);
            t1 = t1.min(far * SLAB_SLACK);
            if t0 > t1 {
                return None;
            }
        }
        Some(t0)
    }
}

impl<'a> BvhAccel<'a> {
    pub fn new(scene: &'a Scene) -> Self {
        let prims = Hittable::new(scene);
        if prims.prims.is_empty() {
            return BvhAccel { prims, nodes: Vec::new(), order: Vec::new() };
        }
        let boxes: Vec<_> = prims.prims.iter().map(prim_box).collect();
        let tree = build(&boxes);
        let d = |v: [f32; 3]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
        let nodes = tree
            .nodes
            .iter()
            .map(|n| Node { min: d(n.min), max: d(n.max), count: n.count, first: n.first })
            .collect();
        BvhAccel { prims, nodes, order: tree.order }
    }

    /// Visits the leaves the ray may reach, nearest box first, while `t_max()` bounds the
    /// search. `leaf` returns false to stop.
    #[inline]
    fn traverse(&self, ray: &Ray, t_max: &dyn Fn() -> f64, leaf: &mut dyn FnMut(&[u32]) -> bool) {
        if self.nodes.is_empty() {
            return;
        }
        let slab = SlabRay::new(ray);
        let root = &self.nodes[0];
        if slab.enter(root, t_max()).is_none() {
            return;
        }
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
        stack.push((0, 0.0));
        while let Some((index, t_enter)) = stack.pop() {
            let limit = t_max();
            if t_enter > limit {
                continue;
            }
            let node = &self.nodes[index as usize];
            if node.count > 0 {
                let range = node.first as usize..(node.first + node.count) as usize;
                if !leaf(&self.order[range]) {
                    return;
                }
                continue;
            }
            let (l, r) = (node.first, node.first + 1);
            let tl = slab.enter(&self.nodes[l as usize], limit);
            let tr = slab.enter(&self.nodes[r as usize], limit);
            match (tl, tr) {
                (Some(a), Some(b)) => {
                    // Push the farther child first so that the nearer one is visited next.
                    if a <= b {
                        stack.push((r, b));
                        stack.push((l, a));
                    } else {
                        stack.push((l, a));
                        stack.push((r, b));
                    }
                }
                (Some(a), None) => stack.push((l, a)),
                (None, Some(b)) => stack.push((r, b)),
                (None, None) => {}
            }
        }
    }
}

impl Intersector for BvhAccel<'_> {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn closest(
        &self,
        ray: &Ray,
        _origin: OriginKey,
        t_max: f64,
        tests: &mut TestCounts,
    ) -> Option<NearestHit> {
        nearest_by_rule(|best| {
            // Boxes entered exactly at the limit are still visited (ties).
            let state = std::cell::Cell::new(*best);
            let limit = || state.get().limit(t_max);
            self.traverse(ray, &limit, &mut |ids| {
                let mut b = state.get();
                for &id in ids {
                    test_closest(&self.prims, id, ray, t_max, &mut b, tests);
                }
                state.set(b);
                true
            });
            *best = state.get();
        })
    }

    fn occluded(&self, q: &ShadowQuery, tests: &mut TestCounts) -> bool {
        let mut blocked = false;
        let t_max = q.t_max;
        self.traverse(&q.ray, &|| t_max, &mut |ids| {
            for &id in ids {
                count(&self.prims.prims[id as usize], tests);
                if self.prims.hit(id, &q.ray, t_max, true).is_some() {
                    blocked = true;
                    return false;
                }
            }
            true
        });
        blocked
    }
}
