//! Auditing the tables: primitive tests per ray, by ray kind, over a scene's primary rays and
//! the Whitted ray trees they spawn, traced in f32 with the kernels' intersection and spawn
//! twins ([`crate::arith`]) and the table walker. Optionally checks a share of the rays
//! against testing every primitive.
//!
//! This is a geometric tracer only (no shading): the ray trees are [`super::raytree`]'s.

use rayon::prelude::*;
use serde::Serialize;

use super::raytree::{Kind, RayTree, TreeRay};
use super::tables::Tables;
use super::walk::{table_any, table_nearest, OriginKey, WalkCount};
use crate::arith::closest::{brute_nearest, test_prim, Closest};
use crate::arith::geometry::{PrimHit, Ray};
use crate::arith::{FAR, NO_ID};
use crate::scene::Scene;

/// What to trace.
#[derive(Clone, Copy, Debug)]
pub struct AuditParams {
    pub width: u32,
    pub height: u32,
    /// SPD corner sampling: (W+1)×(H+1) eye rays at pixel corners; otherwise pixel centres.
    pub corners: bool,
    pub max_depth: u32,
    /// Check every k-th ray of each kind against brute force (0: none).
    pub verify_every: u32,
}

/// Rays and tests of one kind.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct KindCount {
    pub rays: u64,
    pub tests: u64,
    /// Rays whose origin had no table (they walk the fallback origin: every primitive).
    pub untabled: u64,
    pub tests_per_ray: f64,
}

/// The measurement.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AuditResult {
    pub eye: KindCount,
    pub shadow: KindCount,
    pub reflect: KindCount,
    pub refract: KindCount,
    pub shadow_blocked: u64,
    /// Rays checked against brute force, and how many disagreed (must be 0).
    pub verified: u64,
    pub mismatches: u64,
    /// Secondary rays that brute force says hit the primitive they leave from (spawn
    /// offset failures, not table failures).
    pub self_hits: u64,
    /// The first disagreement found, described.
    pub first_mismatch: Option<String>,
    pub trace_s: f64,
}

impl std::ops::AddAssign for KindCount {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.tests += o.tests;
        self.untabled += o.untabled;
    }
}

impl std::ops::AddAssign for AuditResult {
    fn add_assign(&mut self, o: Self) {
        self.eye += o.eye;
        self.shadow += o.shadow;
        self.reflect += o.reflect;
        self.refract += o.refract;
        self.shadow_blocked += o.shadow_blocked;
        self.verified += o.verified;
        self.mismatches += o.mismatches;
        self.self_hits += o.self_hits;
        if self.first_mismatch.is_none() {
            self.first_mismatch = o.first_mismatch;
        }
    }
}

fn kind_mut(r: &mut AuditResult, kind: Kind) -> &mut KindCount {
    match kind {
        Kind::Eye => &mut r.eye,
        Kind::Reflect => &mut r.reflect,
        Kind::Refract => &mut r.refract,
    }
}

struct Tracer<'a> {
    tree: RayTree<'a>,
    tables: &'a Tables,
    params: AuditParams,
}

impl Tracer<'_> {
    fn nearest(&self, r: &mut AuditResult, tr: &TreeRay, n: u64) -> Closest<f32, PrimHit> {
        let f = &self.tables.flat;
        let (key, ray, skip) = (tr.key(), &tr.ray, tr.skip);
        let prims = &self.tree.prims;
        let mut count = WalkCount::default();
        let hit = table_nearest(f, key, ray.d, FAR, skip, &mut count, |id| {
            test_prim(&prims[id as usize], ray, FAR)
        });
        let c = kind_mut(r, tr.kind);
        c.rays += 1;
        c.untabled += f.cube_of(key).is_none() as u64;
        c.tests += count.tests as u64;
        if self.params.verify_every > 0 && n % self.params.verify_every as u64 == 0 {
            r.verified += 1;
            let want = brute_nearest(prims, ray, FAR, skip);
            if (want.prim, want.t) != (hit.prim, hit.t) {
                r.mismatches += 1;
                r.first_mismatch.get_or_insert(format!(
                    "{key:?} o={} d={} skip={skip}: walker {:?} brute {:?}",
                    ray.o,
                    ray.d,
                    (hit.prim, hit.t),
                    (want.prim, want.t)
                ));
            }
            if skip != NO_ID && prims[skip as usize].intersect(ray, hit.best_t(FAR)).ok {
                r.self_hits += 1;
            }
        }
        hit
    }

    fn any(&self, r: &mut AuditResult, key: OriginKey, ray: &Ray, t_max: f32, skip: u32, n: u64) -> bool {
        let f = &self.tables.flat;
        let prims = &self.tree.prims;
        let mut count = WalkCount::default();
        let hits = |id: u32| prims[id as usize].intersect(ray, t_max).ok;
        let blocked = table_any(f, key, ray.d, t_max, skip, &mut count, hits);
        r.shadow.untabled += f.cube_of(key).is_none() as u64;
        r.shadow.rays += 1;
        r.shadow.tests += count.tests as u64;
        r.shadow_blocked += blocked as u64;
        if self.params.verify_every > 0 && n % self.params.verify_every as u64 == 0 {
            r.verified += 1;
            let want = brute_nearest(prims, ray, t_max, skip).found;
            if want != blocked {
                r.mismatches += 1;
                r.first_mismatch.get_or_insert(format!(
                    "{key:?} any o={} d={} t_max={t_max} skip={skip}: walker {blocked} brute {want}",
                    ray.o, ray.d
                ));
            }
        }
        blocked
    }

    /// Traces `tr` and, depth first, everything its hit spawns.
    fn trace(&self, r: &mut AuditResult, tr: TreeRay, n: u64) {
        let hit = self.nearest(r, &tr, n);
        let (mut shadows, mut rays) = (Vec::new(), Vec::new());
        self.tree.spawn(&tr, &hit, self.params.max_depth, &mut shadows, &mut rays);
        let f = &self.tables.flat;
        for s in &shadows {
            let light_table = f.cube_of(OriginKey::Light(s.light)).is_some();
            if let Some((key, ray, t_max)) = self.tree.shadow_ray(s, light_table) {
                self.any(r, key, &ray, t_max, s.skip, n);
            }
        }
        for child in rays {
            self.trace(r, child, n);
        }
    }
}

/// Traces the primary rays of `params` and their ray trees and counts tests per ray kind.
pub fn trace_counts(scene: &Scene, tables: &Tables, params: AuditParams) -> AuditResult {
    let start = std::time::Instant::now();
    let tracer = Tracer { tree: RayTree::new(scene, tables.spawn, scene.effects().shadows), tables, params };
    let (w, h) = (params.width, params.height);
    let (cols, rows, off) = if params.corners { (w + 1, h + 1, 0.0) } else { (w, h, 0.5) };
    let mut total = (0..rows)
        .into_par_iter()
        .map(|j| {
            let mut r = AuditResult::default();
            for i in 0..cols {
                let n = (j * cols + i) as u64;
                tracer.trace(&mut r, tracer.tree.eye_ray(i as f64 + off, j as f64 + off, w, h), n);
            }
            r
        })
        .reduce(AuditResult::default, |mut a, b| {
            a += b;
            a
        });
    for k in [&mut total.eye, &mut total.shadow, &mut total.reflect, &mut total.refract] {
        k.tests_per_ray = if k.rays > 0 { k.tests as f64 / k.rays as f64 } else { 0.0 };
    }
    total.trace_s = start.elapsed().as_secs_f64();
    total
}
