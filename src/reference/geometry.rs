//! Rays, primitive intersection in f64 and the surface data at a hit, with the robust
//! spawn offset for secondary rays.
//!
//! - Spheres: the precise form of Haines, Günther and Akenine-Möller (*Ray Tracing Gems*
//!   ch. 7), with the discriminant computed as `r² − |f + b·d|²`.
//! - Triangles: the watertight test of Woop, Benthin and Wald (JCGT 2013), with a zero
//!   edge function accepted on both sides of an edge (no cracks).
//! - Cylinders and cones: the quadric without end caps, its discriminant rewritten as a
//!   difference of squared lengths so that grazing rays keep their accuracy. A cone may
//!   end in a point (radius 0).
//!
//! Hits are accepted for `0 < t < t_max`: there is no scene-wide epsilon. Instead a
//! secondary ray starts from the hit point moved off the surface along the geometric
//! normal by [`spawn_offset`], which scales with the magnitude of the numbers that
//! produced the hit point.
//!
//! `inside_only` spheres and cylinders (NFF negative radii) are hit only where the ray
//! leaves the solid (travels along the outward normal), so only their inside shows.

use glam::{DVec2, DVec3};

use crate::scene::{Cylinder, Primitive, Sphere, Triangle};

/// A ray with a unit direction and the per-ray constants of the watertight triangle test.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: DVec3,
    /// Unit length: hit distances `t` are Euclidean.
    pub dir: DVec3,
    kx: usize,
    ky: usize,
    kz: usize,
    shear: DVec3,
}

impl Ray {
    /// A ray from `origin` along `dir` (normalised here).
    pub fn new(origin: DVec3, dir: DVec3) -> Ray {
        let dir = dir.normalize();
        let a = dir.abs();
        // The axis where the direction is largest becomes z of the shear frame.
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let shear = DVec3::new(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
        Ray { origin, dir, kx, ky, kz, shear }
    }

    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}

/// Where a ray met a primitive: distance, for triangles the barycentric weights of vertices
/// 1 and 2, and `err`, a bound on the rounding error of `t` (for the tie rule,
/// [`crate::arith::closest`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Intersection {
    pub t: f64,
    pub b1: f64,
    pub b2: f64,
    pub err: f64,
}

impl Intersection {
    fn at(t: f64, err: f64) -> Intersection {
        Intersection { t, b1: 0.0, b2: 0.0, err }
    }
}

/// The unit roundoff of f64, `2⁻⁵³`.
const UNIT_ROUNDOFF: f64 = 1.0 / 9007199254740992.0;
/// The widest a hit's error bound may be, relative to the magnitude of its numbers, as on
/// the GPU (`arith::geometry::TIE_CAP`).
const TIE_CAP: f64 = 1.0 / 1024.0;

/// `γ(n) = n·u / (1 − n·u)` in f64.
fn gamma(n: f64) -> f64 {
    let nu = n * UNIT_ROUNDOFF;
    nu / (1.0 - nu)
}

/// A hit's error bound from its arithmetic's `dt`: capped at [`TIE_CAP`] of `t + scale`, and
/// widened by the rounding of `t` itself.
fn hit_err(t: f64, dt: f64, scale: f64) -> f64 {
    dt.min(TIE_CAP * (t + scale)) * (1.0 + 1e-9) + t * (2.0 * UNIT_ROUNDOFF)
}

/// The error of `√disc` when `disc` carries at most `dd`: `dd / (2·√disc)`, or `√dd` where
/// that is smaller (a discriminant near zero).
fn sqrt_err(dd: f64, sd: f64) -> f64 {
    if sd > 0.0 {
        dd.sqrt().min(dd / (2.0 * sd))
    } else {
        dd.sqrt()
    }
}

/// Intersects `ray` with `prim` for `0 < t < t_max`; the nearest such hit.
pub fn intersect(prim: &Primitive, ray: &Ray, t_max: f64) -> Option<Intersection> {
    match prim {
        Primitive::Sphere(s) => intersect_sphere(s, ray, t_max),
        Primitive::Triangle(t) => intersect_triangle(t, ray, t_max),
        Primitive::Cylinder(c) => intersect_cylinder(c, ray, t_max),
    }
}

/// Ray/sphere, Haines' precise form.
pub fn intersect_sphere(s: &Sphere, ray: &Ray, t_max: f64) -> Option<Intersection> {
    let f = ray.origin - s.center;
    let b = -f.dot(ray.dir);
    let r2 = s.radius * s.radius;
    // The discriminant as the squared distance from the centre to the line, subtracted
    // from r²: no cancellation between two large numbers.
    let disc = r2 - (f + ray.dir * b).length_squared();
    if disc < 0.0 {
        return None;
    }
    let k = f.length_squared() - r2;
    let q = b + if b >= 0.0 { disc.sqrt() } else { -disc.sqrt() };
    if q == 0.0 {
        // Tangent line through the origin: b = 0 and disc = 0.
        return None;
    }
    let (t0, t1) = {
        let (a, c) = (k / q, q);
        if a <= c {
            (a, c)
        } else {
            (c, a)
        }
    };
    // The near root enters the solid, the far root leaves it.
    let t = if !s.inside_only && t0 > 0.0 && t0 < t_max {
        t0
    } else if t1 > 0.0 && t1 < t_max {
        t1
    } else {
        return None;
    };
    // The error bound of the root (as `arith::geometry::sphere_err` bounds the f32 test's):
    // b carries a few roundings of |f|, the discriminant a few of r² and r·|f|, its square
    // root that over 2√disc, k = |f|² − r² a few of |f|² and r².
    let (fl, r) = (f.length(), s.radius);
    let dd = gamma(8.0) * (r2 + 4.0 * r * fl);
    let dq = gamma(4.0) * fl + sqrt_err(dd, disc.sqrt()) + gamma(1.0) * q.abs();
    let dt = if t == q { dq } else { (gamma(4.0) * (fl * fl + r2) + t.abs() * dq) / q.abs() };
    Some(Intersection::at(t, hit_err(t, dt + gamma(2.0) * t, fl + r)))
}

/// Ray/triangle, Woop, Benthin and Wald's watertight test; both sides are hit.
pub fn intersect_triangle(tri: &Triangle, ray: &Ray, t_max: f64) -> Option<Intersection> {
    let (kx, ky, kz, s) = (ray.kx, ray.ky, ray.kz, ray.shear);
    // Vertices relative to the ray origin, sheared so that the ray runs along +z.
    let a = tri.p[0] - ray.origin;
    let b = tri.p[1] - ray.origin;
    let c = tri.p[2] - ray.origin;
    let ax = a[kx] - s.x * a[kz];
    let ay = a[ky] - s.y * a[kz];
    let bx = b[kx] - s.x * b[kz];
    let by = b[ky] - s.y * b[kz];
    let cx = c[kx] - s.x * c[kz];
    let cy = c[ky] - s.y * c[kz];
    // Scaled barycentrics: the 2-D edge functions.
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    // Scaled hit distance, compared with the interval before dividing.
    let t_scaled = s.z * (u * a[kz] + v * b[kz] + w * c[kz]);
    if det > 0.0 {
        if t_scaled <= 0.0 || t_scaled >= t_max * det {
            return None;
        }
    } else if t_scaled >= 0.0 || t_scaled <= t_max * det {
        return None;
    }
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t > 0.0 && t < t_max) {
        return None;
    }
    // The bound of pbrt-v4 on this test's variables: the sheared coordinates carry a few
    // roundings, the edge functions their products, t their weighted mean over det.
    let max3 = |x: f64, y: f64, z: f64| x.abs().max(y.abs()).max(z.abs());
    let max_z = max3(a[kz], b[kz], c[kz]);
    let max_zt = s.z.abs() * max_z;
    let (max_xt, max_yt) = (max3(ax, bx, cx), max3(ay, by, cy));
    let dx = gamma(5.0) * (max_xt + max_z);
    let dy = gamma(5.0) * (max_yt + max_z);
    let dz = gamma(4.0) * max_zt;
    let de = 2.0 * (gamma(2.0) * max_xt * max_yt + dy * max_xt + dx * max_yt);
    let max_e = max3(u, v, w);
    let dt = 3.0 * (gamma(3.0) * max_e * max_zt + de * max_zt + dz * max_e) * inv.abs();
    let scale = a.abs().max_element().max(b.abs().max_element()).max(c.abs().max_element());
    Some(Intersection { t, b1: v * inv, b2: w * inv, err: hit_err(t, dt, scale) })
}

/// The local frame of a cylinder or cone: unit axis, length and the slope of the radius.
struct ConeFrame {
    axis: DVec3,
    height: f64,
    /// d(radius)/d(height).
    slope: f64,
}

fn cone_frame(c: &Cylinder) -> ConeFrame {
    let v = c.apex - c.base;
    let height = v.length();
    ConeFrame { axis: v / height, height, slope: (c.apex_radius - c.base_radius) / height }
}

/// Ray/cylinder or truncated cone without end caps; both sides are hit unless
/// `inside_only`.
pub fn intersect_cylinder(c: &Cylinder, ray: &Ray, t_max: f64) -> Option<Intersection> {
    let ConeFrame { axis, height, slope } = cone_frame(c);
    // Height along the axis and the radial part, at the origin (s0, r_o) and per unit t.
    let w = ray.origin - c.base;
    let s0 = w.dot(axis);
    let ds = ray.dir.dot(axis);
    let r_o = w - axis * s0;
    let r_d = ray.dir - axis * ds;
    // The radius the surface has at the origin's height, and its rate along the ray.
    let r0 = c.base_radius + slope * s0;
    let dr = slope * ds;
    // |r_o + t·r_d|² = (r0 + t·dr)²  ⇔  A t² + 2 B t + C = 0.
    let qa = r_d.length_squared() - dr * dr;
    let qb = r_o.dot(r_d) - r0 * dr;
    let qc = r_o.length_squared() - r0 * r0;
    // B² − A·C = |r0·r_d − dr·r_o|² − |r_o × r_d|², without cancellation of large terms.
    let disc = (r_d * r0 - r_o * dr).length_squared() - r_o.cross(r_d).length_squared();
    if disc < 0.0 {
        return None;
    }
    let q = -(qb + if qb >= 0.0 { disc.sqrt() } else { -disc.sqrt() });
    if q == 0.0 {
        return None;
    }
    let t_cq = qc / q;
    let mut roots = [t_cq, if qa != 0.0 { q / qa } else { f64::NAN }];
    if roots[1] < roots[0] {
        roots.swap(0, 1);
    }
    for t in roots {
        if !(t > 0.0 && t < t_max) {
            continue;
        }
        let s = s0 + t * ds;
        if !(0.0..=height).contains(&s) {
            continue;
        }
        if c.inside_only {
            let n = cone_normal(axis, slope, r_o + r_d * t);
            if n.dot(ray.dir) <= 0.0 {
                continue;
            }
        }
        // The error bound of the root (as `arith::geometry::cylinder_err` bounds the f32
        // test's): the radial parts carry a few roundings of |w| and of 1, the radius at the
        // origin's height a few of its terms, and the coefficients, the discriminant and its
        // square root what those make of them.
        let (lw, lro, lrd) = (w.length(), r_o.length(), r_d.length());
        let (ar0, adr, aslope) = (r0.abs(), dr.abs(), slope.abs());
        let ew = gamma(6.0) * lw;
        let er0 = gamma(3.0) * c.base_radius.abs() + gamma(4.0) * aslope * lw;
        let (erd, edr) = (gamma(4.0), gamma(4.0) * aslope);
        let qc_err = 2.0 * lro * ew + 2.0 * ar0 * er0 + gamma(3.0) * (lro * lro + ar0 * ar0);
        let qb_err = lrd * ew + lro * erd + adr * er0 + ar0 * edr + gamma(3.0) * (lro * lrd + ar0 * adr);
        let qa_err = 2.0 * lrd * erd + 2.0 * adr * edr + gamma(3.0) * (lrd * lrd + adr * adr);
        let e = lrd * ar0 + lro * adr;
        let e_err = lrd * er0 + ar0 * erd + lro * edr + adr * ew + gamma(3.0) * e;
        let x = lro * lrd;
        let x_err = lrd * ew + lro * erd + gamma(3.0) * x;
        let dd = 2.0 * e * e_err + 2.0 * x * x_err + gamma(3.0) * (e * e + x * x);
        let dq = qb_err + sqrt_err(dd, disc.sqrt()) + gamma(1.0) * q.abs();
        let dt =
            if t == t_cq { (qc_err + t.abs() * dq) / q.abs() } else { (dq + t.abs() * qa_err) / qa.abs() };
        let scale = w.length() + height + c.base_radius.abs().max(c.apex_radius.abs());
        return Some(Intersection::at(t, hit_err(t, dt + gamma(2.0) * t, scale)));
    }
    None
}

/// Outward unit normal of a cone with unit `axis` and radius slope `slope`, given the
/// radial offset of the surface point from the axis.
/// At the tip of a cone ending in a point the radial direction is undefined: any
/// direction perpendicular to the axis serves.
fn cone_normal(axis: DVec3, slope: f64, radial: DVec3) -> DVec3 {
    let len = radial.length();
    let radial_dir = if len > 0.0 { radial / len } else { axis.any_orthonormal_vector() };
    (radial_dir - axis * slope).normalize()
}

/// The surface at a hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// The hit point (triangles: from the barycentrics, not from o + t·d).
    pub p: DVec3,
    /// Unit geometric normal, "outward": sphere and cylinder away from the axis or centre,
    /// triangle along `(p1 − p0) × (p2 − p0)`. Not flipped toward the ray.
    pub ng: DVec3,
    /// Unit shading normal on the same side as `ng` (interpolated for triangles with
    /// vertex normals, else `ng`).
    pub ns: DVec3,
    /// Texture coordinates, sets 0 and 1, where the triangle carries them.
    pub uv: [Option<DVec2>; 2],
    /// The tangent frame of a triangle with tangents: the interpolated unit vertex normal
    /// (not turned to `ng`'s side), the unit tangent made orthogonal to it, and the
    /// bitangent's sign.
    pub frame: Option<TangentFrame>,
    /// The vertex colour, interpolated (white where the primitive has none).
    pub color: DVec3,
    /// Size of the numbers that produced `p`, for the spawn offset.
    pub scale: f64,
}

/// A normal map's frame at a point: `b = sign·(n × t)`.
#[derive(Clone, Copy, Debug)]
pub struct TangentFrame {
    pub n: DVec3,
    pub t: DVec3,
    pub sign: f64,
}

/// The surface data of a hit found by [`intersect`].
pub fn surface(prim: &Primitive, ray: &Ray, hit: &Intersection) -> SurfacePoint {
    let scale_of = |p: DVec3| p.abs().max_element().max(ray.origin.abs().max_element()) + hit.t;
    match prim {
        Primitive::Sphere(s) => {
            let p = ray.at(hit.t);
            let ng = (p - s.center).normalize();
            let scale = scale_of(p).max(s.center.abs().max_element() + s.radius);
            SurfacePoint { p, ng, ns: ng, uv: [None; 2], frame: None, color: DVec3::ONE, scale }
        }
        Primitive::Cylinder(c) => {
            let p = ray.at(hit.t);
            let f = cone_frame(c);
            let v = p - c.base;
            let radial = v - f.axis * v.dot(f.axis);
            let ng = cone_normal(f.axis, f.slope, radial);
            let extent = c.base.abs().max_element().max(c.apex.abs().max_element());
            let scale = scale_of(p).max(extent);
            SurfacePoint { p, ng, ns: ng, uv: [None; 2], frame: None, color: DVec3::ONE, scale }
        }
        Primitive::Triangle(t) => {
            let b0 = 1.0 - hit.b1 - hit.b2;
            let p = t.p[0] * b0 + t.p[1] * hit.b1 + t.p[2] * hit.b2;
            let ng = t.cross().normalize();
            // The interpolated vertex normal, unit, on its own side.
            let n = t.n.as_ref().and_then(|n| {
                let s = n[0] * b0 + n[1] * hit.b1 + n[2] * hit.b2;
                let len = s.length();
                (len > 1e-12).then(|| s / len)
            });
            // Keep the shading normal on the geometric normal's side.
            let ns = n.map_or(ng, |n| if n.dot(ng) < 0.0 { -n } else { n });
            let frame = t.tangent.as_deref().and_then(|tg| {
                let n = n.unwrap_or(ng);
                let v = (tg[0] * b0 + tg[1] * hit.b1 + tg[2] * hit.b2).truncate();
                let v = v - n * n.dot(v);
                let len = v.length();
                (len > 1e-12).then(|| TangentFrame { n, t: v / len, sign: tg[0].w })
            });
            let uv = t.uvs_at(hit.b1, hit.b2);
            let color = t.color.as_ref().map_or(DVec3::ONE, |c| c[0] * b0 + c[1] * hit.b1 + c[2] * hit.b2);
            let extent = t.p.iter().map(|q| q.abs().max_element()).fold(0.0, f64::max);
            SurfacePoint { p, ng, ns, uv, frame, color, scale: scale_of(p).max(extent) }
        }
    }
}

/// Relative size of the spawn offset: 2⁻³² of the magnitude of the numbers behind the hit
/// point, about a million times the f64 rounding error of that point and far below
/// anything visible.
pub const SPAWN_OFFSET_REL: f64 = 1.0 / 4_294_967_296.0;

/// The distance a secondary ray's origin is moved off the surface.
pub fn spawn_offset(s: &SurfacePoint) -> f64 {
    s.scale * SPAWN_OFFSET_REL
}

/// The origin of a ray leaving surface `s` in direction `dir`: the hit point moved along
/// the geometric normal, to the side `dir` goes to.
pub fn spawn_origin(s: &SurfacePoint, dir: DVec3) -> DVec3 {
    let side = if dir.dot(s.ng) >= 0.0 { s.ng } else { -s.ng };
    s.p + side * spawn_offset(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(c: DVec3, r: f64, inside_only: bool) -> Sphere {
        Sphere { center: c, radius: r, inside_only, material: 0 }
    }

    #[test]
    fn sphere_hits_near_and_far() {
        let s = sphere(DVec3::ZERO, 1.0, false);
        let r = Ray::new(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z);
        assert_eq!(intersect_sphere(&s, &r, f64::INFINITY).map(|h| h.t), Some(4.0));
        // From inside: the far side.
        let r = Ray::new(DVec3::ZERO, DVec3::X);
        assert_eq!(intersect_sphere(&s, &r, f64::INFINITY).map(|h| h.t), Some(1.0));
        // Limited by t_max.
        let r = Ray::new(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z);
        assert_eq!(intersect_sphere(&s, &r, 3.9).map(|h| h.t), None);
        // Pointing away.
        let r = Ray::new(DVec3::new(0.0, 0.0, 5.0), DVec3::Z);
        assert_eq!(intersect_sphere(&s, &r, f64::INFINITY).map(|h| h.t), None);
    }

    #[test]
    fn inside_only_sphere_shows_only_its_inside() {
        let s = sphere(DVec3::ZERO, 1.0, true);
        let r = Ray::new(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z);
        assert_eq!(intersect_sphere(&s, &r, f64::INFINITY).map(|h| h.t), Some(6.0));
    }

    #[test]
    fn far_small_sphere_is_precise() {
        // r/distance = 1e-7: the naive b² − c form loses every digit here.
        let s = sphere(DVec3::new(0.0, 0.0, -1e7), 1.0, false);
        let r = Ray::new(DVec3::ZERO, DVec3::new(0.5e-7, 0.0, -1.0));
        let t = intersect_sphere(&s, &r, f64::INFINITY).map(|h| h.t).expect("hit");
        let p = r.at(t);
        assert!(((p - s.center).length() - 1.0).abs() < 1e-8, "{}", (p - s.center).length());
    }

    fn tri(p0: DVec3, p1: DVec3, p2: DVec3) -> Triangle {
        Triangle::new([p0, p1, p2], 0)
    }

    #[test]
    fn triangle_barycentrics_and_both_sides() {
        let t = tri(DVec3::ZERO, DVec3::X, DVec3::Y);
        let r = Ray::new(DVec3::new(0.25, 0.5, 1.0), DVec3::NEG_Z);
        let h = intersect_triangle(&t, &r, f64::INFINITY).unwrap();
        assert!((h.t - 1.0).abs() < 1e-15 && (h.b1 - 0.25).abs() < 1e-15 && (h.b2 - 0.5).abs() < 1e-15);
        let r = Ray::new(DVec3::new(0.25, 0.5, -1.0), DVec3::Z);
        assert!(intersect_triangle(&t, &r, f64::INFINITY).is_some());
        // Parallel to the plane: no hit and no NaN.
        let r = Ray::new(DVec3::new(0.25, 0.5, 0.0), DVec3::X);
        assert!(intersect_triangle(&t, &r, f64::INFINITY).is_none());
    }

    #[test]
    fn smooth_shading_interpolates_vertex_normals() {
        let n0 = DVec3::new(-1.0, 0.0, 1.0).normalize();
        let n1 = DVec3::new(1.0, 0.0, 1.0).normalize();
        let t = Triangle {
            // Stored pointing down: the shading normal is turned to the geometric side.
            n: Some([-n0, -n1, -DVec3::Z]),
            uv: Some([glam::DVec2::ZERO, glam::DVec2::X, glam::DVec2::Y]),
            ..Triangle::new([DVec3::ZERO, DVec3::X, DVec3::Y], 0)
        };
        let r = Ray::new(DVec3::new(0.5, 0.0, 1.0), DVec3::NEG_Z);
        let h = intersect_triangle(&t, &r, f64::INFINITY).unwrap();
        let s = surface(&Primitive::Triangle(t.clone()), &r, &h);
        assert!((s.ng - DVec3::Z).length() < 1e-15);
        assert!((s.ns - DVec3::Z).length() < 1e-12, "{}", s.ns);
        assert!((s.uv[0].unwrap() - glam::DVec2::new(0.5, 0.0)).length() < 1e-15);
        let r = Ray::new(DVec3::new(0.25, 0.0, 1.0), DVec3::NEG_Z);
        let h = intersect_triangle(&t, &r, f64::INFINITY).unwrap();
        let tri =
            Triangle { n: Some([n0, n1, DVec3::Z]), ..Triangle::new([DVec3::ZERO, DVec3::X, DVec3::Y], 0) };
        let s = surface(&Primitive::Triangle(tri), &r, &h);
        let want = (n0 * 0.75 + n1 * 0.25).normalize();
        assert!((s.ns - want).length() < 1e-12, "{}", s.ns);
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles of a quad; rays exactly through the diagonal must hit one of them.
        let a = tri(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0));
        let b = tri(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Y);
        for i in 1..100 {
            let x = i as f64 / 100.0;
            let r = Ray::new(DVec3::new(0.3, 0.2, 3.0), DVec3::new(x, x, 0.0) - DVec3::new(0.3, 0.2, 3.0));
            let ha = intersect_triangle(&a, &r, f64::INFINITY);
            let hb = intersect_triangle(&b, &r, f64::INFINITY);
            assert!(ha.is_some() || hb.is_some(), "crack at {x}");
        }
    }

    fn cyl(r0: f64, r1: f64, inside_only: bool) -> Cylinder {
        Cylinder {
            base: DVec3::ZERO,
            base_radius: r0,
            apex: DVec3::new(0.0, 0.0, 2.0),
            apex_radius: r1,
            inside_only,
            material: 0,
        }
    }

    #[test]
    fn cylinder_and_cone() {
        let c = cyl(1.0, 1.0, false);
        let r = Ray::new(DVec3::new(5.0, 0.0, 1.0), DVec3::NEG_X);
        assert!((intersect_cylinder(&c, &r, f64::INFINITY).map(|h| h.t).unwrap() - 4.0).abs() < 1e-12);
        // No caps: along the axis misses.
        let r = Ray::new(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z);
        assert_eq!(intersect_cylinder(&c, &r, f64::INFINITY).map(|h| h.t), None);
        // Above the top: misses.
        let r = Ray::new(DVec3::new(5.0, 0.0, 2.5), DVec3::NEG_X);
        assert_eq!(intersect_cylinder(&c, &r, f64::INFINITY).map(|h| h.t), None);
        // Inside only: the far wall.
        let ci = cyl(1.0, 1.0, true);
        let r = Ray::new(DVec3::new(5.0, 0.0, 1.0), DVec3::NEG_X);
        assert!((intersect_cylinder(&ci, &r, f64::INFINITY).map(|h| h.t).unwrap() - 6.0).abs() < 1e-12);
        // A cone from radius 1 to 0.5: at height 1 the radius is 0.75.
        let k = cyl(1.0, 0.5, false);
        let t = intersect_cylinder(&k, &r, f64::INFINITY).map(|h| h.t).unwrap();
        assert!((t - 4.25).abs() < 1e-12, "{t}");
        let h = Intersection::at(t, 0.0);
        let s = surface(&Primitive::Cylinder(k), &r, &h);
        // Normal leans up (towards the apex) as the cone narrows.
        let expect = DVec3::new(1.0, 0.0, 0.25).normalize();
        assert!((s.ng - expect).length() < 1e-12, "{}", s.ng);
    }

    #[test]
    fn spawned_rays_do_not_self_intersect() {
        let s = sphere(DVec3::new(1e4, -3e4, 2e4), 3.0, false);
        let prim = Primitive::Sphere(s.clone());
        let eye = DVec3::new(1e4 + 100.0, -3e4 + 1.0, 2e4 + 2.0);
        for i in 0..200 {
            let a = i as f64 * 0.013;
            let dir = (s.center + DVec3::new(a.cos(), a.sin(), 0.3) * 2.8 - eye).normalize();
            let r = Ray::new(eye, dir);
            let h = intersect(&prim, &r, f64::INFINITY).unwrap();
            let surf = surface(&prim, &r, &h);
            let refl = dir - surf.ng * 2.0 * dir.dot(surf.ng);
            let r2 = Ray::new(spawn_origin(&surf, refl), refl);
            assert!(intersect(&prim, &r2, f64::INFINITY).is_none());
            // Into the sphere: the far side, not the entry point again.
            let r3 = Ray::new(spawn_origin(&surf, dir), dir);
            assert!(intersect(&prim, &r3, f64::INFINITY).unwrap().t > 1e-3);
        }
    }
}
