//! Rust twins of the WGSL functions, in f32, named as the WGSL functions are.
//!
//! Every function here is written so that the WGSL can mirror it line by line: no recursion,
//! no allocation, no NaN or infinity as a sentinel (a miss is [`F32_MAX`], i.e.
//! `0x1.fffffep+127f`), only operations WGSL has (`select` is written as `if`). They are used
//! by the tests, by the CPU table walker's self-checks and by the GPU issue to find whether a
//! GPU difference comes from the tables or from the kernels.
//!
//! | Rust | WGSL |
//! |---|---|
//! | [`cube_face_cell`] | `fn cube_face_cell(d: vec3<f32>, n: u32) -> vec3<u32>` |
//! | [`cube_cell_range`] | `fn cube_cell_range(origin: u32, d: vec3<f32>) -> vec2<u32>` |
//! | [`ray_sphere`] | `fn ray_sphere(o: vec3<f32>, d: vec3<f32>, c: vec3<f32>, r: f32) -> f32` |
//! | [`ray_triangle`] | `fn ray_triangle(o, d, p0, p1, p2) -> f32` |
//! | [`ray_cylinder`] | `fn ray_cylinder(o, d, base, r0, apex, r1) -> f32` |
//! | [`offset_ray_origin`] | `fn offset_ray_origin(p: vec3<f32>, ng: vec3<f32>, dir: vec3<f32>) -> vec3<f32>` |
//! | [`triangle_patch`] | `fn triangle_patch(p0, p1, p2, m: u32, at: vec3<f32>) -> u32` |
//! | [`cube_walk_nearest`] | `fn cube_walk_nearest(origin: u32, ray: Ray, t_max: f32, skip: u32, ray_kind: u32) -> Closest` |
//! | [`cube_walk_any`] | `fn cube_walk_any(origin: u32, ray: Ray, t_max: f32, skip: u32) -> bool` |
//! | [`brute_nearest`] | `fn brute_nearest(ray: Ray, t_max: f32, skip: u32, ray_kind: u32) -> Closest` |
//!
//! (`shaders/cube.wgsl` and `shaders/brute.wgsl`; `ray_kind` selects the test counter, and
//! the WGSL intersection routines take `t_max` themselves.)
//!
//! The table buffers the walkers read are described in [`crate::coherence::flat`].

use glam::Vec3;

use crate::coherence::flat::{FlatTables, GpuEntry, GpuFace, GpuOrigin};
use crate::coherence::groups::{group_hit, GROUP_BIT};
use crate::coherence::WalkCount;

/// The largest finite f32, `0x1.fffffep+127`: the "no hit" distance.
pub const F32_MAX: f32 = f32::MAX;
/// "No primitive": `0xffffffffu`.
pub const NO_ID: u32 = u32::MAX;

/// Face and cell of a direction on the direction cube with `n`×`n` cells per face.
///
/// Returns `[face, iu, iv]`: the major axis `ax` is the component of largest magnitude (ties
/// go to x before y before z), `face = 2·ax + (d[ax] < 0)`, `u = d[(ax+1)%3] / |d[ax]|` and
/// `v = d[(ax+2)%3] / |d[ax]|` lie in [−1, 1] and `iu = clamp(floor((u+1)·0.5·n), 0, n−1)`
/// (`iv` likewise). The direction need not be unit length but must not be zero: callers
/// reject a zero direction before the lookup (the indices are clamped anyway, and a NaN
/// would turn into cell 0 here but is undefined in WGSL). −0.0 components are harmless.
///
/// Cell assignment at exact boundaries may differ between this function and the WGSL one
/// (WGSL division is 2.5 ULP): the tables are built for directions within a small angle of
/// the cell, so correctness never depends on these ties.
pub fn cube_face_cell(d: Vec3, n: u32) -> [u32; 3] {
    let a = d.abs();
    let mut ax = 0u32;
    let mut m = a.x;
    if a.y > m {
        ax = 1;
        m = a.y;
    }
    if a.z > m {
        ax = 2;
        m = a.z;
    }
    let major = d[ax as usize];
    let face = 2 * ax + if major < 0.0 { 1 } else { 0 };
    let u = d[((ax + 1) % 3) as usize] / m;
    let v = d[((ax + 2) % 3) as usize] / m;
    let nf = n as f32;
    let iu = ((u + 1.0) * 0.5 * nf).floor().clamp(0.0, nf - 1.0) as u32;
    let iv = ((v + 1.0) * 0.5 * nf).floor().clamp(0.0, nf - 1.0) as u32;
    [face, iu, iv]
}

/// The surface patch of triangle `v` (split into an `m×m` barycentric grid) holding point
/// `at` (a ray origin on or just off the triangle): `j·m + i` for the grid square
/// `b1 ∈ [i/m, (i+1)/m)`, `b2 ∈ [j/m, (j+1)/m)`, clamped into the triangle's squares
/// (`i + j < m`). Rounding may put a point near a square's edge into its neighbour; the
/// tables inflate each patch's origin sphere for that.
pub fn triangle_patch(v: &[Vec3; 3], m: u32, at: Vec3) -> u32 {
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let w = at - v[0];
    let d11 = e1.dot(e1);
    let d12 = e1.dot(e2);
    let d22 = e2.dot(e2);
    let w1 = w.dot(e1);
    let w2 = w.dot(e2);
    let den = d11 * d22 - d12 * d12;
    let b1 = (d22 * w1 - d12 * w2) / den;
    let b2 = (d11 * w2 - d12 * w1) / den;
    let last = (m - 1) as f32;
    let i = (b1 * m as f32).floor().max(0.0).min(last) as u32;
    let j = (b2 * m as f32).floor().max(0.0).min(last) as u32;
    j.min(m - 1 - i) * m + i
}

/// The range `[begin, end)` of `entries` holding the candidate list of the cell that
/// direction `d` falls in, for origin `origin`. Directions outside the origin's stored
/// window of a face have an empty list.
pub fn cube_cell_range(
    origins: &[GpuOrigin],
    faces: &[GpuFace],
    cell_start: &[u32],
    origin: u32,
    d: Vec3,
) -> [u32; 2] {
    let org = origins[origin as usize];
    let fc = cube_face_cell(d, org.n);
    let w = faces[(origin * 6 + fc[0]) as usize];
    // u32 subtraction wraps, so a cell left of or below the window fails the test too.
    let lu = fc[1].wrapping_sub(w.iu0);
    let lv = fc[2].wrapping_sub(w.iv0);
    if lu >= w.width || lv >= w.height {
        return [0, 0];
    }
    let c = w.cell_base + lv * w.width + lu;
    [cell_start[c as usize], cell_start[c as usize + 1]]
}

/// Nearest t > 0 where the ray `o + t·d` (`d` unit) meets the sphere, or [`F32_MAX`].
///
/// Haines, Günther and Akenine-Möller's precise form (*Ray Tracing Gems* ch. 7): the
/// discriminant is `r² − |f + b·d|²` rather than `b² − c`, and the roots are `c/q` and `q`.
/// A ray starting inside returns the exit point.
pub fn ray_sphere(o: Vec3, d: Vec3, c: Vec3, r: f32) -> f32 {
    let f = o - c;
    let b = -f.dot(d);
    let g = f + b * d;
    let disc = r * r - g.dot(g);
    if disc < 0.0 {
        return F32_MAX;
    }
    let k = f.dot(f) - r * r;
    let sgn = if b >= 0.0 { 1.0 } else { -1.0 };
    let q = b + sgn * disc.sqrt();
    if q == 0.0 {
        return F32_MAX;
    }
    let t0 = k / q;
    let t1 = q;
    let tn = t0.min(t1);
    let tf = t0.max(t1);
    if tn > 0.0 {
        return tn;
    }
    if tf > 0.0 {
        return tf;
    }
    F32_MAX
}

/// Watertight ray/triangle intersection (Woop, Benthin and Wald, JCGT 2013): nearest t > 0
/// or [`F32_MAX`]. Both sides are hit. Edge values that are exactly zero count as inside (WGSL
/// cannot re-evaluate them in double), so a ray through a shared edge hits both triangles;
/// nearest-hit ties are resolved by the walker (lowest id).
pub fn ray_triangle(o: Vec3, d: Vec3, p0: Vec3, p1: Vec3, p2: Vec3) -> f32 {
    let ad = d.abs();
    let mut kz = 0usize;
    if ad.y > ad.x {
        kz = 1;
    }
    if ad.z > ad[kz] {
        kz = 2;
    }
    let mut kx = (kz + 1) % 3;
    let mut ky = (kx + 1) % 3;
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let sx = d[kx] / d[kz];
    let sy = d[ky] / d[kz];
    let sz = 1.0 / d[kz];
    let a = p0 - o;
    let b = p1 - o;
    let c = p2 - o;
    let ax = a[kx] - sx * a[kz];
    let ay = a[ky] - sy * a[kz];
    let bx = b[kx] - sx * b[kz];
    let by = b[ky] - sy * b[kz];
    let cx = c[kx] - sx * c[kz];
    let cy = c[ky] - sy * c[kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return F32_MAX;
    }
    let det = u + v + w;
    if det == 0.0 {
        return F32_MAX;
    }
    let tt = sz * (u * a[kz] + v * b[kz] + w * c[kz]);
    let t = tt / det;
    if t > 0.0 && t < F32_MAX {
        return t;
    }
    F32_MAX
}

/// Nearest t > 0 where the ray meets the lateral surface of a cylinder or truncated cone
/// (no end caps) from `base` (radius `r0`) to `apex` (radius `r1`), or [`F32_MAX`]. `d` unit.
pub fn ray_cylinder(o: Vec3, d: Vec3, base: Vec3, r0: f32, apex: Vec3, r1: f32) -> f32 {
    let axis = apex - base;
    let len = axis.length();
    let a = axis / len;
    let k = (r1 - r0) / len;
    // Solve from the point of the ray nearest the middle of the axis (as Haines's sphere test
    // does): far from the ray origin the quadratic's terms would otherwise cancel.
    let tc = (0.5 * (base + apex) - o).dot(d);
    let f = o + tc * d - base;
    let fa = f.dot(a);
    let da = d.dot(a);
    let fp = f - fa * a;
    let dp = d - da * a;
    let rf = r0 + k * fa;
    // |fp + t·dp|² = (r0 + k·(fa + t·da))²  ⇔  qa·t² + 2·qb·t + qc = 0
    let qa = dp.dot(dp) - k * k * da * da;
    let qb = fp.dot(dp) - k * da * rf;
    let qc = fp.dot(fp) - rf * rf;
    let mut t0 = F32_MAX;
    let mut t1 = F32_MAX;
    if qa == 0.0 {
        if qb != 0.0 {
            t0 = -qc / (2.0 * qb);
        }
    } else {
        let disc = qb * qb - qa * qc;
        if disc < 0.0 {
            return F32_MAX;
        }
        let sgn = if qb >= 0.0 { 1.0 } else { -1.0 };
        let q = -(qb + sgn * disc.sqrt());
        if q != 0.0 {
            t0 = qc / q;
        }
        t1 = q / qa;
    }
    let mut best = F32_MAX;
    for tl in [t0, t1] {
        if tl == F32_MAX {
            continue;
        }
        let t = tc + tl;
        if t > 0.0 && t < best {
            let s = fa + tl * da;
            if s >= 0.0 && s <= len {
                best = t;
            }
        }
    }
    best
}

/// Wächter and Binder's spawn offset (*Ray Tracing Gems* ch. 6): moves `p` off the surface
/// with geometric normal `ng` to the side `dir` leaves on, by 256 ULP per axis (or
/// 1/65536 near the origin). Rays then start at the moved point with t_min = 0.
pub fn offset_ray_origin(p: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if dir.dot(ng) > 0.0 { ng } else { -ng };
    let mut out = Vec3::ZERO;
    for i in 0..3 {
        let of = (INT_SCALE * n[i]) as i32;
        let bits = p[i].to_bits() as i32;
        let moved = f32::from_bits((if p[i] < 0.0 { bits - of } else { bits + of }) as u32);
        out[i] = if p[i].abs() < ORIGIN { p[i] + FLOAT_SCALE * n[i] } else { moved };
    }
    out
}

/// The largest distance [`offset_ray_origin`] can move a point whose coordinates are at most
/// `max_abs` in magnitude (unit normal).
pub fn max_origin_offset(max_abs: f32) -> f32 {
    // 256 ULP of the largest coordinate per axis (one ULP of x is at most x·2^-23), or
    // 1/65536 near the origin; sqrt(3) for the three axes.
    let per_axis = (max_abs * 256.0 * f32::EPSILON).max(1.0 / 65536.0);
    per_axis * 3f32.sqrt() * 1.01
}

/// A nearest hit: the primitive id ([`NO_ID`] for none) and its distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub id: u32,
    pub t: f32,
}

/// The candidate-table walk for a nearest hit (the WGSL `cube_walk_nearest`).
///
/// Merges the cell's list and the origin's always-test list by increasing `d_min` and stops
/// as soon as the next `d_min` exceeds the nearest hit found so far (the distance interval
/// optimization). `intersect(id)` returns the hit distance of primitive `id` or [`F32_MAX`];
/// hits at t ≥ `t_max` are ignored. Equal distances go to the lowest id, so the result does
/// not depend on the order of the lists. `skip` is a primitive never tested (the convex
/// primitive a reflected ray leaves from), or [`NO_ID`]. A group entry
/// ([`crate::coherence::groups`]) tests its sphere against the ray from `o` along the unit
/// `d`, then every member. Returns the hit and the tests made.
#[allow(clippy::too_many_arguments)]
pub fn cube_walk_nearest(
    tables: &FlatTables,
    origin: u32,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    skip: u32,
    mut intersect: impl FnMut(u32) -> f32,
) -> (Hit, WalkCount) {
    let mut best = Hit { id: NO_ID, t: t_max };
    let mut count = WalkCount::default();
    if d.abs().max_element() == 0.0 {
        return (best, count);
    }
    let entries = &tables.entries;
    let org = tables.origins[origin as usize];
    let range = cube_cell_range(&tables.origins, &tables.faces, &tables.cell_start, origin, d);
    let mut i = range[0];
    let iend = range[1];
    let mut j = org.always_start;
    let jend = org.always_start + org.always_count;
    let mut consider = |id: u32, best: &mut Hit, count: &mut WalkCount| {
        if id == skip {
            return;
        }
        count.tests += 1;
        let t = intersect(id);
        if t < best.t || (t == best.t && best.id != NO_ID && id < best.id) {
            *best = Hit { id, t };
        }
    };
    loop {
        let e: GpuEntry;
        if i < iend && (j >= jend || entries[i as usize].d_min <= entries[j as usize].d_min) {
            e = entries[i as usize];
            i += 1;
        } else if j < jend {
            e = entries[j as usize];
            j += 1;
        } else {
            break;
        }
        if e.d_min > best.t {
            break;
        }
        if e.id & GROUP_BIT != 0 {
            let g = &tables.groups[(e.id & !GROUP_BIT) as usize];
            count.bounds += 1;
            if group_hit(g, o, d, best.t) {
                for k in g.first..g.first + g.count {
                    consider(tables.group_prims[k as usize], &mut best, &mut count);
                }
            }
            continue;
        }
        consider(e.id, &mut best, &mut count);
    }
    if best.id == NO_ID {
        best.t = F32_MAX;
    }
    (best, count)
}

/// The candidate-table walk for an any-hit (shadow) query (the WGSL `cube_walk_any`): true
/// when some primitive other than `skip` is hit at 0 < t < `t_max` by the ray from `o` along
/// the unit `d`. Returns the answer and the tests made.
#[allow(clippy::too_many_arguments)]
pub fn cube_walk_any(
    tables: &FlatTables,
    origin: u32,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    skip: u32,
    mut intersect: impl FnMut(u32) -> f32,
) -> (bool, WalkCount) {
    let mut count = WalkCount::default();
    if d.abs().max_element() == 0.0 {
        return (false, count);
    }
    let entries = &tables.entries;
    let org = tables.origins[origin as usize];
    let range = cube_cell_range(&tables.origins, &tables.faces, &tables.cell_start, origin, d);
    let mut i = range[0];
    let iend = range[1];
    let mut j = org.always_start;
    let jend = org.always_start + org.always_count;
    let mut hits = |id: u32, count: &mut WalkCount| {
        if id == skip {
            return false;
        }
        count.tests += 1;
        intersect(id) < t_max
    };
    loop {
        let e: GpuEntry;
        if i < iend && (j >= jend || entries[i as usize].d_min <= entries[j as usize].d_min) {
            e = entries[i as usize];
            i += 1;
        } else if j < jend {
            e = entries[j as usize];
            j += 1;
        } else {
            break;
        }
        if e.d_min >= t_max {
            break;
        }
        if e.id & GROUP_BIT != 0 {
            let g = &tables.groups[(e.id & !GROUP_BIT) as usize];
            count.bounds += 1;
            if group_hit(g, o, d, t_max) {
                for k in g.first..g.first + g.count {
                    if hits(tables.group_prims[k as usize], &mut count) {
                        return (true, count);
                    }
                }
            }
            continue;
        }
        if hits(e.id, &mut count) {
            return (true, count);
        }
    }
    (false, count)
}

/// A primitive in f32, as the GPU stores it (after re-centring on the camera). Used by the
/// tests and the measurements; the GPU issue owns the real buffer layout.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Prim32 {
    Sphere { c: Vec3, r: f32 },
    Triangle { p: [Vec3; 3] },
    Cylinder { base: Vec3, r0: f32, apex: Vec3, r1: f32 },
}

impl Prim32 {
    /// The scene's primitives in f32, translated by `-shift` (re-centred on `shift`).
    pub fn from_scene(scene: &crate::scene::Scene, shift: glam::DVec3) -> Vec<Prim32> {
        use crate::scene::Primitive;
        let v = |p: glam::DVec3| (p - shift).as_vec3();
        scene
            .primitives
            .iter()
            .map(|p| match p {
                Primitive::Sphere(s) => Prim32::Sphere { c: v(s.center), r: s.radius as f32 },
                Primitive::Triangle(t) => Prim32::Triangle { p: [v(t.p[0]), v(t.p[1]), v(t.p[2])] },
                Primitive::Cylinder(c) => Prim32::Cylinder {
                    base: v(c.base),
                    r0: c.base_radius as f32,
                    apex: v(c.apex),
                    r1: c.apex_radius as f32,
                },
            })
            .collect()
    }

    /// The WGSL `intersect_prim`: nearest t > 0 or [`F32_MAX`].
    pub fn intersect(&self, o: Vec3, d: Vec3) -> f32 {
        match *self {
            Prim32::Sphere { c, r } => ray_sphere(o, d, c, r),
            Prim32::Triangle { p } => ray_triangle(o, d, p[0], p[1], p[2]),
            Prim32::Cylinder { base, r0, apex, r1 } => ray_cylinder(o, d, base, r0, apex, r1),
        }
    }
}

/// Testing every primitive except `skip`, with the walkers' tie rule (equal distances go to
/// the lower id): the answer the table walks must reproduce. Returns (id, t), with
/// (`NO_ID`, `F32_MAX`) for a miss.
pub fn brute_nearest(prims: &[Prim32], o: Vec3, d: Vec3, t_max: f32, skip: u32) -> (u32, f32) {
    let mut best = (NO_ID, t_max);
    for (i, p) in prims.iter().enumerate() {
        if i as u32 == skip {
            continue;
        }
        let t = p.intersect(o, d);
        if t < best.1 || (t == best.1 && best.0 != NO_ID && (i as u32) < best.0) {
            best = (i as u32, t);
        }
    }
    if best.0 == NO_ID {
        best.1 = F32_MAX;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_of_axes_and_signs() {
        let n = 8;
        assert_eq!(cube_face_cell(Vec3::X, n), [0, 4, 4]);
        assert_eq!(cube_face_cell(-Vec3::X, n), [1, 4, 4]);
        assert_eq!(cube_face_cell(Vec3::Y, n), [2, 4, 4]);
        assert_eq!(cube_face_cell(-Vec3::Z, n), [5, 4, 4]);
        // −0.0 components behave like +0.0.
        assert_eq!(cube_face_cell(Vec3::new(-0.0, -0.0, 1.0), n), cube_face_cell(Vec3::Z, n));
        // Ties go to x, then y.
        assert_eq!(cube_face_cell(Vec3::new(1.0, 1.0, 1.0), n)[0], 0);
        assert_eq!(cube_face_cell(Vec3::new(0.0, -1.0, 1.0), n)[0], 3);
        // u = ±1 is clamped into the last cell.
        assert_eq!(cube_face_cell(Vec3::new(1.0, 1.0, -1.0), n), [0, 7, 0]);
    }

    #[test]
    fn sphere_hits_inside_and_misses() {
        let o = Vec3::ZERO;
        assert!((ray_sphere(o, Vec3::X, Vec3::new(5.0, 0.0, 0.0), 1.0) - 4.0).abs() < 1e-6);
        assert!((ray_sphere(o, Vec3::X, Vec3::ZERO, 2.0) - 2.0).abs() < 1e-6);
        assert_eq!(ray_sphere(o, -Vec3::X, Vec3::new(5.0, 0.0, 0.0), 1.0), F32_MAX);
        assert_eq!(ray_sphere(o, Vec3::Y, Vec3::new(5.0, 0.0, 0.0), 1.0), F32_MAX);
    }

    #[test]
    fn triangle_watertight_shared_edge() {
        // A quad split along its diagonal: a ray through the diagonal hits at least one half.
        let p = [Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, -1.0, 2.0), Vec3::new(1.0, 1.0, 2.0)];
        let q = [Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, 1.0, 2.0), Vec3::new(-1.0, 1.0, 2.0)];
        for k in -20..=20 {
            let s = k as f32 * 0.037;
            let d = Vec3::new(s, s, 2.0).normalize();
            let a = ray_triangle(Vec3::ZERO, d, p[0], p[1], p[2]);
            let b = ray_triangle(Vec3::ZERO, d, q[0], q[1], q[2]);
            assert!(a < F32_MAX || b < F32_MAX, "crack at s = {s}");
        }
        // Parallel ray: a finite miss.
        assert_eq!(ray_triangle(Vec3::new(0.0, 0.0, 2.0), Vec3::X, p[0], p[1], p[2]), F32_MAX);
    }

    #[test]
    fn cylinder_and_cone() {
        let t = ray_cylinder(Vec3::new(-5.0, 0.0, 0.5), Vec3::X, Vec3::ZERO, 1.0, Vec3::Z, 1.0);
        assert!((t - 4.0).abs() < 1e-5);
        // Beyond the apex: miss (no caps).
        let t = ray_cylinder(Vec3::new(-5.0, 0.0, 1.5), Vec3::X, Vec3::ZERO, 1.0, Vec3::Z, 1.0);
        assert_eq!(t, F32_MAX);
        // Inside, looking out.
        let t = ray_cylinder(Vec3::new(0.0, 0.0, 0.5), Vec3::Y, Vec3::ZERO, 1.0, Vec3::Z, 1.0);
        assert!((t - 1.0).abs() < 1e-5);
        // Cone from radius 1 to 0.5 over height 1: at z = 0.5 the radius is 0.75.
        let t = ray_cylinder(Vec3::new(-5.0, 0.0, 0.5), Vec3::X, Vec3::ZERO, 1.0, Vec3::Z, 0.5);
        assert!((t - 4.25).abs() < 1e-5);
        // Along the axis inside the cylinder: never meets the wall.
        let t = ray_cylinder(Vec3::new(0.0, 0.0, 0.5), Vec3::Z, Vec3::ZERO, 1.0, Vec3::Z, 1.0);
        assert_eq!(t, F32_MAX);
    }

    #[test]
    fn offset_moves_to_the_outgoing_side() {
        for p in [Vec3::new(0.001, 0.0, 0.0), Vec3::new(3.0, -7.0, 100.0), Vec3::new(-1e5, 2.0, 0.5)] {
            let n = Vec3::new(0.0, 0.6, 0.8);
            let q = offset_ray_origin(p, n, n);
            assert!((q - p).dot(n) > 0.0);
            let q2 = offset_ray_origin(p, n, -n);
            assert!((q2 - p).dot(n) < 0.0);
            let bound = max_origin_offset(p.abs().max_element());
            assert!((q - p).length() <= bound, "{p}: moved {} > {bound}", (q - p).length());
        }
    }
}
