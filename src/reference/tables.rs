//! `--accel cube` on the CPU: the reference renderer's queries answered through the
//! candidate tables of [`crate::coherence`] (direction cubes), walked by the one walker
//! ([`crate::coherence::walk`], the twin of the WGSL walk, in steps of [`WALK_CHUNK`] as the
//! GPU walks) with the reference's own f64 intersection tests. This is the only file of the
//! reference that knows the tables.
//!
//! The tables decide only *which* primitives are tested and in what order; every test is the
//! reference's own, so a conservative table gives exactly the images of `--accel brute`. A
//! shadow ray towards a point or spot light is looked up light-buffer style, in the light's
//! table along the direction from the light to the shaded point, but each candidate is tested
//! with the reference's own shadow ray (from the point towards the light): the segment it
//! covers lies on the light's ray through the point, so the light's cell lists every
//! primitive that can block it, and the answer is brute force's. Rays leaving surfaces go to
//! the reference's BVH, as the kernels' go to theirs. Rays without a table walk the fallback
//! origin, which lists every primitive: brute force in id order.

use glam::Vec3;

use super::accel::{count, nearest_by_rule, Hittable, Intersector, NearestHit, OriginKey, ShadowQuery};
use super::bvh::BvhAccel;
use super::geometry::Ray;
use crate::arith::closest::TestHit;
use crate::coherence::walk::{walk_any, walk_nearest, AnyHit, Walk, WALK_CHUNK};
use crate::coherence::{self, BuildParams, FlatTables, Tables, WalkCount};
use crate::error::Result;
use crate::scene::Scene;
use crate::stats::TestCounts;

/// The tables of one scene, built for one image size.
pub struct TableAccel<'a> {
    prims: Hittable<'a>,
    tables: Tables,
    /// What rays leaving surfaces walk.
    surface_bvh: BvhAccel<'a>,
}

impl<'a> TableAccel<'a> {
    /// Builds the tables `scene` calls for, with the eye table covering a `width`×`height`
    /// image, and the BVH for the rays leaving surfaces.
    pub fn new(scene: &'a Scene, width: u32, height: u32) -> Result<TableAccel<'a>> {
        let params = BuildParams { image: Some((width, height)), ..BuildParams::default() };
        let tables = coherence::build(scene, &params)?;
        Ok(TableAccel { prims: Hittable::new(scene), tables, surface_bvh: BvhAccel::new(scene) })
    }

    /// The tables as built (for statistics).
    pub fn tables(&self) -> &Tables {
        &self.tables
    }

    fn flat(&self) -> &FlatTables {
        &self.tables.flat
    }

    /// Whether something in the list of the ray from `key` along `d` lies before `reach`,
    /// each candidate tested with the reference's shadow ray `test_ray`.
    fn any_hit(
        &self,
        key: coherence::OriginKey,
        d: Vec3,
        reach: f64,
        test_ray: &ShadowQuery,
        tests: &mut TestCounts,
    ) -> bool {
        let flat = self.flat();
        let mut walked = WalkCount::default();
        let mut w: Walk = flat.walk_from(key, d);
        let mut hits = |id: u32| {
            count(&self.prims.prims[id as usize], tests);
            self.prims.hit(id, &test_ray.ray, test_ray.t_max, true).is_some()
        };
        let answer = loop {
            match walk_any(flat, &mut w, reach, u32::MAX, WALK_CHUNK, &mut walked, &mut hits) {
                AnyHit::Unfinished => continue,
                a => break a,
            }
        };
        answer == AnyHit::Blocked
    }
}

impl Intersector for TableAccel<'_> {
    fn name(&self) -> &'static str {
        "cube"
    }

    fn closest(
        &self,
        ray: &Ray,
        origin: OriginKey,
        t_max: f64,
        tests: &mut TestCounts,
    ) -> Option<NearestHit> {
        let flat = self.flat();
        if let OriginKey::Surface(_) = origin {
            return self.surface_bvh.closest(ray, origin, t_max, tests);
        }
        if ray.dir.abs().max_element() == 0.0 {
            return None;
        }
        let d = ray.dir.as_vec3().normalize();
        let mut walked = WalkCount::default();
        let mut test = |id: u32| {
            count(&self.prims.prims[id as usize], tests);
            self.prims.hit(id, ray, t_max, false).map(|h| TestHit { t: h.t, err: h.err, hit: h })
        };
        nearest_by_rule(|best| {
            // In steps, as the GPU walks, each resuming where the last stopped.
            let mut w = flat.walk_from(origin, d);
            while !walk_nearest(flat, &mut w, best, t_max, u32::MAX, WALK_CHUNK, &mut walked, &mut test) {}
        })
    }

    fn occluded(&self, q: &ShadowQuery, tests: &mut TestCounts) -> bool {
        let flat = self.flat();
        let light = coherence::OriginKey::Light(q.light as usize);
        if let (true, Some(lp)) = (flat.cube_of(light).is_some(), q.light_position) {
            // From the light through the point: candidates nearer than the point.
            let to_point = q.ray.origin - lp;
            let reach = to_point.length();
            if reach > 0.0 {
                let d = (to_point / reach).as_vec3().normalize();
                return self.any_hit(light, d, reach, q, tests);
            }
        }
        self.surface_bvh.occluded(q, tests)
    }
}
