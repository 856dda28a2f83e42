//! Measuring the tables: primitive tests per ray, by ray kind, over a scene's primary rays and
//! the Whitted ray trees they spawn, traced in f32 with the kernels' intersection and spawn
//! twins ([`crate::kernel`]) and the table walker. Optionally checks a share of the rays
//! against testing every primitive.
//!
//! This is a geometric tracer only (no shading): it spawns a shadow ray per light where the
//! surface faces the light, a reflection ray on reflecting surfaces, a refraction ray on
//! transmitting ones (Snell's law; total internal reflection spawns a reflection instead), up
//! to a maximum depth (the eye ray is depth 1), as the reference renderer does.

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::Serialize;

use super::tables::Tables;
use super::walk::{cube_walk_any, cube_walk_nearest, OriginKey, WalkCount};
use crate::kernel::closest::{brute_nearest, test_prim, Closest};
use crate::kernel::geometry::{make_ray, surface, Prim32, PrimHit, Ray};
use crate::kernel::spawn::spawn_origin;
use crate::kernel::{FAR, NO_ID, SHADOW_END_REL};
use crate::scene::{LightKind, Scene};

/// What to trace.
#[derive(Clone, Copy, Debug)]
pub struct BenchParams {
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
    /// Group bounding-sphere tests.
    pub bounds: u64,
    /// Rays whose origin had no table (they walk the fallback origin: every primitive).
    pub untabled: u64,
    pub tests_per_ray: f64,
    pub bounds_per_ray: f64,
}

/// The measurement.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BenchResult {
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
        self.bounds += o.bounds;
        self.untabled += o.untabled;
    }
}

impl std::ops::AddAssign for BenchResult {
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

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Eye,
    Reflect,
    Refract,
}

struct Tracer<'a> {
    scene: &'a Scene,
    tables: &'a Tables,
    prims: Vec<Prim32>,
    lights: Vec<(Vec3, LightKind, Vec3)>,
    params: BenchParams,
}

fn kind_mut(r: &mut BenchResult, kind: Kind) -> &mut KindCount {
    match kind {
        Kind::Eye => &mut r.eye,
        Kind::Reflect => &mut r.reflect,
        Kind::Refract => &mut r.refract,
    }
}

impl Tracer<'_> {
    #[allow(clippy::too_many_arguments)]
    fn nearest(
        &self,
        r: &mut BenchResult,
        kind: Kind,
        key: OriginKey,
        ray: &Ray,
        skip: u32,
        n: u64,
    ) -> Closest<f32, PrimHit> {
        let f = &self.tables.flat;
        let mut count = WalkCount::default();
        let hit = cube_walk_nearest(f, f.cube_origin(key), ray.o, ray.d, FAR, skip, &mut count, |id| {
            test_prim(&self.prims[id as usize], ray, FAR)
        });
        let c = kind_mut(r, kind);
        c.rays += 1;
        c.untabled += f.table_of(key).is_none() as u64;
        c.tests += count.tests as u64;
        c.bounds += count.bounds as u64;
        if self.params.verify_every > 0 && n % self.params.verify_every as u64 == 0 {
            r.verified += 1;
            let want = brute_nearest(&self.prims, ray, FAR, skip);
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
            if skip != NO_ID && self.prims[skip as usize].intersect(ray, hit.best_t(FAR)).ok {
                r.self_hits += 1;
            }
        }
        hit
    }

    #[allow(clippy::too_many_arguments)]
    fn any(&self, r: &mut BenchResult, key: OriginKey, ray: &Ray, t_max: f32, skip: u32, n: u64) -> bool {
        let f = &self.tables.flat;
        let mut count = WalkCount::default();
        let hits = |id: u32| self.prims[id as usize].intersect(ray, t_max).ok;
        let blocked = cube_walk_any(f, f.cube_origin(key), ray.o, ray.d, t_max, skip, &mut count, hits);
        r.shadow.untabled += f.table_of(key).is_none() as u64;
        r.shadow.rays += 1;
        r.shadow.tests += count.tests as u64;
        r.shadow.bounds += count.bounds as u64;
        r.shadow_blocked += blocked as u64;
        if self.params.verify_every > 0 && n % self.params.verify_every as u64 == 0 {
            r.verified += 1;
            let want = brute_nearest(&self.prims, ray, t_max, skip).found;
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

    /// Which primitive a ray leaving primitive `id` towards `dir` need not test (WGSL
    /// `leave_skip`): a triangle, or a sphere left outwards.
    fn leave_skip(&self, id: u32, dir: Vec3, ng: Vec3) -> u32 {
        match self.prims[id as usize] {
            Prim32::Triangle { .. } => id,
            Prim32::Sphere { inside_only: false, .. } if dir.dot(ng) > 0.0 => id,
            _ => NO_ID,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn trace(
        &self,
        r: &mut BenchResult,
        kind: Kind,
        key: OriginKey,
        ray: Ray,
        skip: u32,
        depth: u32,
        n: u64,
    ) {
        let hit = self.nearest(r, kind, key, &ray, skip, n);
        if !hit.found {
            return;
        }
        let id = hit.prim;
        let s = surface(&self.prims[id as usize], &ray, &hit.hit);
        let (d, ng) = (ray.d, s.ng);
        if !ng.is_finite() {
            return;
        }
        let outside = d.dot(ng) < 0.0; // arrived from the side the normal points to
        let nf = if outside { ng } else { -ng };
        let spawn = |dir: Vec3| spawn_origin(&s, dir, self.tables.spawn);
        let prim = &self.scene.primitives[id as usize];
        let mat = &self.scene.materials[prim.material() as usize];
        for (li, &(lp, lk, ldir)) in self.lights.iter().enumerate() {
            let to_light = if lk == LightKind::Directional { -ldir } else { (lp - s.p).normalize() };
            if nf.dot(to_light) <= 0.0 {
                continue;
            }
            let q = spawn(to_light);
            let skip = self.leave_skip(id, to_light, ng);
            // As the kernels choose (`shadow_walk`): a light with a table of its own is traced
            // from the light towards the point, any other from the point.
            if self.tables.flat.table_of(OriginKey::Light(li)).is_some() {
                let v = q - lp;
                let dist = v.length();
                if dist > 0.0 {
                    self.any(
                        r,
                        OriginKey::Light(li),
                        &make_ray(lp, v),
                        dist * (1.0 - SHADOW_END_REL),
                        skip,
                        n,
                    );
                }
            } else {
                let t_max = if lk == LightKind::Directional {
                    FAR
                } else {
                    (lp - q).length() * (1.0 - SHADOW_END_REL)
                };
                self.any(r, OriginKey::Surface(id, q), &make_ray(q, to_light), t_max, skip, n);
            }
        }
        if depth >= self.params.max_depth {
            return;
        }
        let refl = (d - 2.0 * d.dot(ng) * ng).normalize();
        let mut want_reflect = mat.reflects();
        if mat.transmits() {
            let eta = if outside { 1.0 / mat.ior as f32 } else { mat.ior as f32 };
            let cosi = -d.dot(nf);
            let k = 1.0 - eta * eta * (1.0 - cosi * cosi);
            if k < 0.0 {
                want_reflect = true;
            } else {
                let dt = (eta * d + (eta * cosi - k.sqrt()) * nf).normalize();
                let q = spawn(dt);
                let skip = self.leave_skip(id, dt, ng);
                self.trace(r, Kind::Refract, OriginKey::Surface(id, q), make_ray(q, dt), skip, depth + 1, n);
            }
        }
        if want_reflect {
            let q = spawn(refl);
            let skip = self.leave_skip(id, refl, ng);
            self.trace(r, Kind::Reflect, OriginKey::Surface(id, q), make_ray(q, refl), skip, depth + 1, n);
        }
    }
}

/// Traces the primary rays of `params` and their ray trees and counts tests per ray kind.
pub fn trace_counts(scene: &Scene, tables: &Tables, params: BenchParams) -> BenchResult {
    let start = std::time::Instant::now();
    let eye = scene.camera.eye;
    let shift = |p: DVec3| (p - eye).as_vec3();
    let tracer = Tracer {
        scene,
        tables,
        prims: Prim32::from_scene(scene, eye),
        lights: if scene.effects().shadows {
            scene.lights.iter().map(|l| (shift(l.position), l.kind, l.direction.as_vec3())).collect()
        } else {
            Vec::new()
        },
        params,
    };
    let (w, h) = (params.width, params.height);
    let (cols, rows, off) = if params.corners { (w + 1, h + 1, 0.0) } else { (w, h, 0.5) };
    let mut total = (0..rows)
        .into_par_iter()
        .map(|j| {
            let mut r = BenchResult::default();
            for i in 0..cols {
                let (o, d) = scene.camera.ray(i as f64 + off, j as f64 + off, w, h);
                let n = (j * cols + i) as u64;
                tracer.trace(&mut r, Kind::Eye, OriginKey::Eye, make_ray(shift(o), d.as_vec3()), NO_ID, 1, n);
            }
            r
        })
        .reduce(BenchResult::default, |mut a, b| {
            a += b;
            a
        });
    for k in [&mut total.eye, &mut total.shadow, &mut total.reflect, &mut total.refract] {
        k.tests_per_ray = if k.rays > 0 { k.tests as f64 / k.rays as f64 } else { 0.0 };
        k.bounds_per_ray = if k.rays > 0 { k.bounds as f64 / k.rays as f64 } else { 0.0 };
    }
    total.trace_s = start.elapsed().as_secs_f64();
    total
}
