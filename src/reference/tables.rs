//! `--accel cube` and `beams` on the CPU: the reference renderer's queries answered through
//! the candidate tables of [`crate::coherence`] (direction cubes and beams), walked by the one walker
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
//! primitive that can block it, and the answer is brute force's. Rays leaving surfaces, when
//! the tables have no beams (`--accel cube`), go to the reference's BVH, as the kernels' go
//! to theirs. Rays without a table walk the fallback origin, which lists every primitive:
//! brute force in id order.

use glam::{DVec3, Vec3};

use super::accel::{count, Accel, NearestHit, OriginKey, ShadowQuery};
use super::bvh::BvhAccel;
use super::geometry::{intersect, Intersection, Ray};
use crate::arith::closest::no_closest;
use crate::coherence::walk::{walk_any, walk_nearest, AnyHit, Walk, WALK_CHUNK};
use crate::coherence::{self, BuildParams, FlatTables, Tables, WalkCount};
use crate::error::Result;
use crate::scene::{Primitive, Scene};
use crate::stats::TestCounts;

/// The tables of one scene, built for one image size.
pub struct TableAccel<'a> {
    prims: &'a [Primitive],
    tables: Tables,
    /// The camera's eye: table lookups take points relative to it.
    eye: DVec3,
    /// What rays leaving surfaces walk when the tables have no beams.
    surface_bvh: Option<BvhAccel<'a>>,
    /// Whether the beams were asked for (`--accel beams`).
    beams: bool,
}

impl<'a> TableAccel<'a> {
    /// Builds the tables `scene` calls for, with the eye table covering a `width`×`height`
    /// image, and `beams` for the rays leaving surfaces (else the BVH for those).
    pub fn new(
        scene: &'a Scene,
        width: u32,
        height: u32,
        max_depth: u32,
        beams: bool,
    ) -> Result<TableAccel<'a>> {
        let params = BuildParams { image: Some((width, height)), max_depth, beams, ..BuildParams::default() };
        let tables = coherence::build(scene, &params)?;
        let surface_bvh = tables.flat.surface_bvh().then(|| BvhAccel::new(&scene.primitives));
        Ok(TableAccel { prims: &scene.primitives, tables, eye: scene.camera.eye, surface_bvh, beams })
    }

    /// The tables as built (for statistics).
    pub fn tables(&self) -> &Tables {
        &self.tables
    }

    fn flat(&self) -> &FlatTables {
        &self.tables.flat
    }

    /// A point in the walkers' camera-relative f32 frame.
    fn at(&self, p: DVec3) -> Vec3 {
        (p - self.eye).as_vec3()
    }

    /// The table key of a ray from `origin` starting at `p`.
    fn key(&self, origin: OriginKey, p: DVec3) -> coherence::OriginKey {
        match origin {
            OriginKey::Eye => coherence::OriginKey::Eye,
            OriginKey::Light(i) => coherence::OriginKey::Light(i as usize),
            OriginKey::Surface(id) => coherence::OriginKey::Surface(id, self.at(p)),
        }
    }

    /// Whether something in the list of the ray from `key` at `at` along `d` lies before
    /// `reach`, each candidate tested with the reference's shadow ray `test_ray`.
    fn any_hit(
        &self,
        key: coherence::OriginKey,
        at: Vec3,
        d: Vec3,
        reach: f64,
        test_ray: &ShadowQuery,
        tests: &mut TestCounts,
    ) -> bool {
        let flat = self.flat();
        let mut walked = WalkCount::default();
        let mut w: Walk = flat.walk_from(key, d);
        let mut hits = |id: u32| {
            let prim = &self.prims[id as usize];
            count(prim, tests);
            intersect(prim, &test_ray.ray, test_ray.t_max).is_some()
        };
        let answer = loop {
            match walk_any(flat, &mut w, at, d, reach, u32::MAX, WALK_CHUNK, &mut walked, &mut hits) {
                AnyHit::Unfinished => continue,
                a => break a,
            }
        };
        tests.bound += walked.bounds as u64;
        answer == AnyHit::Blocked
    }
}

impl Accel for TableAccel<'_> {
    fn name(&self) -> &'static str {
        if self.beams {
            "beams"
        } else {
            "cube"
        }
    }

    fn closest(
        &self,
        ray: &Ray,
        origin: OriginKey,
        t_max: f64,
        tests: &mut TestCounts,
    ) -> Option<NearestHit> {
        let flat = self.flat();
        if let (OriginKey::Surface(_), Some(bvh)) = (origin, &self.surface_bvh) {
            return bvh.closest(ray, origin, t_max, tests);
        }
        if ray.dir.abs().max_element() == 0.0 {
            return None;
        }
        let d = ray.dir.as_vec3().normalize();
        let at = self.at(ray.origin);
        let mut walked = WalkCount::default();
        let mut best = no_closest::<f64, Intersection>();
        let mut w = flat.walk_from(self.key(origin, ray.origin), d);
        let mut test = |id: u32| {
            let prim = &self.prims[id as usize];
            count(prim, tests);
            intersect(prim, ray, t_max).map(|h| (h.t, h))
        };
        // In steps, as the GPU walks, each resuming where the last stopped.
        while !walk_nearest(
            flat,
            &mut w,
            &mut best,
            at,
            d,
            t_max,
            u32::MAX,
            WALK_CHUNK,
            &mut walked,
            &mut test,
        ) {}
        tests.bound += walked.bounds as u64;
        best.found.then_some(NearestHit { prim: best.prim, hit: best.hit })
    }

    fn occluded(&self, q: &ShadowQuery, tests: &mut TestCounts) -> bool {
        let flat = self.flat();
        let light = coherence::OriginKey::Light(q.light as usize);
        if let (true, Some(lp)) = (flat.has_table(light), q.light_position) {
            // From the light through the point: candidates nearer than the point.
            let to_point = q.ray.origin - lp;
            let reach = to_point.length();
            if reach > 0.0 {
                let d = (to_point / reach).as_vec3().normalize();
                return self.any_hit(light, self.at(lp), d, reach, q, tests);
            }
        }
        if let Some(bvh) = &self.surface_bvh {
            return bvh.occluded(q, tests);
        }
        let key = self.key(OriginKey::Surface(q.object), q.ray.origin);
        let d = q.ray.dir.as_vec3().normalize();
        self.any_hit(key, self.at(q.ray.origin), d, q.t_max, q, tests)
    }
}
