//! Whitted shading: the ray tree of one eye ray, with shadow, reflection and refraction
//! rays, and the lights' falloff.
//!
//! At a hit with material m, base colour C (m.color × texture), shading normal N and
//! geometric normal turned towards the incoming ray, viewer direction V = −d:
//!
//! ```text
//! L = m.emission + ambient·kd·C
//!   + Σ_lights [N·Lᵢ > 0, unshadowed] Iᵢ·(kd·C·(N·Lᵢ) + ks·max(Rᵢ·V, 0)^shine)
//!   + mirror·L(reflected ray)                  (mirror + transmittance under total internal reflection)
//!   + transmittance·T·L(refracted ray)         (T: the base colour if the transmission
//!                                               is tinted (glTF), else 1 (NFF))
//! ```
//!
//! - Iᵢ = colour·intensity·falloff. NFF lights have no falloff. glTF point and spot lights
//!   fall off as 1/d², times glTF's range window `clamp(1 − (d/range)⁴, 0, 1)`; spot
//!   lights are further scaled by glTF's cone term `clamp((cos α − cos outer)/(cos inner −
//!   cos outer), 0, 1)²`. Directional lights shine along their direction with no falloff.
//! - A shadow ray is traced only where N·Lᵢ > 0 and the light's falloff is not zero. It
//!   starts at the hit point offset along the geometric normal towards the light, ends
//!   before a positional light by 1e-9 of the light's own scale (its distance from the
//!   origin plus from the eye, or the ray's length if shorter; at least 2⁻⁵⁰ of that length,
//!   beyond f64 rounding), and any hit blocks it. Scaling the cut by the ray's length alone
//!   lost blockers next to the light for points far away: on a sphere of radius 10¹¹ around
//!   a scene, a cut of 100 units passed through an object 19 units from the light.
//! - Rᵢ is Lᵢ mirrored about N (Phong).
//! - A reflection ray (r = d − 2(d·N)N, Glassner §2.6) is spawned on every hit of a
//!   surface that reflects (mirror > 0) or transmits, a refraction ray (Snell, relative
//!   index 1/ior entering, ior leaving) on every hit of a transmitting surface unless the
//!   ray is totally internally reflected; both only while the depth stays within
//!   `max_depth` (the eye ray is depth 1). "Entering" means hitting the outward side of
//!   the geometric normal (triangles: the side of (p1 − p0) × (p2 − p0)).
//! - With a shading normal, a reflected or refracted direction that would cross the
//!   geometric surface the wrong way is recomputed with the geometric normal.
//! - A material with maps has its Whitted terms evaluated at the hit, and a normal map
//!   bends N there ([`texture::shading`], [`texture::normal`]).
//! - A blended (glTF `alphaMode` BLEND) surface of alpha α weights all of the above by α
//!   and adds (1 − α)·L(pass-through ray): a ray on along d from the far side of the hit,
//!   of kind refraction and one depth deeper (none beyond `max_depth`).

use glam::DVec3;

use super::accel::{Intersector, NearestHit, OriginKey, ShadowQuery};
use super::geometry::{spawn_offset, spawn_origin, surface, Ray, SurfacePoint};
use super::texture;
use crate::scene::{Alpha, Light, LightKind, Scene, Shading};
use crate::stats::{Counters, RayKind};

/// Shadow rays towards a positional light end this much of the light's scale before it
/// ([`shadow_t_max`]).
pub const SHADOW_END_REL: f64 = 1e-9;

/// Where a shadow ray from `o` towards a positional light at `light` ends (`eye`: the
/// camera's eye): short of the light by [`SHADOW_END_REL`] of the light's scale, so that the
/// light's own surroundings still block it however far away `o` lies.
pub fn shadow_t_max(o: DVec3, light: DVec3, eye: DVec3) -> f64 {
    let d = (light - o).length();
    let scale = d.min(light.length() + (light - eye).length());
    d - (SHADOW_END_REL * scale).max(d * 2f64.powi(-50))
}

/// A spawned ray whose nearest hit (a shadow ray: any blocker) lies within this many spawn
/// offsets of its origin is counted in `rays.self_hits` (the same rule as the kernels', in
/// the reference's own offsets).
pub const SELF_HIT_SPAWNS: f64 = 4.0;

/// Direction, distance and strength of a light's incidence at a point.
pub struct Incidence {
    /// Unit vector from the point towards the light.
    pub dir: DVec3,
    /// Distance to the light; `None` for directional lights.
    pub distance: Option<f64>,
    /// Colour × intensity × falloff.
    pub radiance: DVec3,
}

/// How light `l` reaches point `p`, or `None` where it contributes nothing.
pub fn incidence(l: &Light, p: DVec3) -> Option<Incidence> {
    let base = l.color * l.intensity;
    if l.kind == LightKind::Directional {
        let dir = -l.direction;
        return (base.max_element() > 0.0).then_some(Incidence { dir, distance: None, radiance: base });
    }
    let to = l.position - p;
    let d = to.length();
    if d <= 0.0 || !d.is_finite() {
        return None;
    }
    let dir = to / d;
    let mut scale = 1.0;
    if l.inverse_square {
        scale /= d * d;
    }
    if let Some(range) = l.range {
        scale *= (1.0 - (d / range).powi(4)).clamp(0.0, 1.0);
    }
    if let LightKind::Spot { inner_cone, outer_cone } = l.kind {
        let cos_outer = outer_cone.cos();
        let span = (inner_cone.cos() - cos_outer).max(1e-3);
        let cd = l.direction.dot(-dir);
        let a = ((cd - cos_outer) / span).clamp(0.0, 1.0);
        scale *= a * a;
    }
    let radiance = base * scale;
    (radiance.max_element() > 0.0 && radiance.is_finite()).then_some(Incidence {
        dir,
        distance: Some(d),
        radiance,
    })
}

/// The first-hit record an AOV needs.
pub struct FirstHit {
    pub t: f64,
    pub prim: u32,
    /// Shading normal turned to face the ray.
    pub normal: DVec3,
}

/// Traces ray trees against one scene and one acceleration structure.
pub struct Tracer<'a> {
    pub scene: &'a Scene,
    pub accel: &'a dyn Intersector,
    /// Maximum ray-tree depth, the eye ray being depth 1.
    pub max_depth: u32,
}

impl Tracer<'_> {
    /// Radiance along an eye ray.
    pub fn eye(&self, ray: &Ray, c: &mut Counters) -> DVec3 {
        self.trace(ray, OriginKey::Eye, RayKind::Eye, 1, 0.0, c)
    }

    /// The first hit of an eye ray (for AOVs), counted as an eye ray.
    pub fn first_hit(&self, ray: &Ray, c: &mut Counters) -> Option<FirstHit> {
        c.count_ray(RayKind::Eye);
        let h = self.accel.closest(ray, OriginKey::Eye, f64::INFINITY, c.tests_mut(RayKind::Eye))?;
        c.eye_hit += 1;
        let s = surface(&self.scene.primitives[h.prim as usize], ray, &h.hit);
        let normal = if ray.dir.dot(s.ng) < 0.0 { s.ns } else { -s.ns };
        Some(FirstHit { t: h.hit.t, prim: h.prim, normal })
    }

    /// Radiance along `ray` of `kind`, whose origin was moved `spawn` off the surface it
    /// leaves (0 for the eye).
    #[allow(clippy::too_many_arguments)]
    fn trace(
        &self,
        ray: &Ray,
        origin: OriginKey,
        kind: RayKind,
        depth: u32,
        spawn: f64,
        c: &mut Counters,
    ) -> DVec3 {
        c.count_ray(kind);
        match self.accel.closest(ray, origin, f64::INFINITY, c.tests_mut(kind)) {
            None => match &self.scene.environment {
                Some(env) => env.radiance(ray.dir),
                None => self.scene.background,
            },
            Some(h) => {
                if kind == RayKind::Eye {
                    c.eye_hit += 1;
                } else if h.hit.t < SELF_HIT_SPAWNS * spawn {
                    c.self_hits += 1;
                }
                self.shade(ray, &h, depth, c)
            }
        }
    }

    /// `l` plus what the lights add at surface point `s` of primitive `prim` with Whitted
    /// terms `sh`, normal `n` and view `v` (both facing the ray): each light's diffuse and
    /// Phong terms where its shadow ray is not blocked.
    #[allow(clippy::too_many_arguments)]
    fn direct(
        &self,
        mut l: DVec3,
        s: &SurfacePoint,
        prim: u32,
        sh: &Shading,
        n: DVec3,
        v: DVec3,
        c: &mut Counters,
    ) -> DVec3 {
        let scene = self.scene;
        let diffuse = sh.color * sh.kd;
        for (i, light) in scene.lights.iter().enumerate() {
            let Some(inc) = incidence(light, s.p) else { continue };
            let n_dot_l = n.dot(inc.dir);
            if n_dot_l <= 0.0 {
                continue;
            }
            let o = spawn_origin(s, inc.dir);
            let t_max = match inc.distance {
                Some(_) => shadow_t_max(o, light.position, scene.camera.eye),
                None => f64::INFINITY,
            };
            let q = ShadowQuery {
                ray: Ray::new(o, inc.dir),
                t_max,
                object: prim,
                light: i as u32,
                light_position: inc.distance.map(|_| light.position),
            };
            c.count_ray(RayKind::Shadow);
            if self.accel.occluded(&q, c.tests_mut(RayKind::Shadow)) {
                c.shadow_blocked += 1;
                // A self-hit when something blocks it within SELF_HIT_SPAWNS offsets: a second,
                // short query from the point, its tests not counted (it is instrumentation).
                let near = ShadowQuery {
                    t_max: q.t_max.min(SELF_HIT_SPAWNS * spawn_offset(s)),
                    light_position: None,
                    ..q
                };
                if self.accel.occluded(&near, &mut Default::default()) {
                    c.self_hits += 1;
                }
                continue;
            }
            let mut local = diffuse * n_dot_l;
            if sh.ks > 0.0 {
                let r = n * (2.0 * n_dot_l) - inc.dir;
                let r_dot_v = r.dot(v);
                if r_dot_v > 0.0 {
                    local += DVec3::splat(sh.ks * r_dot_v.powf(sh.shine));
                }
            }
            l += inc.radiance * local;
        }
        l
    }

    fn shade(&self, ray: &Ray, h: &NearestHit, depth: u32, c: &mut Counters) -> DVec3 {
        let scene = self.scene;
        let prim = &scene.primitives[h.prim as usize];
        let m = &scene.materials[prim.material() as usize];
        let mut s: SurfacePoint = surface(prim, ray, &h.hit);
        let d = ray.dir;
        // The coat reads the interpolated normal, not the base's normal map.
        let coat = texture::clearcoat(scene, m, &s, d);
        s.ns = texture::normal(scene, m, &s);
        // Normals turned to face the incoming ray.
        let entering = d.dot(s.ng) < 0.0;
        let (ng, n) = if entering { (s.ng, s.ns) } else { (-s.ng, -s.ns) };
        // Light reaching this hit from inside an attenuating body crossed `t` of it.
        let through =
            if !entering && m.attenuates() { attenuated(m.attenuation, h.hit.t) } else { DVec3::ONE };
        let sh = texture::shading(scene, m, &s);
        let base = sh.color;
        let diffuse = base * sh.kd;
        let v = -d;
        // What the base sends passes through the coat's 1 − k.
        let (coat_k, coat_mirror) = coat.as_ref().map_or((0.0, 0.0), |c| (c.k, c.mirror));
        let under = 1.0 - coat_k;

        let mut l = self.direct(sh.emission + scene.ambient * diffuse, &s, h.prim, &sh, n, v, c);
        l *= under;
        // A blended surface sends alpha of this, and lets 1 − alpha through.
        let alpha = if m.alpha == Alpha::Blend { texture::alpha(scene, m, s.uv) } else { 1.0 };
        if depth >= self.max_depth {
            return l * alpha * through;
        }
        let transmits = sh.transmittance > 0.0;
        let refracted = if transmits { refract(d, n, ng, entering, m.ior) } else { None };
        let transmitted = under * sh.transmittance * if m.tinted_transmission { base } else { DVec3::ONE };
        if sh.mirror.max_element() > 0.0 || transmits || coat_mirror > 0.0 {
            // One reflected ray: about the coat's normal where the coat reflects.
            let rn = match &coat {
                Some(c) if coat_mirror > 0.0 => c.normal,
                _ => n,
            };
            let mut r = reflect(d, rn);
            if r.dot(ng) <= 0.0 {
                r = reflect(d, ng);
            }
            let mut weight = under * sh.mirror + DVec3::splat(coat_mirror);
            if transmits && refracted.is_none() {
                // Total internal reflection: what would have been transmitted is reflected.
                weight += transmitted;
            }
            let rr = Ray::new(spawn_origin(&s, r), r);
            let spawn = spawn_offset(&s);
            l += weight * self.trace(&rr, OriginKey::Surface(h.prim), RayKind::Reflect, depth + 1, spawn, c);
        }
        if let Some(t) = refracted {
            let rt = Ray::new(spawn_origin(&s, t), t);
            let spawn = spawn_offset(&s);
            l += transmitted
                * self.trace(&rt, OriginKey::Surface(h.prim), RayKind::Refract, depth + 1, spawn, c);
        }
        l *= alpha;
        if alpha < 1.0 {
            let rp = Ray::new(spawn_origin(&s, d), d);
            let spawn = spawn_offset(&s);
            l += (1.0 - alpha)
                * self.trace(&rp, OriginKey::Surface(h.prim), RayKind::Refract, depth + 1, spawn, c);
        }
        l * through
    }
}

/// What reaches the end of `t` of a body of Beer–Lambert coefficient `sigma`: `exp(−σ·t)`.
pub fn attenuated(sigma: DVec3, t: f64) -> DVec3 {
    (-sigma * t).exp()
}

/// Mirror reflection of unit `d` about unit `n`, renormalised.
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    (d - n * (2.0 * d.dot(n))).normalize()
}

/// The refracted direction of `d` at a surface with normals `n` (shading) and `ng`
/// (geometric), both facing the incoming ray; `None` on total internal reflection.
pub fn refract(d: DVec3, n: DVec3, ng: DVec3, entering: bool, ior: f64) -> Option<DVec3> {
    let eta = if entering { 1.0 / ior } else { ior };
    let snell = |n: DVec3| -> Option<DVec3> {
        let cos_i = -d.dot(n);
        let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
        (k >= 0.0).then(|| (d * eta + n * (eta * cos_i - k.sqrt())).normalize())
    };
    let t = snell(n)?;
    if t.dot(ng) < 0.0 {
        Some(t)
    } else {
        // The shading normal bent the ray back out of the surface: use the geometric one.
        snell(ng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snell_and_total_internal_reflection() {
        let n = DVec3::Y;
        let d = DVec3::new(1.0, -1.0, 0.0).normalize();
        let t = refract(d, n, n, true, 1.5).unwrap();
        let sin_t = t.x;
        assert!((sin_t - (45f64.to_radians().sin() / 1.5)).abs() < 1e-12);
        // Leaving glass at 45°: sin θt = 1.5·0.707 > 1.
        assert!(refract(d, n, n, false, 1.5).is_none());
        // Normal incidence goes straight through.
        let t = refract(DVec3::NEG_Y, n, n, true, 1.5).unwrap();
        assert!((t - DVec3::NEG_Y).length() < 1e-15);
    }

    #[test]
    fn gltf_falloff() {
        let mut l = Light::point(DVec3::ZERO, DVec3::ONE, 4.0);
        l.inverse_square = true;
        let inc = incidence(&l, DVec3::new(0.0, 2.0, 0.0)).unwrap();
        assert!((inc.radiance.x - 1.0).abs() < 1e-12);
        assert!((inc.dir - DVec3::NEG_Y).length() < 1e-15);
        l.range = Some(2.0);
        assert!(incidence(&l, DVec3::new(0.0, 2.5, 0.0)).is_none());
        l.range = None;
        l.kind = LightKind::Spot { inner_cone: 0.1, outer_cone: 0.5 };
        l.direction = DVec3::NEG_Y;
        // On the axis: full; outside the outer cone: nothing.
        assert!((incidence(&l, DVec3::new(0.0, -2.0, 0.0)).unwrap().radiance.x - 1.0).abs() < 1e-12);
        assert!(incidence(&l, DVec3::new(2.0, -2.0, 0.0)).is_none());
    }
}
