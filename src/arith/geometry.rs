//! Rays and primitive intersection in f32: the twins of `shaders/shared/geometry.wgsl` and
//! `shaders/shared/intersect.wgsl` (keep them in sync), function for function and with the
//! same names.
//!
//! | Rust | WGSL |
//! |---|---|
//! | [`make_ray`] | `fn make_ray(o: vec3<f32>, dir: vec3<f32>) -> Ray` |
//! | [`intersect_sphere`] | `fn intersect_sphere(center, radius, inside_only, ray, t_max) -> PrimHit` |
//! | [`intersect_triangle`] | `fn intersect_triangle(p0, p1, p2, ray, t_max) -> PrimHit` |
//! | [`intersect_cylinder`] | `fn intersect_cylinder(base: vec4, apex: vec4, inside_only, ray, t_max) -> PrimHit` |
//! | [`Prim32::intersect`] | `fn intersect_prim(p: Prim, ray: Ray, t_max: f32) -> PrimHit` |
//! | [`surface`] | `fn surface(prim: Prim, ray: Ray, h: PrimHit) -> Surface` (position, normal, scale) |
//!
//! WGSL's `select(f, t, c)` is written `if c { t } else { f }`.

use glam::{DVec3, Vec3};

use crate::scene::{Primitive, Scene};

/// A ray with the watertight triangle test's per-ray constants (WGSL `Ray`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    pub shear: Vec3,
}

/// The ray from `o` along `dir` (normalised here), with the axis permutation and shear of
/// Woop, Benthin and Wald's test.
pub fn make_ray(o: Vec3, dir: Vec3) -> Ray {
    let d = dir.normalize();
    let a = d.abs();
    let mut kz = 2;
    if a.x >= a.y && a.x >= a.z {
        kz = 0;
    } else if a.y >= a.z {
        kz = 1;
    }
    let mut kx = (kz + 1) % 3;
    let mut ky = (kx + 1) % 3;
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let shear = Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    Ray { o, d, kx, ky, kz, shear }
}

/// A hit: `ok` says whether there is one; then t, the barycentrics of vertices 1 and 2, and
/// `err`, a bound on the rounding error of `t` (the tie rule's, [`super::closest`]; WGSL
/// `PrimHit`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PrimHit {
    pub ok: bool,
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
    pub err: f32,
}

pub fn no_hit() -> PrimHit {
    PrimHit { ok: false, t: 0.0, b1: 0.0, b2: 0.0, err: 0.0 }
}

pub fn hit_at(t: f32, err: f32) -> PrimHit {
    PrimHit { ok: true, t, b1: 0.0, b2: 0.0, err }
}

/// The unit roundoff of f32, `2⁻²⁴` (WGSL `UNIT_ROUNDOFF`).
pub const UNIT_ROUNDOFF: f32 = 1.0 / 16777216.0;
/// The widest a hit's error bound may be, relative to the magnitude of its numbers
/// (`t` + the primitive's size from the ray origin): `2⁻¹⁰`. A hit whose arithmetic bounds
/// more (a ray grazing a triangle, a near-double root) is that ill-conditioned, and a wider
/// window would only let farther surfaces tie with it (WGSL `TIE_CAP`).
pub const TIE_CAP: f32 = 1.0 / 1024.0;

/// `γ(n) = n·u / (1 − n·u)`: the relative error bound of `n` rounded operations (Higham;
/// WGSL `gamma`).
pub fn gamma(n: f32) -> f32 {
    let nu = n * UNIT_ROUNDOFF;
    nu / (1.0 - nu)
}

/// The error bound handed to the tie rule for a hit at `t` whose arithmetic bounds `dt`, on
/// numbers of magnitude `scale` from the ray origin: capped at [`TIE_CAP`], rounded up, and
/// widened by an ulp of `t` for the rounding of `t` itself (WGSL `hit_err`).
pub fn hit_err(t: f32, dt: f32, scale: f32) -> f32 {
    let capped = dt.min(TIE_CAP * (t + scale));
    capped * (1.0 + 1.0 / 1048576.0) + t * (2.0 * UNIT_ROUNDOFF)
}

/// The error of `sd = √disc` when `disc` carries an error of at most `dd`: `dd / (2·sd)`,
/// or `√dd` where that is smaller (a discriminant near zero; WGSL `sqrt_err`).
pub fn sqrt_err(dd: f32, sd: f32) -> f32 {
    let near_zero = dd.sqrt();
    if sd > 0.0 {
        near_zero.min(dd / (2.0 * sd))
    } else {
        near_zero
    }
}

/// The error bound of a root `t` of Haines' sphere test (`q`, or `k/q`; `fl` = |f|, the
/// origin's distance from the centre): b carries a few roundings of |f|, the discriminant
/// r² − |g|² a few of r² and r·|f| (g is perpendicular to the ray and |g| ≤ r), its square
/// root that error over 2√disc (or its square root near zero), and k = |f|² − r² a few of
/// |f|² and r² (WGSL `sphere_err`).
pub fn sphere_err(t: f32, q: f32, fl: f32, radius: f32, disc: f32) -> f32 {
    let db = gamma(4.0) * fl;
    let dd = gamma(8.0) * (radius * radius + 4.0 * radius * fl);
    let dq = db + sqrt_err(dd, disc.sqrt()) + gamma(1.0) * q.abs();
    let dt = if t == q {
        dq
    } else {
        let dk = gamma(4.0) * (fl * fl + radius * radius);
        (dk + t.abs() * dq) / q.abs()
    };
    hit_err(t, dt + gamma(2.0) * t, fl + radius)
}

/// The error bound of a root `t` of the cylinder test (`qc/q` when `by_q`, else `q/qa`),
/// from `[|w|, |r_o|, |r_d|, r0, dr, slope, base radius, qa, q, disc]`: the radial parts
/// carry a few roundings of |w| (r_o, s0) and of 1 (r_d), the radius at the origin's height
/// a few of its terms, and each coefficient, the discriminant and its square root what
/// those errors make of them (WGSL `cylinder_err`).
pub fn cylinder_err(t: f32, by_q: bool, parts: [f32; 10], scale: f32) -> f32 {
    let [lw, lro, lrd, r0, dr, slope, base_r, qa, q, disc] = parts;
    let (r0, dr, slope) = (r0.abs(), dr.abs(), slope.abs());
    let ew = gamma(6.0) * lw;
    let er0 = gamma(3.0) * base_r.abs() + gamma(4.0) * slope * lw;
    let erd = gamma(4.0);
    let edr = gamma(4.0) * slope;
    let qc_err = 2.0 * lro * ew + 2.0 * r0 * er0 + gamma(3.0) * (lro * lro + r0 * r0);
    let qb_err = lrd * ew + lro * erd + dr * er0 + r0 * edr + gamma(3.0) * (lro * lrd + r0 * dr);
    let qa_err = 2.0 * lrd * erd + 2.0 * dr * edr + gamma(3.0) * (lrd * lrd + dr * dr);
    let e = lrd * r0 + lro * dr;
    let e_err = lrd * er0 + r0 * erd + lro * edr + dr * ew + gamma(3.0) * e;
    let x = lro * lrd;
    let x_err = lrd * ew + lro * erd + gamma(3.0) * x;
    let dd = 2.0 * e * e_err + 2.0 * x * x_err + gamma(3.0) * (e * e + x * x);
    let dq = qb_err + sqrt_err(dd, disc.sqrt()) + gamma(1.0) * q.abs();
    let dt = if by_q { (qc_err + t.abs() * dq) / q.abs() } else { (dq + t.abs() * qa_err) / qa.abs() };
    hit_err(t, dt + gamma(2.0) * t, scale)
}

/// Ray/sphere, Haines' precise form (*Ray Tracing Gems* ch. 7): the discriminant as
/// `r² − |f + b·d|²`, the roots `k/q` and `q`. An inside-only sphere is hit only from inside.
pub fn intersect_sphere(center: Vec3, radius: f32, inside_only: bool, ray: &Ray, t_max: f32) -> PrimHit {
    let f = ray.o - center;
    let b = -f.dot(ray.d);
    let r2 = radius * radius;
    let g = f + ray.d * b;
    let disc = r2 - g.dot(g);
    if disc < 0.0 {
        return no_hit();
    }
    let k = f.dot(f) - r2;
    let q = b + if b >= 0.0 { disc.sqrt() } else { -disc.sqrt() };
    if q == 0.0 {
        return no_hit();
    }
    let r0 = k / q;
    let t0 = r0.min(q);
    let t1 = r0.max(q);
    let t = if !inside_only && t0 > 0.0 && t0 < t_max {
        t0
    } else if t1 > 0.0 && t1 < t_max {
        t1
    } else {
        return no_hit();
    };
    hit_at(t, sphere_err(t, q, f.length(), radius, disc))
}

/// Ray/triangle, watertight (Woop, Benthin and Wald, JCGT 2013); both sides are hit. Edge
/// values that are exactly zero count as inside (WGSL cannot re-evaluate them in double), so
/// a ray through a shared edge hits both triangles; the nearest-hit rule takes the lower id.
pub fn intersect_triangle(p0: Vec3, p1: Vec3, p2: Vec3, ray: &Ray, t_max: f32) -> PrimHit {
    let s = ray.shear;
    let a = p0 - ray.o;
    let b = p1 - ray.o;
    let c = p2 - ray.o;
    let ax = a[ray.kx] - s.x * a[ray.kz];
    let ay = a[ray.ky] - s.y * a[ray.kz];
    let bx = b[ray.kx] - s.x * b[ray.kz];
    let by = b[ray.ky] - s.y * b[ray.kz];
    let cx = c[ray.kx] - s.x * c[ray.kz];
    let cy = c[ray.ky] - s.y * c[ray.kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return no_hit();
    }
    let det = u + v + w;
    if det == 0.0 {
        return no_hit();
    }
    let t_scaled = s.z * (u * a[ray.kz] + v * b[ray.kz] + w * c[ray.kz]);
    if det > 0.0 {
        if t_scaled <= 0.0 || t_scaled >= t_max * det {
            return no_hit();
        }
    } else if t_scaled >= 0.0 || t_scaled <= t_max * det {
        return no_hit();
    }
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t > 0.0 && t < t_max) {
        return no_hit();
    }
    let sheared = [ax, ay, bx, by, cx, cy];
    let zs = [a[ray.kz], b[ray.kz], c[ray.kz]];
    let scale = a.abs().max_element().max(b.abs().max_element()).max(c.abs().max_element());
    PrimHit {
        ok: true,
        t,
        b1: v * inv,
        b2: w * inv,
        err: triangle_err(t, sheared, zs, s.z, [u, v, w], inv, scale),
    }
}

/// The error bound of the watertight test's `t` (as pbrt-v4 bounds it, on this test's
/// variables): the vertices' sheared coordinates `[ax, ay, bx, by, cx, cy]` and depths `zs`
/// carry a few roundings each, the edge functions `e` the products of those, and `t` is
/// their weighted mean over `det` (`inv` = 1/det; WGSL `triangle_err`).
fn triangle_err(t: f32, sheared: [f32; 6], zs: [f32; 3], sz: f32, e: [f32; 3], inv: f32, scale: f32) -> f32 {
    let max_z = zs[0].abs().max(zs[1].abs()).max(zs[2].abs());
    let max_zt = sz.abs() * max_z;
    let max_xt = sheared[0].abs().max(sheared[2].abs()).max(sheared[4].abs());
    let max_yt = sheared[1].abs().max(sheared[3].abs()).max(sheared[5].abs());
    // The shear's factors are at most 1: kz is the direction's largest axis.
    let dx = gamma(5.0) * (max_xt + max_z);
    let dy = gamma(5.0) * (max_yt + max_z);
    let dz = gamma(4.0) * max_zt;
    let de = 2.0 * (gamma(2.0) * max_xt * max_yt + dy * max_xt + dx * max_yt);
    let max_e = e[0].abs().max(e[1].abs()).max(e[2].abs());
    let dt = 3.0 * (gamma(3.0) * max_e * max_zt + de * max_zt + dz * max_e) * inv.abs();
    hit_err(t, dt, scale)
}

/// Outward unit normal of a cone; at a cone's tip any direction across the axis serves.
pub fn cone_normal(axis: Vec3, slope: f32, radial: Vec3) -> Vec3 {
    let len = radial.length();
    let radial_dir = if len > 0.0 { radial / len } else { any_orthonormal(axis) };
    (radial_dir - axis * slope).normalize()
}

/// A unit vector orthogonal to unit `v` (the same construction as glam's).
pub fn any_orthonormal(v: Vec3) -> Vec3 {
    let sign = if v.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + v.z);
    let b = v.x * v.y * a;
    Vec3::new(b, sign + v.y * v.y * a, -v.y)
}

/// Ray/cylinder or truncated cone without caps (`base`, `apex`: centre and radius in `w`);
/// the discriminant as a difference of squared lengths.
pub fn intersect_cylinder(
    base: [f32; 4],
    apex: [f32; 4],
    inside_only: bool,
    ray: &Ray,
    t_max: f32,
) -> PrimHit {
    let (b3, a3) = (Vec3::new(base[0], base[1], base[2]), Vec3::new(apex[0], apex[1], apex[2]));
    let v = a3 - b3;
    let height = v.length();
    let axis = v / height;
    let slope = (apex[3] - base[3]) / height;
    let w = ray.o - b3;
    let s0 = w.dot(axis);
    let ds = ray.d.dot(axis);
    let r_o = w - axis * s0;
    let r_d = ray.d - axis * ds;
    let r0 = base[3] + slope * s0;
    let dr = slope * ds;
    let qa = r_d.dot(r_d) - dr * dr;
    let qb = r_o.dot(r_d) - r0 * dr;
    let qc = r_o.dot(r_o) - r0 * r0;
    let e = r_d * r0 - r_o * dr;
    let x = r_o.cross(r_d);
    let disc = e.dot(e) - x.dot(x);
    if disc < 0.0 {
        return no_hit();
    }
    let q = -(qb + if qb >= 0.0 { disc.sqrt() } else { -disc.sqrt() });
    if q == 0.0 {
        return no_hit();
    }
    let t_cq = qc / q;
    let mut roots = [t_cq, 0.0];
    let mut n_roots = 1;
    if qa != 0.0 {
        let other = q / qa;
        if other < roots[0] {
            roots[1] = roots[0];
            roots[0] = other;
        } else {
            roots[1] = other;
        }
        n_roots = 2;
    }
    for &t in &roots[..n_roots] {
        if !(t > 0.0 && t < t_max) {
            continue;
        }
        let s = s0 + t * ds;
        if !(s >= 0.0 && s <= height) {
            continue;
        }
        if inside_only {
            let n = cone_normal(axis, slope, r_o + r_d * t);
            if n.dot(ray.d) <= 0.0 {
                continue;
            }
        }
        let scale = w.length() + height + base[3].abs().max(apex[3].abs());
        let parts = [w.length(), r_o.length(), r_d.length(), r0, dr, slope, base[3], qa, q, disc];
        return hit_at(t, cylinder_err(t, t == t_cq, parts, scale));
    }
    no_hit()
}

/// A primitive as the GPU stores it: f32, relative to the camera's eye.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Prim32 {
    Sphere { c: Vec3, r: f32, inside_only: bool },
    Triangle { p: [Vec3; 3] },
    Cylinder { base: [f32; 4], apex: [f32; 4], inside_only: bool },
}

impl Prim32 {
    /// The scene's primitives in f32, translated by `-shift` (subtracted in f64, as the GPU
    /// packing does).
    pub fn from_scene(scene: &Scene, shift: DVec3) -> Vec<Prim32> {
        let v = |p: DVec3| (p - shift).as_vec3();
        let v4 = |p: DVec3, w: f64| {
            let q = v(p);
            [q.x, q.y, q.z, w as f32]
        };
        scene
            .primitives
            .iter()
            .map(|p| match p {
                Primitive::Sphere(s) => {
                    Prim32::Sphere { c: v(s.center), r: s.radius as f32, inside_only: s.inside_only }
                }
                Primitive::Triangle(t) => Prim32::Triangle { p: [v(t.p[0]), v(t.p[1]), v(t.p[2])] },
                Primitive::Cylinder(c) => Prim32::Cylinder {
                    base: v4(c.base, c.base_radius),
                    apex: v4(c.apex, c.apex_radius),
                    inside_only: c.inside_only,
                },
            })
            .collect()
    }

    /// The WGSL `intersect_prim`: the hit with `0 < t < t_max`, if any.
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> PrimHit {
        match *self {
            Prim32::Sphere { c, r, inside_only } => intersect_sphere(c, r, inside_only, ray, t_max),
            Prim32::Triangle { p } => intersect_triangle(p[0], p[1], p[2], ray, t_max),
            Prim32::Cylinder { base, apex, inside_only } => {
                intersect_cylinder(base, apex, inside_only, ray, t_max)
            }
        }
    }
}

pub fn max3(v: Vec3) -> f32 {
    v.x.max(v.y.max(v.z))
}

/// The surface at a hit, as far as the spawn offset needs it (WGSL `Surface` without the
/// shading normal and texture coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    pub p: Vec3,
    /// Unit geometric normal, outward (not flipped toward the ray).
    pub ng: Vec3,
    /// Size of the numbers behind `p`, for the spawn offset.
    pub scale: f32,
}

/// The WGSL `surface`: the hit point, its geometric normal and the magnitude of the numbers
/// the point was computed from.
///
/// The point is computed from the primitive, not from the ray, so that its rounding error
/// scales with the primitive's coordinates and not with how far the ray travelled: on a
/// triangle it is interpolated from the barycentrics, and on a sphere or cone the point
/// `o + t·d` is projected back onto the surface (as pbrt-v4 does), which removes the error
/// of `t` across the surface. `scale` is then the largest coordinate magnitude behind the
/// point: the point itself and the primitive's defining points (plus a sphere's radius).
pub fn surface(prim: &Prim32, ray: &Ray, h: &PrimHit) -> Surface {
    match *prim {
        Prim32::Sphere { c, r, .. } => {
            let v = ray.o + ray.d * h.t - c;
            let len = v.length();
            let ng = v / len;
            let p = c + ng * r;
            Surface { p, ng, scale: max3(p.abs()).max(max3(c.abs()) + r) }
        }
        Prim32::Triangle { p: v } => {
            let b0 = 1.0 - h.b1 - h.b2;
            let p = v[0] * b0 + v[1] * h.b1 + v[2] * h.b2;
            let ng = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            let extent = max3(v[0].abs()).max(max3(v[1].abs()).max(max3(v[2].abs())));
            Surface { p, ng, scale: max3(p.abs()).max(extent) }
        }
        Prim32::Cylinder { base, apex, .. } => {
            let (b3, a3) = (Vec3::new(base[0], base[1], base[2]), Vec3::new(apex[0], apex[1], apex[2]));
            let v = a3 - b3;
            let height = v.length();
            let axis = v / height;
            let slope = (apex[3] - base[3]) / height;
            let w = ray.o + ray.d * h.t - b3;
            let along = w.dot(axis);
            let radial = w - axis * along;
            let ng = cone_normal(axis, slope, radial);
            let len = radial.length();
            let radius = base[3] + slope * along;
            let p = if len > 0.0 { b3 + axis * along + radial * (radius / len) } else { b3 + w };
            let extent = max3(b3.abs()).max(max3(a3.abs()));
            Surface { p, ng, scale: max3(p.abs()).max(extent) }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_hits_inside_and_misses() {
        let far = crate::arith::FAR;
        let ray = make_ray(Vec3::ZERO, Vec3::X);
        assert!((intersect_sphere(Vec3::new(5.0, 0.0, 0.0), 1.0, false, &ray, far).t - 4.0).abs() < 1e-6);
        assert!((intersect_sphere(Vec3::ZERO, 2.0, false, &ray, far).t - 2.0).abs() < 1e-6);
        // Inside only: only the far side, from outside as from inside.
        assert!((intersect_sphere(Vec3::new(5.0, 0.0, 0.0), 1.0, true, &ray, far).t - 6.0).abs() < 1e-6);
        assert!(
            !intersect_sphere(Vec3::new(5.0, 0.0, 0.0), 1.0, false, &make_ray(Vec3::ZERO, -Vec3::X), far).ok
        );
        assert!(
            !intersect_sphere(Vec3::new(5.0, 0.0, 0.0), 1.0, false, &make_ray(Vec3::ZERO, Vec3::Y), far).ok
        );
        // A hit beyond t_max does not count.
        assert!(!intersect_sphere(Vec3::new(5.0, 0.0, 0.0), 1.0, false, &ray, 3.5).ok);
    }

    #[test]
    fn triangle_watertight_shared_edge() {
        // A quad split along its diagonal: a ray through the diagonal hits at least one half.
        let p = [Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, -1.0, 2.0), Vec3::new(1.0, 1.0, 2.0)];
        let q = [Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, 1.0, 2.0), Vec3::new(-1.0, 1.0, 2.0)];
        for k in -20..=20 {
            let s = k as f32 * 0.037;
            let ray = make_ray(Vec3::ZERO, Vec3::new(s, s, 2.0));
            let a = intersect_triangle(p[0], p[1], p[2], &ray, crate::arith::FAR);
            let b = intersect_triangle(q[0], q[1], q[2], &ray, crate::arith::FAR);
            assert!(a.ok || b.ok, "crack at s = {s}");
        }
        // Parallel ray: a finite miss.
        let ray = make_ray(Vec3::new(0.0, 0.0, 2.0), Vec3::X);
        assert!(!intersect_triangle(p[0], p[1], p[2], &ray, crate::arith::FAR).ok);
    }

    /// The hit points behind the spawn offset lie on their surface to a few ulps of the
    /// primitive's magnitude (about 1 here), even when the ray came from 1e4 away: a point
    /// `o + t·d` would be off by ulps of 1e4.
    #[test]
    fn surface_points_are_on_the_surface_however_far_the_ray_came() {
        let far = crate::arith::FAR;
        let (c, r) = (Vec3::new(0.3, -0.2, 0.1), 0.7);
        let sphere = Prim32::Sphere { c, r, inside_only: false };
        let (base, apex) = ([0.1, 0.2, -0.5, 0.4], [0.3, -0.1, 0.6, 0.2]);
        let cone = Prim32::Cylinder { base, apex, inside_only: false };
        let (b3, a3) = (Vec3::new(0.1, 0.2, -0.5), Vec3::new(0.3, -0.1, 0.6));
        let axis = (a3 - b3).normalize();
        let height = (a3 - b3).length();
        let (mut worst, mut hits) = ([0.0f32; 2], [0; 2]);
        for k in 0..200 {
            let f = k as f32 * 0.0137;
            let o = Vec3::new(1e4 * f.cos(), 1e4 * f.sin(), 3e3 * (f * 3.0).sin());
            for (i, prim) in [sphere, cone].iter().enumerate() {
                let aim =
                    if i == 0 { c } else { (a3 + b3) * 0.5 } + Vec3::new(0.1 * f.sin(), 0.05, -0.1 * f.cos());
                let ray = make_ray(o, aim - o);
                let h = prim.intersect(&ray, far);
                if !h.ok {
                    continue;
                }
                hits[i] += 1;
                let s = surface(prim, &ray, &h);
                assert!(s.scale < 2.0, "the scale {} is the ray's, not the primitive's", s.scale);
                let off = if i == 0 {
                    ((s.p - c).length() - r).abs()
                } else {
                    let w = s.p - b3;
                    let along = w.dot(axis);
                    let radius = base[3] + (apex[3] - base[3]) * along / height;
                    ((w - axis * along).length() - radius).abs()
                };
                worst[i] = worst[i].max(off / s.scale / f32::EPSILON);
            }
        }
        assert!(hits[0] > 150 && hits[1] > 150, "too few hits: {hits:?}");
        assert!(worst[0] < 4.0 && worst[1] < 4.0, "points off their surface by {worst:?} ulps of scale");
        eprintln!("points off their surface by at most {worst:?} ulps of scale ({hits:?} hits)");
    }

    #[test]
    fn cylinder_and_cone() {
        let far = crate::arith::FAR;
        let (base, apex) = ([0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]);
        let t = intersect_cylinder(base, apex, false, &make_ray(Vec3::new(-5.0, 0.0, 0.5), Vec3::X), far);
        assert!((t.t - 4.0).abs() < 1e-5);
        // Beyond the apex: miss (no caps).
        assert!(
            !intersect_cylinder(base, apex, false, &make_ray(Vec3::new(-5.0, 0.0, 1.5), Vec3::X), far).ok
        );
        // Inside, looking out.
        let t = intersect_cylinder(base, apex, false, &make_ray(Vec3::new(0.0, 0.0, 0.5), Vec3::Y), far);
        assert!((t.t - 1.0).abs() < 1e-5);
        // Cone from radius 1 to 0.5 over height 1: at z = 0.5 the radius is 0.75.
        let cone = [0.0, 0.0, 1.0, 0.5];
        let t = intersect_cylinder(base, cone, false, &make_ray(Vec3::new(-5.0, 0.0, 0.5), Vec3::X), far);
        assert!((t.t - 4.25).abs() < 1e-5);
        // Along the axis inside the cylinder: never meets the wall.
        assert!(!intersect_cylinder(base, apex, false, &make_ray(Vec3::new(0.0, 0.0, 0.5), Vec3::Z), far).ok);
    }
}
