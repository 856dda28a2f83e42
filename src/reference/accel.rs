//! The queries every accelerator of the reference answers ([`Accel`]), and what they share:
//! the ray's origin entity, the hit record, the shadow query, and the nearest-hit rule for
//! the reference's own f64 tests (ties in `t` go to the lower primitive id, so that every
//! accelerator gives the same image). Primitive intersection tests are counted into the
//! [`TestCounts`] the caller passes (one per ray kind).

use glam::DVec3;

use super::geometry::{intersect, Intersection, Ray};
use crate::scene::Primitive;
use crate::stats::TestCounts;

/// The entity a ray starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OriginKey {
    /// A primary ray from the camera.
    Eye,
    /// A ray from light `i` (index into [`Scene::lights`](crate::scene::Scene::lights)).
    Light(u32),
    /// A ray leaving the surface of primitive `id`.
    Surface(u32),
}

/// A nearest-hit answer: the primitive and where it was hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearestHit {
    pub prim: u32,
    pub hit: Intersection,
}

/// A shadow query: is anything between the surface point and the light?
#[derive(Clone, Copy, Debug)]
pub struct ShadowQuery {
    /// The ray from the (offset) surface point towards the light, `t_max` before the light.
    pub ray: Ray,
    pub t_max: f64,
    /// The primitive the point lies on.
    pub object: u32,
    /// Index of the light in [`Scene::lights`](crate::scene::Scene::lights).
    pub light: u32,
    /// The light's position, `None` for directional lights.
    pub light_position: Option<DVec3>,
}

/// The largest scene [`AccelKind::Auto`](crate::job::AccelKind::Auto) traces by brute force.
pub const AUTO_BRUTE_MAX: usize = 16;

/// Nearest-hit and any-hit queries over a scene's primitives.
pub trait Accel: Sync {
    /// `brute`, `bvh`...: the name `--stats` reports.
    fn name(&self) -> &'static str;

    /// The nearest hit with `0 < t < t_max`, ties to the lower primitive id.
    fn closest(&self, ray: &Ray, origin: OriginKey, t_max: f64, tests: &mut TestCounts)
        -> Option<NearestHit>;

    /// True when some primitive is hit by the shadow ray before `t_max`.
    fn occluded(&self, query: &ShadowQuery, tests: &mut TestCounts) -> bool;
}

/// Counts one intersection test of `prim`.
pub fn count(prim: &Primitive, tests: &mut TestCounts) {
    match prim {
        Primitive::Sphere(_) => tests.sphere += 1,
        Primitive::Triangle(_) => tests.triangle += 1,
        Primitive::Cylinder(_) => tests.cylinder += 1,
    }
}

/// Relative room above the best distance so far within which hits are still tested (ties).
const TIE_ROOM: f64 = 1.0 + 8.0 * f64::EPSILON;

/// Tests primitive `id` and keeps the hit if it is nearer (or as near with a lower id).
#[inline]
pub fn test_closest(
    prims: &[Primitive],
    id: u32,
    ray: &Ray,
    t_max: f64,
    best: &mut Option<NearestHit>,
    tests: &mut TestCounts,
) {
    let prim = &prims[id as usize];
    count(prim, tests);
    // Let t == best.t through so that ties can go to the lower id. The intersection tests
    // compare scaled distances (`t·det` against `t_max·det`), whose rounding can turn away a
    // hit at exactly `best.t` when the limit is only one ulp above it: a BVH that met a
    // primitive's exact twin first then kept the twin (`tests/it/hard.rs`, coplanar triangles).
    // A few ulps of room let every tie through; `better` below decides exactly.
    let limit = best.map_or(t_max, |b| b.hit.t * TIE_ROOM);
    if let Some(h) = intersect(prim, ray, limit) {
        let better = match best {
            None => true,
            Some(b) => h.t < b.hit.t || (h.t == b.hit.t && id < b.prim),
        };
        if better {
            *best = Some(NearestHit { prim: id, hit: h });
        }
    }
}
