//! Brute force: every primitive for every ray.

use super::accel::{
    count, nearest_by_rule, test_closest, Hittable, Intersector, NearestHit, OriginKey, ShadowQuery,
};
use super::geometry::Ray;
use crate::scene::Scene;
use crate::stats::TestCounts;

/// Tests every primitive for every ray.
pub struct Brute<'a> {
    prims: Hittable<'a>,
}

impl<'a> Brute<'a> {
    pub fn new(scene: &'a Scene) -> Self {
        Brute { prims: Hittable::new(scene) }
    }
}

impl Intersector for Brute<'_> {
    fn name(&self) -> &'static str {
        "brute"
    }

    fn closest(
        &self,
        ray: &Ray,
        _origin: OriginKey,
        t_max: f64,
        tests: &mut TestCounts,
    ) -> Option<NearestHit> {
        nearest_by_rule(|best| {
            for id in 0..self.prims.prims.len() as u32 {
                test_closest(&self.prims, id, ray, t_max, best, tests);
            }
        })
    }

    fn occluded(&self, q: &ShadowQuery, tests: &mut TestCounts) -> bool {
        (0..self.prims.prims.len() as u32).any(|id| {
            count(&self.prims.prims[id as usize], tests);
            self.prims.hit(id, &q.ray, q.t_max, true).is_some()
        })
    }
}
