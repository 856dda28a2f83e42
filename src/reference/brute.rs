//! Brute force: every primitive for every ray.

use super::accel::{count, nearest_by_rule, test_closest, Accel, NearestHit, OriginKey, ShadowQuery};
use super::geometry::{intersect, Ray};
use crate::scene::Primitive;
use crate::stats::TestCounts;

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

    fn closest(
        &self,
        ray: &Ray,
        _origin: OriginKey,
        t_max: f64,
        tests: &mut TestCounts,
    ) -> Option<NearestHit> {
        nearest_by_rule(|best| {
            for id in 0..self.prims.len() as u32 {
                test_closest(self.prims, id, ray, t_max, best, tests);
            }
        })
    }

    fn occluded(&self, q: &ShadowQuery, tests: &mut TestCounts) -> bool {
        self.prims.iter().any(|p| {
            count(p, tests);
            intersect(p, &q.ray, q.t_max).is_some()
        })
    }
}
