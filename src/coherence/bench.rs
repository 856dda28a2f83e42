//! Measuring the tables: primitive tests per ray, by ray kind, over a scene's primary rays and
//! the Whitted ray trees they spawn, traced in f32 with the [`crate::mirror`] functions and the
//! table walker. Optionally checks a share of the rays against testing every primitive.
//!
//! This is a geometric tracer only (no shading): it spawns a shadow ray per light where the
//! surface faces the light, a reflection ray on reflecting surfaces, a refraction ray on
//! transmitting ones (Snell's law; total internal reflection spawns a reflection instead), up
//! to a maximum depth (the eye ray is depth 1), as the reference renderer does.

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::Serialize;

use super::build::{ShadowMode, Tables};
use super::walk::{OriginKey, WalkCount};
use crate::mirror::{self, Prim32, F32_MAX, NO_ID};
use crate::scene::{LightKind, Primitive, Scene};

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
    /// Rays whose origin had no table (traced by brute force, tests counted here too).
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
        o: Vec3,
        d: Vec3,
        skip: u32,
        n: u64,
    ) -> (u32, f32) {
        let f = &self.tables.flat;
        let (hit, tests, untabled) = match f.origin(key) {
            Some(org) => {
                let (h, tests) = mirror::cube_walk_nearest(f, org, o, d, F32_MAX, skip, |id| {
                    self.prims[id as usize].intersect(o, d)
                });
                ((h.id, h.t), tests, 0)
            }
            None => (
                mirror::brute_nearest(&self.prims, o, d, F32_MAX, skip),
                WalkCount { tests: self.prims.len() as u32, bounds: 0 },
                1,
            ),
        };
        let c = kind_mut(r, kind);
        c.rays += 1;
        c.untabled += untabled;
        c.tests += tests.tests as u64;
        c.bounds += tests.bounds as u64;
        if self.params.verify_every > 0 && n % self.params.verify_every as u64 == 0 {
            r.verified += 1;
            let want = mirror::brute_nearest(&self.prims, o, d, F32_MAX, skip);
            if want != hit {
                r.mismatches += 1;
                r.first_mismatch
                    .get_or_insert(format!("{key:?} o={o} d={d} skip={skip}: walker {hit:?} brute {want:?}"));
            }
            if skip != NO_ID && self.prims[skip as usize].intersect(o, d) < hit.1 {
                r.self_hits += 1;
            }
        }
        hit
    }

    #[allow(clippy::too_many_arguments)]
    fn any(
        &self,
        r: &mut BenchResult,
        key: OriginKey,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        skip: u32,
        n: u64,
    ) -> bool {
        let f = &self.tables.flat;
        let (blocked, tests) = match f.origin(key) {
            Some(org) => {
                let (b, tests) = mirror::cube_walk_any(f, org, o, d, t_max, skip, |id| {
                    self.prims[id as usize].intersect(o, d)
                });
                (b, tests)
            }
            None => {
                r.shadow.untabled += 1;
                (
                    mirror::brute_nearest(&self.prims, o, d, t_max, skip).0 != NO_ID,
                    WalkCount { tests: self.prims.len() as u32, bounds: 0 },
                )
            }
        };
        r.shadow.rays += 1;
        r.shadow.tests += tests.tests as u64;
        r.shadow.bounds += tests.bounds as u64;
        r.shadow_blocked += blocked as u64;
        if self.params.verify_every > 0 && n % self.params.verify_every as u64 == 0 {
            r.verified += 1;
            let want = mirror::brute_nearest(&self.prims, o, d, t_max, skip);
            if (want.0 != NO_ID) != blocked {
                r.mismatches += 1;
                r.first_mismatch.get_or_insert(format!(
                    "{key:?} any o={o} d={d} t_max={t_max} skip={skip}: walker {blocked} brute {want:?}"
                ));
            }
        }
        blocked
    }

    /// Geometric normal at `p` on primitive `id` (unit, outward for spheres and cylinders).
    fn normal(&self, id: u32, p: Vec3) -> Vec3 {
        match self.prims[id as usize] {
            Prim32::Sphere { c, .. } => (p - c).normalize(),
            Prim32::Triangle { p: v } => (v[1] - v[0]).cross(v[2] - v[0]).normalize(),
            Prim32::Cylinder { base, r0, apex, r1 } => {
                let axis = apex - base;
                let len = axis.length();
                let a = axis / len;
                let x = p - base;
                let radial = x - x.dot(a) * a;
                let k = (r1 - r0) / len;
                (radial.normalize_or_zero() - k * a).normalize_or_zero()
            }
        }
    }

    /// Whether rays leaving `id` at this hit may skip testing `id` (convex, left from outside).
    fn can_skip(&self, id: u32, leaves_outside: bool) -> u32 {
        match &self.scene.primitives[id as usize] {
            Primitive::Triangle(_) => id,
            Primitive::Sphere(s) if leaves_outside && !s.inside_only => id,
            _ => NO_ID,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn trace(
        &self,
        r: &mut BenchResult,
        kind: Kind,
        key: OriginKey,
        o: Vec3,
        d: Vec3,
        skip: u32,
        depth: u32,
        n: u64,
    ) {
        let (id, t) = self.nearest(r, kind, key, o, d, skip, n);
        if id == NO_ID {
            return;
        }
        let p = o + t * d;
        let ng = self.normal(id, p);
        if ng == Vec3::ZERO {
            return;
        }
        let outside = d.dot(ng) < 0.0; // arrived from the side the normal points to
        let nf = if outside { ng } else { -ng };
        let prim = &self.scene.primitives[id as usize];
        let mat = &self.scene.materials[prim.material() as usize];
        for (li, &(lp, lk, ldir)) in self.lights.iter().enumerate() {
            let to_light = if lk == LightKind::Directional { -ldir } else { lp - p };
            if nf.dot(to_light) <= 0.0 {
                continue;
            }
            let q = mirror::offset_ray_origin(p, ng, to_light);
            let use_light =
                lk != LightKind::Directional && self.tables.shadow_mode == ShadowMode::LightBuffer;
            if use_light {
                let v = q - lp;
                let dist = v.length();
                self.any(r, OriginKey::Light(li), lp, v / dist, dist * (1.0 - 1e-4), NO_ID, n);
            } else {
                let (dir, t_max) = if lk == LightKind::Directional {
                    (to_light.normalize(), F32_MAX)
                } else {
                    let v = lp - q;
                    (v.normalize(), v.length())
                };
                let skip = self.can_skip(id, true);
                self.any(r, OriginKey::Surface(id, q), q, dir, t_max, skip, n);
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
                let q = mirror::offset_ray_origin(p, ng, dt);
                let skip = if matches!(prim, Primitive::Triangle(_)) { id } else { NO_ID };
                self.trace(r, Kind::Refract, OriginKey::Surface(id, q), q, dt, skip, depth + 1, n);
            }
        }
        if want_reflect {
            let q = mirror::offset_ray_origin(p, ng, refl);
            let skip = self.can_skip(id, outside);
            self.trace(r, Kind::Reflect, OriginKey::Surface(id, q), q, refl, skip, depth + 1, n);
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
                tracer.trace(
                    &mut r,
                    Kind::Eye,
                    OriginKey::Eye,
                    shift(o),
                    d.as_vec3().normalize(),
                    NO_ID,
                    1,
                    n,
                );
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
