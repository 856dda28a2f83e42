//! Direction-cube geometry in f64: cells and their bounding cones, direction bounds (cones)
//! from an origin sphere to spheres, triangles and capsules, the cell tests (Test A to build,
//! exact Test B to validate), and the "certain hit" (cover) tests that let a cell's list stop
//! at the first object every ray of the cell must hit.
//!
//! Conventions (shared with [`crate::mirror::cube_face_cell`]): face `f = 2·ax + neg`; on that
//! face a direction is `w[ax] = ±1, w[(ax+1)%3] = u, w[(ax+2)%3] = v` (unnormalised), and cell
//! `(iu, iv)` spans `u ∈ [−1 + 2·iu/n, −1 + 2·(iu+1)/n]`, `v` likewise. The gnomonic projection
//! maps great circles to lines, so a cell is a convex spherical quadrilateral.
//!
//! Every test is conservative in the direction that keeps rendering exact: "meets" may say yes
//! for a cell the object cannot be seen through (costs time), never no for one it can; "covers"
//! may say no for a covered cell, never yes for one that is not. Origins are spheres already
//! inflated by the largest ray-spawn offset; angles are widened by `delta` so that a direction
//! the GPU's f32 lookup puts in a neighbouring cell (or face) is still accounted for.

// `!(a > b)` is deliberate: a NaN must fail these tests, not pass them.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::DVec3;

/// A unit vector along axis `ax` of face `face`, and the two in-face axes, as world vectors:
/// `dir(u, v) = s·e[ax] + u·e[i1] + v·e[i2]`.
#[inline]
pub fn face_dir(face: usize, u: f64, v: f64) -> DVec3 {
    let ax = face / 2;
    let s = if face % 2 == 1 { -1.0 } else { 1.0 };
    let mut w = [0.0; 3];
    w[ax] = s;
    w[(ax + 1) % 3] = u;
    w[(ax + 2) % 3] = v;
    DVec3::from_array(w)
}

/// The `u` (or `v`) coordinate of cell boundary `k` on an `n`-cell face.
#[inline]
pub fn edge_coord(k: u32, n: u32) -> f64 {
    -1.0 + 2.0 * k as f64 / n as f64
}

/// A cell's bounding cone: unit centre direction and the cosine/sine of the largest angle to
/// its corners. Also the four corners, unnormalised (on the face plane).
#[derive(Clone, Copy, Debug)]
pub struct CellCone {
    pub m: DVec3,
    /// Half-angle β of the bounding cone.
    pub beta: f64,
    pub cos_b: f64,
    pub sin_b: f64,
    pub corners: [DVec3; 4],
}

/// Computes the geometry of cell `(iu, iv)` on `face` of an `n`-cube.
pub fn cell_cone(face: usize, iu: u32, iv: u32, n: u32) -> CellCone {
    region_cone(face, [iu, iv, iu, iv], n)
}

/// The same for the block of cells `iu0..=iu1` × `iv0..=iv1` (`r = [iu0, iv0, iu1, iv1]`):
/// a gnomonic rectangle is a convex spherical quadrilateral, so every test written for a
/// cell holds for a block.
pub fn region_cone(face: usize, r: [u32; 4], n: u32) -> CellCone {
    let (u0, u1) = (edge_coord(r[0], n), edge_coord(r[2] + 1, n));
    let (v0, v1) = (edge_coord(r[1], n), edge_coord(r[3] + 1, n));
    let m = face_dir(face, 0.5 * (u0 + u1), 0.5 * (v0 + v1)).normalize();
    let corners =
        [face_dir(face, u0, v0), face_dir(face, u1, v0), face_dir(face, u1, v1), face_dir(face, u0, v1)];
    let cos_b = corners.iter().map(|c| m.dot(c.normalize())).fold(1.0, f64::min).clamp(-1.0, 1.0);
    CellCone { m, beta: cos_b.acos(), cos_b, sin_b: (1.0 - cos_b * cos_b).max(0.0).sqrt(), corners }
}

/// A cone of directions: unit axis and half-angle `theta` in [0, π].
#[derive(Clone, Copy, Debug)]
pub struct Cone {
    pub axis: DVec3,
    pub theta: f64,
    pub cos_t: f64,
    pub sin_t: f64,
    /// Range `[lo, hi]` of each component `w_i` over the cap.
    range: [[f64; 2]; 3],
}

impl Cone {
    pub fn new(axis: DVec3, theta: f64) -> Cone {
        let theta = theta.clamp(0.0, std::f64::consts::PI);
        let (cos_t, sin_t) = (theta.cos(), theta.sin());
        // w·e_i over the cap: [cos(min(π, α+θ)), cos(max(0, α−θ))], α = angle(axis, e_i),
        // expanded as cosα·cosθ ∓ sinα·sinθ.
        let range = [0, 1, 2].map(|i| {
            let c = axis[i].clamp(-1.0, 1.0);
            let s = (1.0 - c * c).max(0.0).sqrt();
            let lo = if c <= -cos_t { -1.0 } else { c * cos_t - s * sin_t };
            let hi = if c >= cos_t { 1.0 } else { c * cos_t + s * sin_t };
            [lo.max(-1.0), hi.min(1.0)]
        });
        Cone { axis, theta, cos_t, sin_t, range }
    }

    /// Test A: true when the angle between the axis and the cell's centre is at most θ + β,
    /// which holds whenever the cap meets the cell (conservative).
    #[inline]
    pub fn meets(&self, cell: &CellCone) -> bool {
        if self.theta + cell.beta >= std::f64::consts::PI {
            return true;
        }
        // cos(θ + β) = cosθ·cosβ − sinθ·sinβ
        self.axis.dot(cell.m) >= self.cos_t * cell.cos_b - self.sin_t * cell.sin_b
    }

    /// True when the whole cell lies inside the cap (angle(axis, m) + β ≤ θ).
    #[inline]
    pub fn contains(&self, cell: &CellCone) -> bool {
        if self.theta >= std::f64::consts::PI {
            return true;
        }
        if cell.cos_b < self.cos_t {
            return false; // β > θ
        }
        // cos(θ − β) = cosθ·cosβ + sinθ·sinβ
        self.axis.dot(cell.m) >= self.cos_t * cell.cos_b + self.sin_t * cell.sin_b
    }

    /// Test B: exact cap/cell intersection (for validation). The cap meets the spherical
    /// quadrilateral iff a corner is inside the cap, the axis is inside the cell, or an edge
    /// arc comes within θ of the axis.
    pub fn meets_exact(&self, cell: &CellCone) -> bool {
        let c: Vec<DVec3> = cell.corners.iter().map(|c| c.normalize()).collect();
        if c.iter().any(|ck| self.axis.dot(*ck) >= self.cos_t) {
            return true;
        }
        if self.theta >= std::f64::consts::FRAC_PI_2 {
            // The complement cap is convex: all corners outside it means the cell is outside.
            return false;
        }
        // Axis inside the cell: on the inner side of all four edge planes.
        let inside = (0..4).all(|k| {
            let nk = c[k].cross(c[(k + 1) % 4]);
            let nk = if nk.dot(cell.m) < 0.0 { -nk } else { nk };
            nk.dot(self.axis) >= 0.0
        });
        if inside {
            return true;
        }
        (0..4).any(|k| {
            let (a, b) = (c[k], c[(k + 1) % 4]);
            let n = a.cross(b).normalize();
            let s = self.axis.dot(n);
            if s.abs() > self.sin_t {
                return false;
            }
            let p = self.axis - s * n;
            if p.length_squared() == 0.0 {
                return true;
            }
            let p = p.normalize();
            a.cross(p).dot(n) >= 0.0 && p.cross(b).dot(n) >= 0.0
        })
    }

    /// Conservative bounding rectangle `[u0, u1] × [v0, v1]` of the cap on `face`, or `None`
    /// when the cap does not reach the face's pyramid.
    pub fn face_rect(&self, face: usize) -> Option<[f64; 4]> {
        let ax = face / 2;
        let (i1, i2) = ((ax + 1) % 3, (ax + 2) % 3);
        let [lo, hi] = self.range[ax];
        // Range of s·w[ax] over the cap.
        let (k_lo, k_hi) = if face % 2 == 1 { (-hi, -lo) } else { (lo, hi) };
        // The face's pyramid is where s·w[ax] ≥ |w[i1]|, |w[i2]|, so it needs s·w[ax] > 0.
        if k_hi <= 0.0 {
            return None;
        }
        if k_lo <= 1e-9 {
            // The cap reaches the plane w[ax] = 0: no useful bound on the ratios.
            return Some([-1.0, 1.0, -1.0, 1.0]);
        }
        let [l1, h1] = self.range[i1];
        let [l2, h2] = self.range[i2];
        let lo = |l: f64| if l < 0.0 { l / k_lo } else { l / k_hi };
        let hi = |h: f64| if h > 0.0 { h / k_lo } else { h / k_hi };
        let r = [lo(l1).max(-1.0), hi(h1).min(1.0), lo(l2).max(-1.0), hi(h2).min(1.0)];
        if r[0] > r[1] || r[2] > r[3] {
            return None;
        }
        Some(r)
    }
}

/// The cell index range `[lo, hi]` (inclusive) covering coordinates `[a, b]`, widened by one
/// cell on each side for rounding.
#[inline]
pub fn cell_span(a: f64, b: f64, n: u32) -> (u32, u32) {
    let nf = n as f64;
    let lo = (((a + 1.0) * 0.5 * nf).floor() - 1.0).clamp(0.0, nf - 1.0) as u32;
    let hi = (((b + 1.0) * 0.5 * nf).floor() + 1.0).clamp(0.0, nf - 1.0) as u32;
    (lo, hi)
}

/// The direction bound from an origin sphere to a sphere (or to a bounding sphere): a cone
/// widened by `delta`, or `None` when the spheres overlap or touch (every direction).
pub fn sphere_cone(ca: DVec3, ra: f64, cb: DVec3, rb: f64, delta: f64) -> Option<Cone> {
    let v = cb - ca;
    let d = v.length();
    let s = (ra + rb) / d;
    if !(d > 0.0) || s >= 1.0 - 1e-9 {
        return None;
    }
    let theta = s.asin() + delta;
    if theta >= std::f64::consts::PI {
        return None;
    }
    Some(Cone::new(v / d, theta))
}

/// Distance from `p` to triangle `t` (exact, f64).
pub fn point_triangle_distance(p: DVec3, t: &[DVec3; 3]) -> f64 {
    // Ericson's closest point on triangle, by Voronoi regions.
    let (a, b, c) = (t[0], t[1], t[2]);
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (p - a).length();
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (p - b).length();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (p - (a + v * ab)).length();
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (p - c).length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + w * ac)).length();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + w * (c - b))).length();
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (p - (a + ab * v + ac * w)).length()
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    (p - (a + t * ab)).length()
}

/// The edge functions of a triangle seen from an origin sphere lying entirely on one side
/// of the triangle's plane.
///
/// A ray from `p` (on side σ) along `w` hits the triangle iff `E_e(p, w) ≥ 0` for its three
/// edges, with `E_e = −σ·((v_i − p) × (v_j − p))·w`. Writing `p = c + q`, `|q| ≤ r`:
/// `E_e = g_e·w + q·(w × k_e)` with `g_e = −σ·(a × b)`, `a = v_i − c`, `b = v_j − c`,
/// `k_e = b − a`, so `g_e·w − r·|w × k_e| ≤ E_e ≤ g_e·w + r·|w × k_e|`. Both bounds are
/// homogeneous in `w`, the upper one convex and the lower one concave, so their extremes over
/// a cell are at its corners: testing the four (unnormalised) corners is exact per edge.
#[derive(Clone, Copy, Debug)]
pub struct TriEdges {
    g: [DVec3; 3],
    k: [DVec3; 3],
    g_len: [f64; 3],
    k_len: [f64; 3],
    /// Unit normal pointing from the origin side toward the plane (rays must have w·n > 0).
    toward: DVec3,
    /// Distance from the origin sphere's centre to the plane.
    h: f64,
    r: f64,
}

impl TriEdges {
    /// `None` when the sphere `(c, r)` touches or straddles the plane (within `margin`).
    pub fn new(c: DVec3, r: f64, v: &[DVec3; 3], margin: f64) -> Option<TriEdges> {
        let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let h = n.dot(c - v[0]);
        if !(h.abs() > r + margin) {
            return None;
        }
        let sigma = h.signum();
        let mut g = [DVec3::ZERO; 3];
        let mut k = [DVec3::ZERO; 3];
        for e in 0..3 {
            let a = v[e] - c;
            let b = v[(e + 1) % 3] - c;
            g[e] = -sigma * a.cross(b);
            k[e] = b - a;
        }
        Some(TriEdges {
            g,
            k,
            g_len: g.map(|x| x.length()),
            k_len: k.map(|x| x.length()),
            toward: -sigma * n,
            h: h.abs(),
            r,
        })
    }

    /// True when some ray from the sphere with a direction within `delta` of the cell may hit
    /// the triangle (each edge and the plane side separately: conservative).
    pub fn meets(&self, cell: &CellCone, delta: f64) -> bool {
        let sd = delta.sin();
        let toward = cell.corners.iter().any(|w| self.toward.dot(*w) >= -sd * w.length());
        if !toward {
            return false;
        }
        (0..3).all(|e| {
            cell.corners.iter().any(|w| {
                let wl = w.length();
                self.g[e].dot(*w) + self.r * self.k[e].cross(*w).length()
                    >= -sd * wl * (self.g_len[e] + self.r * self.k_len[e])
            })
        })
    }

    /// Lower bound on the distance to the triangle's plane along directions within `delta`
    /// of the cell: `(h − r) / max(w·n)` over the cell.
    pub fn plane_dmin(&self, cell: &CellCone, delta: f64) -> f64 {
        let ang = self.toward.dot(cell.m).clamp(-1.0, 1.0).acos();
        let cos_max = (ang - cell.beta - delta).max(0.0).cos();
        if cos_max > 1e-9 {
            (self.h - self.r) / cos_max
        } else {
            self.h - self.r
        }
    }

    /// When every ray from the sphere with a direction within `delta` of the cell hits the
    /// triangle, an upper bound on the hit distance.
    pub fn covers(&self, cell: &CellCone, delta: f64) -> Option<f64> {
        let sd = delta.sin();
        for e in 0..3 {
            for w in &cell.corners {
                let wl = w.length();
                let lo = self.g[e].dot(*w)
                    - self.r * self.k[e].cross(*w).length()
                    - sd * wl * (self.g_len[e] + self.r * self.k_len[e]);
                if !(lo > 0.0) {
                    return None;
                }
            }
        }
        let min_cos = cell.corners.iter().map(|w| self.toward.dot(w.normalize())).fold(1.0, f64::min) - sd;
        if !(min_cos > 1e-6) {
            return None;
        }
        Some((self.h + self.r) / min_cos)
    }
}

/// The direction bound from an origin sphere `(c, r)` to a capsule (every point within `rad`
/// of the segment `p0`–`p1`): directions within `asin(ρ/d)` of the arc of directions toward the
/// segment, `ρ = r + rad`, `d` the distance from `c` to the segment.
#[derive(Clone, Copy, Debug)]
pub struct ArcBound {
    e0: DVec3,
    e1: DVec3,
    /// Unit normal of the arc's great circle, or zero when the arc is (nearly) a point.
    n: DVec3,
    cos_t: f64,
    sin_t: f64,
    theta: f64,
}

impl ArcBound {
    /// `None` when the sphere meets the capsule (every direction).
    pub fn new(c: DVec3, r: f64, p0: DVec3, p1: DVec3, rad: f64, delta: f64) -> Option<ArcBound> {
        let rho = r + rad;
        let d = point_segment_distance(c, p0, p1);
        if !(d > rho * (1.0 + 1e-9)) {
            return None;
        }
        let theta = (rho / d).min(1.0).asin() + delta;
        if theta >= std::f64::consts::FRAC_PI_2 {
            return None;
        }
        let e0 = (p0 - c).normalize();
        let e1 = (p1 - c).normalize();
        let x = e0.cross(e1);
        let n = if x.length() > 1e-9 { x.normalize() } else { DVec3::ZERO };
        Some(ArcBound { e0, e1, n, cos_t: theta.cos(), sin_t: theta.sin(), theta })
    }

    /// Cosine of the angular distance from unit `m` to the arc.
    fn cos_dist(&self, m: DVec3) -> f64 {
        let ends = m.dot(self.e0).max(m.dot(self.e1));
        if self.n == DVec3::ZERO {
            return ends;
        }
        let p = m - m.dot(self.n) * self.n;
        let pl = p.length();
        if pl < 1e-12 {
            return ends;
        }
        let ph = p / pl;
        if self.e0.cross(ph).dot(self.n) >= 0.0 && ph.cross(self.e1).dot(self.n) >= 0.0 {
            pl.max(ends)
        } else {
            ends
        }
    }

    /// True when every direction of the cell is within θ of the arc.
    pub fn contains(&self, cell: &CellCone) -> bool {
        if cell.beta > self.theta {
            return false;
        }
        // cos(θ − β) = cosθ·cosβ + sinθ·sinβ
        self.cos_dist(cell.m) >= self.cos_t * cell.cos_b + self.sin_t * cell.sin_b
    }

    /// True when the widened bound meets the cell (angle(m, arc) ≤ θ + β).
    pub fn meets(&self, cell: &CellCone) -> bool {
        if self.theta + cell.beta >= std::f64::consts::PI {
            return true;
        }
        self.cos_dist(cell.m) >= self.cos_t * cell.cos_b - self.sin_t * cell.sin_b
    }
}

/// The inner cone of a sphere `(cb, rb)` seen from an origin sphere `(ca, ra)`: every ray from
/// the origin sphere with a direction inside it hits the target sphere, at a distance at most
/// the returned bound. `None` when there is no such cone.
pub fn sphere_inner_cone(ca: DVec3, ra: f64, cb: DVec3, rb: f64, delta: f64) -> Option<(Cone, f64)> {
    let v = cb - ca;
    let d = v.length();
    if !(rb > 0.0 && d > ra + rb) {
        return None;
    }
    let theta = (rb / (d + ra)).asin() - (ra / d).asin() - delta;
    if !(theta > 0.0) {
        return None;
    }
    let t_far = ((d + ra) * (d + ra) - rb * rb).sqrt();
    Some((Cone::new(v / d, theta), t_far))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rng(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    fn unit(seed: &mut u64) -> DVec3 {
        loop {
            let v = DVec3::new(rng(seed) * 2.0 - 1.0, rng(seed) * 2.0 - 1.0, rng(seed) * 2.0 - 1.0);
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    /// Test A contains Test B, and Test B contains every sampled direction of the cell
    /// that lies in the cap.
    #[test]
    fn test_a_contains_test_b_contains_samples() {
        let mut s = 0x9e3779b97f4a7c15u64;
        let n = 8;
        let mut b_only = 0;
        let mut a_count = 0;
        let mut b_count = 0;
        for _ in 0..200 {
            let cone = Cone::new(unit(&mut s), rng(&mut s) * 1.2);
            for face in 0..6 {
                for iv in 0..n {
                    for iu in 0..n {
                        let cell = cell_cone(face, iu, iv, n);
                        let a = cone.meets(&cell);
                        let b = cone.meets_exact(&cell);
                        a_count += a as u32;
                        b_count += b as u32;
                        if b && !a {
                            b_only += 1;
                        }
                        if !b {
                            // Sample the cell: no direction may be in the cap.
                            for _ in 0..6 {
                                let u = edge_coord(iu, n) + rng(&mut s) * 2.0 / n as f64;
                                let v = edge_coord(iv, n) + rng(&mut s) * 2.0 / n as f64;
                                let w = face_dir(face, u, v).normalize();
                                assert!(cone.axis.dot(w) < cone.cos_t + 1e-12, "Test B missed a direction");
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(b_only, 0, "Test A missed cells Test B found");
        assert!(a_count >= b_count && b_count > 0);
    }

    #[test]
    fn face_rect_contains_cap_cells() {
        let mut s = 12345u64;
        let n = 16;
        for _ in 0..300 {
            let cone = Cone::new(unit(&mut s), rng(&mut s) * 1.5);
            for face in 0..6 {
                let rect = cone.face_rect(face);
                for iv in 0..n {
                    for iu in 0..n {
                        let cell = cell_cone(face, iu, iv, n);
                        if cone.meets_exact(&cell) {
                            let r = rect.expect("face with a cap cell has a rectangle");
                            let (lu, hu) = cell_span(r[0], r[1], n);
                            let (lv, hv) = cell_span(r[2], r[3], n);
                            assert!(lu <= iu && iu <= hu && lv <= iv && iv <= hv, "cell outside rect");
                        }
                    }
                }
            }
        }
    }

    /// Rays from random points of the origin sphere toward random points of the triangle
    /// meet the edge bound in their cell; covered cells are really hit by sampled rays.
    #[test]
    fn triangle_edges_meet_and_cover() {
        let mut s = 777u64;
        let n = 8;
        for _ in 0..100 {
            let c = DVec3::ZERO;
            let r = rng(&mut s) * 0.3;
            let base = unit(&mut s) * (1.0 + rng(&mut s) * 3.0);
            let v = [base + unit(&mut s) * 1.5, base + unit(&mut s) * 1.5, base + unit(&mut s) * 1.5];
            let Some(te) = TriEdges::new(c, r, &v, 0.0) else { continue };
            for _ in 0..50 {
                let p = c + unit(&mut s) * r * rng(&mut s).sqrt();
                let (a, b) = (rng(&mut s), rng(&mut s));
                let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                let q = v[0] + a * (v[1] - v[0]) + b * (v[2] - v[0]);
                let w = (q - p).normalize();
                let [face, iu, iv] = crate::mirror::cube_face_cell(w.as_vec3(), n);
                let cell = cell_cone(face as usize, iu, iv, n);
                assert!(te.meets(&cell, 1e-6), "edge bound missed a hitting direction");
            }
            // Covered cells: rays from sampled origin points through sampled cell directions hit.
            for face in 0..6 {
                for iv in 0..n {
                    for iu in 0..n {
                        let cell = cell_cone(face, iu, iv, n);
                        if let Some(t_far) = te.covers(&cell, 1e-6) {
                            for _ in 0..8 {
                                let p = c + unit(&mut s) * r * rng(&mut s).sqrt();
                                let u = edge_coord(iu, n) + rng(&mut s) * 2.0 / n as f64;
                                let vv = edge_coord(iv, n) + rng(&mut s) * 2.0 / n as f64;
                                let w = face_dir(face, u, vv).normalize();
                                let t = ray_tri_f64(p, w, &v).expect("covered cell ray misses");
                                assert!(t <= t_far * (1.0 + 1e-9));
                            }
                        }
                    }
                }
            }
        }
    }

    fn ray_tri_f64(o: DVec3, d: DVec3, v: &[DVec3; 3]) -> Option<f64> {
        let e1 = v[1] - v[0];
        let e2 = v[2] - v[0];
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-14 {
            return None;
        }
        let tv = o - v[0];
        let a = tv.dot(p) / det;
        let q = tv.cross(e1);
        let b = d.dot(q) / det;
        let t = e2.dot(q) / det;
        (a >= 0.0 && b >= 0.0 && a + b <= 1.0 && t > 0.0).then_some(t)
    }

    #[test]
    fn arc_bound_meets_capsule_directions() {
        let mut s = 4242u64;
        let n = 8;
        for _ in 0..200 {
            let c = DVec3::ZERO;
            let r = rng(&mut s) * 0.2;
            let p0 = unit(&mut s) * (1.0 + rng(&mut s) * 3.0);
            let p1 = p0 + unit(&mut s) * rng(&mut s) * 2.0;
            let rad = rng(&mut s) * 0.3;
            let Some(arc) = ArcBound::new(c, r, p0, p1, rad, 1e-9) else { continue };
            for _ in 0..40 {
                let p = c + unit(&mut s) * r * rng(&mut s).sqrt();
                let q = p0 + (p1 - p0) * rng(&mut s) + unit(&mut s) * rad * rng(&mut s).sqrt();
                let w = (q - p).normalize();
                let [face, iu, iv] = crate::mirror::cube_face_cell(w.as_vec3(), n);
                assert!(arc.meets(&cell_cone(face as usize, iu, iv, n)));
            }
        }
    }

    #[test]
    fn point_triangle_distance_matches_sampling() {
        let mut s = 99u64;
        for _ in 0..100 {
            let v = [unit(&mut s), unit(&mut s), unit(&mut s)];
            let p = unit(&mut s) * 2.0;
            let d = point_triangle_distance(p, &v);
            let mut best = f64::MAX;
            for i in 0..=60 {
                for j in 0..=(60 - i) {
                    let q = v[0] + (v[1] - v[0]) * (i as f64 / 60.0) + (v[2] - v[0]) * (j as f64 / 60.0);
                    best = best.min((q - p).length());
                }
            }
            assert!(d <= best + 1e-12 && d >= best - 0.05, "{d} vs {best}");
        }
    }
}
