// Primitive intersection in f32: the sphere, triangle and cylinder tests, each with a bound
// on the rounding error of its hit's distance, which the tie rule (closest.wgsl) reads. Keep
// in sync with their Rust twins of the same names in src/arith/geometry.rs. Positions and the
// intersection arithmetic are `real` (layout.wgsl): f32, or f64 in the F64 variant
// (`--precision f64`); directions, distances and their error bounds are f32.

// A hit: `ok` says whether there is one; then t, the barycentrics of vertices 1, 2, and
// `err`, a bound on the rounding error of t (the tie rule's: closest.wgsl).
struct PrimHit {
    ok: bool,
    t: f32,
    b1: f32,
    b2: f32,
    err: f32,
}

fn no_hit() -> PrimHit {
    return PrimHit(false, 0.0, 0.0, 0.0, 0.0);
}

fn hit_at(t: f32, err: f32) -> PrimHit {
    return PrimHit(true, t, 0.0, 0.0, err);
}

// The unit roundoff of `real` (2⁻²⁴, or 2⁻⁵³ in the F64 variant).
fn unit_roundoff() -> real {
#if F64
    return real(1.0) / real(9007199254740992.0);
#else
    return real(1.0) / real(16777216.0);
#endif
}

// The widest a hit's error bound may be, relative to the magnitude of its numbers (t and the
// primitive's size from the ray origin): 2⁻¹⁰. Twin: arith::geometry::TIE_CAP.
const TIE_CAP: f32 = 0.0009765625;

// γ(n) = n·u / (1 − n·u): the relative error bound of n rounded operations.
fn gamma(n: real) -> real {
    let nu = n * unit_roundoff();
    return nu / (1.0 - nu);
}

// The error bound handed to the tie rule for a hit at t whose arithmetic bounds `dt`, on
// numbers of magnitude `scale` from the ray origin: capped at TIE_CAP, rounded up, and
// widened by an ulp of t for t's own rounding to f32.
fn hit_err(t: f32, dt: real, scale: real) -> f32 {
    let capped = f32(min(dt, real(TIE_CAP) * (real(t) + scale)));
    return capped * (1.0 + 1.0 / 1048576.0) + t * (2.0 / 16777216.0);
}

// The error of sd = √disc when disc carries at most `dd`: dd / (2·sd), or √dd where that is
// smaller (a discriminant near zero).
fn sqrt_err(dd: real, sd: real) -> real {
    let near_zero = sqrt(dd);
    if sd > 0.0 {
        return min(near_zero, dd / (2.0 * sd));
    }
    return near_zero;
}

#if SPHERES
// The error bound of a root t of Haines' sphere test (q, or k/q; fl = |f|): b carries a few
// roundings of |f|, the discriminant r² − |g|² a few of r² and r·|f| (|g| ≤ r), its square
// root that error over 2√disc, and k = |f|² − r² a few of |f|² and r². Twin:
// arith::geometry::sphere_err.
fn sphere_err(t: real, q: real, fl: real, radius: real, disc: real) -> f32 {
    let db = gamma(4.0) * fl;
    let dd = gamma(8.0) * (radius * radius + 4.0 * radius * fl);
    let dq = db + sqrt_err(dd, sqrt(disc)) + gamma(1.0) * abs(q);
    var dt = dq;
    if t != q {
        let dk = gamma(4.0) * (fl * fl + radius * radius);
        dt = (dk + abs(t) * dq) / abs(q);
    }
    return hit_err(f32(t), dt + gamma(2.0) * t, fl + radius);
}
#endif

#if CYLINDERS
// The error bound of a root t of the cylinder test (qc/q when `by_q`, else q/qa): the radial
// parts carry a few roundings of |w| (r_o, s0) and of 1 (r_d), the radius at the origin's
// height a few of its terms, and each coefficient, the discriminant and its square root
// what those errors make of them. Twin: arith::geometry::cylinder_err.
fn cylinder_err(t: real, by_q: bool, lw: real, lro: real, lrd: real, r0_in: real, dr_in: real, slope_in: real,
    base_r: real, qa: real, q: real, disc: real, scale: real) -> f32 {
    let r0 = abs(r0_in);
    let dr = abs(dr_in);
    let slope = abs(slope_in);
    let ew = gamma(6.0) * lw;
    let er0 = gamma(3.0) * abs(base_r) + gamma(4.0) * slope * lw;
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
    let dq = qb_err + sqrt_err(dd, sqrt(disc)) + gamma(1.0) * abs(q);
    var dt: real;
    if by_q {
        dt = (qc_err + abs(t) * dq) / abs(q);
    } else {
        dt = (dq + abs(t) * qa_err) / abs(qa);
    }
    return hit_err(f32(t), dt + gamma(2.0) * t, scale);
}
#endif

#if SPHERES
// Ray/sphere, Haines' precise form: the discriminant as r² − |f + b·d|².
fn intersect_sphere(center: vec3r, radius: real, inside_only: bool, ray: Ray, t_max: f32) -> PrimHit {
    let d = vec3r(ray.d);
    let f = ray.o - center;
    let b = -dot(f, d);
    let r2 = radius * radius;
    let g = f + d * b;
    let disc = r2 - dot(g, g);
    if disc < 0.0 {
        return no_hit();
    }
    let k = dot(f, f) - r2;
    let q = b + select(-sqrt(disc), sqrt(disc), b >= 0.0);
    if q == 0.0 {
        return no_hit();
    }
    let r0 = k / q;
    let t0 = min(r0, q);
    let t1 = max(r0, q);
    var t: real;
    if !inside_only && t0 > 0.0 && t0 < real(t_max) {
        t = t0;
    } else if t1 > 0.0 && t1 < real(t_max) {
        t = t1;
    } else {
        return no_hit();
    }
    return hit_at(f32(t), sphere_err(t, q, length(f), radius, disc));
}
#endif

#if TRIANGLES
// Ray/triangle, watertight; both sides are hit.
fn intersect_triangle(p0: vec3r, p1: vec3r, p2: vec3r, ray: Ray, t_max: f32) -> PrimHit {
#if F64
    let dr = vec3r(ray.d);
    let s = vec3r(dr[ray.kx] / dr[ray.kz], dr[ray.ky] / dr[ray.kz], 1.0 / dr[ray.kz]);
#else
    let s = ray.shear;
#endif
    let o = ray.o;
    let a = p0 - o;
    let b = p1 - o;
    let c = p2 - o;
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
    let tm = real(t_max);
    if det > 0.0 {
        if t_scaled <= 0.0 || t_scaled >= tm * det {
            return no_hit();
        }
    } else if t_scaled >= 0.0 || t_scaled <= tm * det {
        return no_hit();
    }
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t > 0.0 && t < tm) {
        return no_hit();
    }
    // The bound of pbrt-v4 on this test's variables: the sheared coordinates carry a few
    // roundings, the edge functions their products, t their weighted mean over det.
    let max_z = max(abs(a[ray.kz]), max(abs(b[ray.kz]), abs(c[ray.kz])));
    let max_zt = abs(s.z) * max_z;
    let max_xt = max(abs(ax), max(abs(bx), abs(cx)));
    let max_yt = max(abs(ay), max(abs(by), abs(cy)));
    let dx = gamma(5.0) * (max_xt + max_z);
    let dy = gamma(5.0) * (max_yt + max_z);
    let dz = gamma(4.0) * max_zt;
    let de = 2.0 * (gamma(2.0) * max_xt * max_yt + dy * max_xt + dx * max_yt);
    let max_e = max(abs(u), max(abs(v), abs(w)));
    let dt = 3.0 * (gamma(3.0) * max_e * max_zt + de * max_zt + dz * max_e) * abs(inv);
    let scale = max(max(abs(a.x), max(abs(a.y), abs(a.z))), max(max(abs(b.x), max(abs(b.y), abs(b.z))),
        max(abs(c.x), max(abs(c.y), abs(c.z)))));
    let tf = f32(t);
    return PrimHit(true, tf, f32(v * inv), f32(w * inv), hit_err(tf, dt, scale));
}
#endif

#if CYLINDERS
// Outward unit normal of a cone; at a cone's tip any direction across the axis serves.
fn cone_normal(axis: vec3r, slope: real, radial: vec3r) -> vec3r {
    let len = length(radial);
    var radial_dir: vec3r;
    if len > 0.0 {
        radial_dir = radial / len;
    } else {
        radial_dir = any_orthonormal(axis);
    }
    return normalize(radial_dir - axis * slope);
}

// A unit vector orthogonal to unit `v` (the same construction as glam's).
fn any_orthonormal(v: vec3r) -> vec3r {
    let sign = select(real(-1.0), real(1.0), v.z >= 0.0);
    let a = -1.0 / (sign + v.z);
    let b = v.x * v.y * a;
    return vec3r(b, sign + v.y * v.y * a, -v.y);
}

// Ray/cylinder or truncated cone without caps; the discriminant as a difference of
// squared lengths.
fn intersect_cylinder(base: vec4r, apex: vec4r, inside_only: bool, ray: Ray, t_max: f32) -> PrimHit {
    let d = vec3r(ray.d);
    let v = apex.xyz - base.xyz;
    let height = length(v);
    let axis = v / height;
    let slope = (apex.w - base.w) / height;
    let w = ray.o - base.xyz;
    let s0 = dot(w, axis);
    let ds = dot(d, axis);
    let r_o = w - axis * s0;
    let r_d = d - axis * ds;
    let r0 = base.w + slope * s0;
    let dr = slope * ds;
    let qa = dot(r_d, r_d) - dr * dr;
    let qb = dot(r_o, r_d) - r0 * dr;
    let qc = dot(r_o, r_o) - r0 * r0;
    let e = r_d * r0 - r_o * dr;
    let x = cross(r_o, r_d);
    let disc = dot(e, e) - dot(x, x);
    if disc < 0.0 {
        return no_hit();
    }
    let q = -(qb + select(-sqrt(disc), sqrt(disc), qb >= 0.0));
    if q == 0.0 {
        return no_hit();
    }
    let t_cq = qc / q;
    var roots = array<real, 2>(t_cq, 0.0);
    var n_roots = 1u;
    if qa != 0.0 {
        let other = q / qa;
        if other < roots[0] {
            roots[1] = roots[0];
            roots[0] = other;
        } else {
            roots[1] = other;
        }
        n_roots = 2u;
    }
    for (var i = 0u; i < n_roots; i++) {
        let t = roots[i];
        if !(t > 0.0 && t < real(t_max)) {
            continue;
        }
        let s = s0 + t * ds;
        if !(s >= 0.0 && s <= height) {
            continue;
        }
        if inside_only {
            let n = cone_normal(axis, slope, r_o + r_d * t);
            if dot(n, d) <= 0.0 {
                continue;
            }
        }
        let scale = length(w) + height + max(abs(base.w), abs(apex.w));
        let err = cylinder_err(t, t == t_cq, length(w), length(r_o), length(r_d), r0, dr, slope, base.w, qa, q,
            disc, scale);
        return hit_at(f32(t), err);
    }
    return no_hit();
}
#endif

// The test of `p`'s kind; the module holds the kinds of its scene only (SPHERES,
// TRIANGLES, CYLINDERS), and a kind it lacks never occurs.
fn intersect_prim(p: Prim, ray: Ray, t_max: f32) -> PrimHit {
    let inside_only = (p.flags & FLAG_INSIDE_ONLY) != 0u;
    switch p.kind {
#if SPHERES
        case KIND_SPHERE: {
            return intersect_sphere(p.a.xyz, p.a.w, inside_only, ray, t_max);
        }
#endif
#if CYLINDERS
        case KIND_CYLINDER: {
            return intersect_cylinder(p.a, p.b, inside_only, ray, t_max);
        }
#endif
        default: {
#if TRIANGLES
            return intersect_triangle(p.a.xyz, p.b.xyz, p.c.xyz, ray, t_max);
#else
            return no_hit();
#endif
        }
    }
}
