//! Acceleration structures behind one trait: brute force, and a BVH built by the `obvhs`
//! crate and traversed here in f64.
//!
//! Every query receives the ray's **origin entity** ([`RayOrigin`]): the eye, a light, or
//! the object (primitive id) the ray leaves. Brute force and the BVH ignore it; the
//! direction-cube tables of [`crate::coherence`] will key their candidate lists on it and
//! plug in as a third implementation (`--accel cube`). Shadow queries likewise carry the
//! light's index and position so that a table may trace them light-buffer style (from the
//! light towards the point).
//!
//! Both implementations return the same answer for the same ray: the nearest hit with
//! `0 < t < t_max`, ties in `t` going to the lower primitive id, so that brute force and
//! BVH images are identical. Primitive intersection tests are counted into the
//! [`TestCounts`] the caller passes (one per ray kind).

use glam::{DVec3, Vec3A};
use obvhs::{aabb::Aabb as BvhAabb, bvh2::Bvh2, Boundable, BvhBuildParams};

use super::geometry::{intersect, PrimHit, Ray};
use crate::error::Result;
use crate::job::AccelKind;
use crate::scene::{Aabb, Primitive, Scene};
use crate::stats::TestCounts;

/// The entity a ray starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayOrigin {
    /// A primary ray from the camera.
    Eye,
    /// A ray from light `i` (index into [`Scene::lights`]).
    Light(u32),
    /// A ray leaving the surface of primitive `id`.
    Surface(u32),
}

/// A nearest-hit answer: the primitive and where it was hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub prim: u32,
    pub hit: PrimHit,
}

/// A shadow query: is anything between the surface point and the light?
#[derive(Clone, Copy, Debug)]
pub struct ShadowQuery {
    /// The ray from the (offset) surface point towards the light, `t_max` before the light.
    pub ray: Ray,
    pub t_max: f64,
    /// The primitive the point lies on.
    pub object: u32,
    /// Index of the light in [`Scene::lights`].
    pub light: u32,
    /// The light's position, `None` for directional lights.
    pub light_position: Option<DVec3>,
}

/// The largest scene [`AccelKind::Auto`] traces by brute force.
pub const AUTO_BRUTE_MAX: usize = 16;

/// Nearest-hit and any-hit queries over a scene's primitives.
pub trait Accel: Sync {
    /// `brute`, `bvh`...: the name `--stats` reports.
    fn name(&self) -> &'static str;

    /// The nearest hit with `0 < t < t_max`, ties to the lower primitive id.
    fn closest(&self, ray: &Ray, origin: RayOrigin, t_max: f64, tests: &mut TestCounts) -> Option<Hit>;

    /// True when some primitive is hit by the shadow ray before `t_max`.
    fn occluded(&self, query: &ShadowQuery, tests: &mut TestCounts) -> bool;
}

/// Builds the structure `kind` asks for; the direction-cube tables cover primary rays of a
/// `width`×`height` image.
pub fn build<'a>(scene: &'a Scene, kind: AccelKind, width: u32, height: u32) -> Result<Box<dyn Accel + 'a>> {
    Ok(match kind {
        AccelKind::Auto if scene.primitives.len() <= AUTO_BRUTE_MAX => {
            Box::new(Brute::new(&scene.primitives))
        }
        AccelKind::Brute => Box::new(Brute::new(&scene.primitives)),
        AccelKind::Auto | AccelKind::Bvh => Box::new(Bvh::new(&scene.primitives)),
        AccelKind::Cube => Box::new(super::cube::Cube::new(scene, width, height)?),
    })
}

pub(super) fn count(prim: &Primitive, tests: &mut TestCounts) {
    match prim {
        Primitive::Sphere(_) => tests.sphere += 1,
        Primitive::Triangle(_) => tests.triangle += 1,
        Primitive::Cylinder(_) => tests.cylinder += 1,
    }
}

/// Tests primitive `id` and keeps the hit if it is nearer (or as near with a lower id).
#[inline]
fn test_closest(
    prims: &[Primitive],
    id: u32,
    ray: &Ray,
    t_max: f64,
    best: &mut Option<Hit>,
    tests: &mut TestCounts,
) {
    let prim = &prims[id as usize];
    count(prim, tests);
    // Allow t == best.t through so that ties can go to the lower id.
    let limit = best.map_or(t_max, |b| next_up(b.hit.t));
    if let Some(h) = intersect(prim, ray, limit) {
        let better = match best {
            None => true,
            Some(b) => h.t < b.hit.t || (h.t == b.hit.t && id < b.prim),
        };
        if better {
            *best = Some(Hit { prim: id, hit: h });
        }
    }
}

/// The next f64 above a finite `x` (kept for MSRV 1.85, where `f64::next_up` is missing).
pub(super) fn next_up(x: f64) -> f64 {
    if x.is_finite() {
        if x == 0.0 {
            f64::from_bits(1)
        } else {
            f64::from_bits(if x > 0.0 { x.to_bits() + 1 } else { x.to_bits() - 1 })
        }
    } else {
        x
    }
}

/// Tests every primitive for every ray.
pub struct Brute<'a> {
    prims: &'a [Primitive],
}

impl<'a> Brute<'a> {
    pub fn new(prims: &'a [Primitive]) -> Self {
        Brute { prims }
    }
}

impl Accel for Brute<'_> {
    fn name(&self) -> &'static str {
        "brute"
    }

    fn closest(&self, ray: &Ray, _origin: RayOrigin, t_max: f64, tests: &mut TestCounts) -> Option<Hit> {
        let mut best = None;
        for id in 0..self.prims.len() as u32 {
            test_closest(self.prims, id, ray, t_max, &mut best, tests);
        }
        best
    }

    fn occluded(&self, q: &ShadowQuery, tests: &mut TestCounts) -> bool {
        self.prims.iter().any(|p| {
            count(p, tests);
            intersect(p, &q.ray, q.t_max).is_some()
        })
    }
}

/// A primitive's box for the BVH builder: f64 bounds padded slightly and rounded outward
/// to f32, so the f32 box contains the f64 primitive.
struct PrimBox(BvhAabb);

impl Boundable for PrimBox {
    fn aabb(&self) -> BvhAabb {
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
fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        f32_step(f, false)
    } else {
        f
    }
}

/// The smallest f32 not below `x`.
fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f32_step(f, true)
    } else {
        f
    }
}

fn outward_box(b: &Aabb) -> BvhAabb {
    // The primitive bounds are computed in f64 with a few roundings (cylinders take
    // square roots): pad them by a relative 1e-9 before rounding outward to f32.
    let pad = (b.max - b.min).max_element().max(b.min.abs().max(b.max.abs()).max_element()) * 1e-9;
    let lo = b.min - DVec3::splat(pad);
    let hi = b.max + DVec3::splat(pad);
    BvhAabb {
        min: Vec3A::new(f32_down(lo.x), f32_down(lo.y), f32_down(lo.z)),
        max: Vec3A::new(f32_up(hi.x), f32_up(hi.y), f32_up(hi.z)),
    }
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
pub struct Bvh<'a> {
    prims: &'a [Primitive],
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

impl<'a> Bvh<'a> {
    pub fn new(prims: &'a [Primitive]) -> Self {
        if prims.is_empty() {
            return Bvh { prims, nodes: Vec::new(), order: Vec::new() };
        }
        let boxes: Vec<PrimBox> = prims.iter().map(|p| PrimBox(outward_box(&p.bounds()))).collect();
        let params = BvhBuildParams::medium_build();
        let bvh: Bvh2 = obvhs::bvh2::builder::build_bvh2(&boxes, params, &mut Default::default());
        let nodes = bvh
            .nodes
            .iter()
            .map(|n| Node {
                min: DVec3::new(n.aabb.min.x as f64, n.aabb.min.y as f64, n.aabb.min.z as f64),
                max: DVec3::new(n.aabb.max.x as f64, n.aabb.max.y as f64, n.aabb.max.z as f64),
                count: n.prim_count,
                first: n.first_index,
            })
            .collect();
        Bvh { prims, nodes, order: bvh.primitive_indices }
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

impl Accel for Bvh<'_> {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn closest(&self, ray: &Ray, _origin: RayOrigin, t_max: f64, tests: &mut TestCounts) -> Option<Hit> {
        let best = std::cell::Cell::new(None::<Hit>);
        // Boxes entered exactly at the best distance are still visited (ties).
        let limit = || best.get().map_or(t_max, |b| b.hit.t);
        self.traverse(ray, &limit, &mut |ids| {
            let mut b = best.get();
            for &id in ids {
                test_closest(self.prims, id, ray, t_max, &mut b, tests);
            }
            best.set(b);
            true
        });
        best.get()
    }

    fn occluded(&self, q: &ShadowQuery, tests: &mut TestCounts) -> bool {
        let mut blocked = false;
        let t_max = q.t_max;
        self.traverse(&q.ray, &|| t_max, &mut |ids| {
            for &id in ids {
                let p = &self.prims[id as usize];
                count(p, tests);
                if intersect(p, &q.ray, t_max).is_some() {
                    blocked = true;
                    return false;
                }
            }
            true
        });
        blocked
    }
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
        assert!(next_up(1.0) > 1.0 && next_up(-1.0) > -1.0 && next_up(0.0) > 0.0);
    }
}
