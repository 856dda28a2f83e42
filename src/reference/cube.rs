//! `--accel cube` on the CPU: the reference renderer's queries answered through the
//! direction-cube candidate tables of [`crate::coherence`], walked by the same algorithm as the
//! WGSL ([`FlatTables::walk_nearest`], [`FlatTables::walk_any`]) with the reference's f64
//! intersection routines.
//!
//! The tables decide only *which* primitives are tested and in what order; every test is the
//! reference's own, so a conservative table gives exactly the images of `--accel brute`. A
//! shadow ray towards a point or spot light is looked up light-buffer style, in the light's
//! table along the direction from the light to the shaded point, but each candidate is tested
//! with the reference's own shadow ray (from the point towards the light): the segment it
//! covers lies on the light's ray through the point, so the light's cell lists every
//! primitive that can block it, and the answer is brute force's. Rays whose origin has no
//! table (a primitive that spawns no secondary rays under the current tables) fall back to
//! testing every primitive, and are counted as such.

use glam::DVec3;

use crate::coherence::{self, BuildParams, FlatTables, OriginKey, Tables};
use crate::error::Result;
use crate::scene::{Primitive, Scene};
use crate::stats::TestCounts;

use super::accel::{count, next_up, Accel, Brute, Hit, RayOrigin, ShadowQuery};
use super::geometry::{intersect, Ray};

/// The tables of one scene, built for one image size.
pub struct Cube<'a> {
    prims: &'a [Primitive],
    tables: Tables,
    /// The camera's eye: table lookups take points relative to it.
    eye: DVec3,
}

impl<'a> Cube<'a> {
    /// Builds the tables `scene` calls for, with the eye table covering a `width`×`height`
    /// image.
    pub fn new(scene: &'a Scene, width: u32, height: u32) -> Result<Cube<'a>> {
        let params = BuildParams { image: Some((width, height)), ..BuildParams::default() };
        let tables = coherence::build(scene, &params)?;
        Ok(Cube { prims: &scene.primitives, tables, eye: scene.camera.eye })
    }

    /// The tables as built (for statistics).
    pub fn tables(&self) -> &Tables {
        &self.tables
    }

    fn flat(&self) -> &FlatTables {
        &self.tables.flat
    }

    /// The table key of a ray from `origin` starting at `at`.
    fn key(&self, origin: RayOrigin, at: DVec3) -> OriginKey {
        match origin {
            RayOrigin::Eye => OriginKey::Eye,
            RayOrigin::Light(i) => OriginKey::Light(i as usize),
            RayOrigin::Surface(id) => OriginKey::Surface(id, (at - self.eye).as_vec3()),
        }
    }
}

impl Accel for Cube<'_> {
    fn name(&self) -> &'static str {
        "cube"
    }

    fn closest(&self, ray: &Ray, origin: RayOrigin, t_max: f64, tests: &mut TestCounts) -> Option<Hit> {
        let flat = self.flat();
        let Some(o) = flat.origin(self.key(origin, ray.origin)) else {
            return Brute::new(self.prims).closest(ray, origin, t_max, tests);
        };
        let prims = self.prims;
        // The walker picks the winner by (t, id); the same rule keeps its hit record here.
        let mut kept: Option<Hit> = None;
        let at = (ray.origin - self.eye).as_vec3();
        let (best, walked) =
            flat.walk_nearest(o, at, ray.dir.as_vec3(), t_max, u32::MAX, |id, t_best: f64| {
                let prim = &prims[id as usize];
                count(prim, tests);
                // Up to and including t_best, so that a tie can go to the lower id.
                let h = intersect(prim, ray, next_up(t_best))?;
                if h.t < t_max && kept.is_none_or(|k| h.t < k.hit.t || (h.t == k.hit.t && id < k.prim)) {
                    kept = Some(Hit { prim: id, hit: h });
                }
                Some(h.t)
            });
        tests.bound += walked.bounds as u64;
        debug_assert_eq!(best.map(|b| b.0), kept.map(|k| k.prim));
        best.and(kept)
    }

    fn occluded(&self, q: &ShadowQuery, tests: &mut TestCounts) -> bool {
        let flat = self.flat();
        let prims = self.prims;
        // Every candidate is tested with the reference's own shadow ray.
        let test = |id: u32, tests: &mut TestCounts| -> bool {
            let prim = &prims[id as usize];
            count(prim, tests);
            intersect(prim, &q.ray, q.t_max).is_some()
        };
        if let (Some(l), Some(lp)) = (flat.origin(OriginKey::Light(q.light as usize)), q.light_position) {
            // From the light through the point: candidates nearer than the point.
            let to_point = q.ray.origin - lp;
            let reach = to_point.length();
            if reach > 0.0 {
                let dir = (to_point / reach).as_vec3();
                let at = (lp - self.eye).as_vec3();
                let mut counted = TestCounts::default();
                let (blocked, walked) =
                    flat.walk_any(l, at, dir, reach, u32::MAX, |id, _| test(id, &mut counted).then_some(0.0));
                counted.bound = walked.bounds as u64;
                *tests += counted;
                return blocked;
            }
        }
        if let Some(o) = flat.origin(self.key(RayOrigin::Surface(q.object), q.ray.origin)) {
            let at = (q.ray.origin - self.eye).as_vec3();
            let mut counted = TestCounts::default();
            let (blocked, walked) = flat.walk_any(o, at, q.ray.dir.as_vec3(), q.t_max, u32::MAX, |id, _| {
                test(id, &mut counted).then_some(0.0)
            });
            counted.bound = walked.bounds as u64;
            *tests += counted;
            return blocked;
        }
        Brute::new(self.prims).occluded(q, tests)
    }
}
