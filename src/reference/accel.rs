//! The queries every accelerator of the reference answers ([`Intersector`]), and what they share:
//! the ray's origin entity, the hit record, the shadow query, and the nearest-hit rule for
//! the reference's own f64 tests (the tie rule of [`crate::arith::closest`]: ties within
//! the error bound go to the lower primitive id, so that every accelerator gives the same
//! image). Primitive intersection tests are counted into the
//! [`TestCounts`] the caller passes (one per ray kind).

use glam::DVec3;

use super::geometry::{intersect, Intersection, Ray};
use super::texture;
use crate::arith::closest::{consider, no_closest, Closest, TestHit};
use crate::scene::{Primitive, Scene};
use crate::stats::TestCounts;

/// The entity a ray starts from: the tables' key, which the reference's accelerators take
/// whether they use tables or not.
pub use crate::scene::OriginKey;

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

/// The largest scene [`Accel::Auto`](crate::job::Accel::Auto) traces by brute force.
pub const AUTO_BRUTE_MAX: usize = 16;

/// Nearest-hit and any-hit queries over a scene's primitives.
pub trait Intersector: Sync {
    /// `brute`, `bvh`...: the name `--stats` reports.
    fn name(&self) -> &'static str;

    /// The nearest hit with `0 < t < t_max`, ties to the lower primitive id.
    fn closest(&self, ray: &Ray, origin: OriginKey, t_max: f64, tests: &mut TestCounts)
        -> Option<NearestHit>;

    /// True when some primitive is hit by the shadow ray before `t_max`.
    fn occluded(&self, query: &ShadowQuery, tests: &mut TestCounts) -> bool;
}

/// The primitives every accelerator tests, and the rule that makes a geometric hit a hit:
/// on an alpha-masked or blended material, a hit whose alpha is below the cutoff is no hit
/// (a walk just goes on; shadow rays take a blend as a mask at 0.5).
#[derive(Clone, Copy)]
pub struct Hittable<'a> {
    pub prims: &'a [Primitive],
    scene: &'a Scene,
    /// Some used material is masked or blended.
    cut: bool,
}

impl<'a> Hittable<'a> {
    pub fn new(scene: &'a Scene) -> Hittable<'a> {
        let e = scene.effects();
        Hittable { prims: &scene.primitives, scene, cut: e.alpha || e.blend }
    }

    /// The hit of `ray` on primitive `id` before `t_max` that counts for a ray of this kind
    /// (`shadow`).
    #[inline]
    pub fn hit(&self, id: u32, ray: &Ray, t_max: f64, shadow: bool) -> Option<Intersection> {
        let prim = &self.prims[id as usize];
        let h = intersect(prim, ray, t_max)?;
        if self.cut {
            if let Primitive::Triangle(t) = prim {
                let m = &self.scene.materials[t.material as usize];
                if let Some(cutoff) = m.alpha.cutoff(shadow) {
                    if texture::alpha(self.scene, m, t.uvs_at(h.b1, h.b2)) < cutoff {
                        return None;
                    }
                }
            }
        }
        Some(h)
    }
}

/// Counts one intersection test of `prim`.
pub fn count(prim: &Primitive, tests: &mut TestCounts) {
    match prim {
        Primitive::Sphere(_) => tests.sphere += 1,
        Primitive::Triangle(_) => tests.triangle += 1,
        Primitive::Cylinder(_) => tests.cylinder += 1,
    }
}

/// A nearest-hit query's state: the tie rule's ([`crate::arith::closest`]), over the
/// reference's own f64 hits.
pub type Best = Closest<f64, Intersection>;

/// Tests primitive `id` for a nearest-hit query and takes its hit into `best` by the tie
/// rule (ties within the error bound go to the lower id). Returns the distance past which
/// no hit can join the answer ([`Closest::limit`]).
#[inline]
pub fn test_closest(
    prims: &Hittable,
    id: u32,
    ray: &Ray,
    t_max: f64,
    best: &mut Best,
    tests: &mut TestCounts,
) -> f64 {
    count(&prims.prims[id as usize], tests);
    let hit = prims.hit(id, ray, t_max, false).map(|h| TestHit { t: h.t, err: h.err, hit: h });
    consider(best, id, hit, t_max)
}

/// The answer of a nearest-hit query whose walk `walk` runs: once, or a second time from
/// [`Closest::again`] where the first walk lost its winner.
pub fn nearest_by_rule(mut walk: impl FnMut(&mut Best)) -> Option<NearestHit> {
    let mut best = no_closest();
    walk(&mut best);
    if best.lost {
        best = best.again();
        walk(&mut best);
    }
    best.found.then_some(NearestHit { prim: best.prim, hit: best.hit })
}
