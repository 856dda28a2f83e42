//! Direction bounds in f64 from an origin sphere to each kind of target: cones to spheres
//! (and their inner cones, which every ray of a cell certainly hits), edge functions of
//! triangles, arcs around capsules, and the distances that give each its lower bound
//! `d_min`. Every test is conservative in the direction that keeps rendering exact: "meets"
//! may say yes for a cell the object cannot be seen through, never no for one it can;
//! "covers" may say no for a covered cell, never yes for one that is not. Origins are spheres
//! already inflated by the largest ray-spawn offset; angles are widened by `delta` so that a
//! direction the GPU's f32 lookup puts in a neighbouring cell (or face) is still accounted
//! for.

// `!(a > b)` is deliberate: a NaN must fail these tests, not pass them.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::DVec3;

use super::cells::{CellCone, Cone};

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
    /// sin and cos of the angular widening δ the tests allow for.
    sin_d: f64,
    cos_d: f64,
}

impl TriEdges {
    /// `None` when the sphere `(c, r)` touches or straddles the plane (within `margin`). The
    /// tests widen every cell by `delta` radians.
    pub fn new(c: DVec3, r: f64, v: &[DVec3; 3], margin: f64, delta: f64) -> Option<TriEdges> {
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
            sin_d: delta.sin(),
            cos_d: delta.cos(),
        })
    }

    /// True when some ray from the sphere with a direction within δ of the cell may hit
    /// the triangle (each edge and the plane side separately: conservative).
    pub fn meets(&self, cell: &CellCone) -> bool {
        let sd = self.sin_d;
        let toward = (0..4).any(|k| self.toward.dot(cell.corners[k]) >= -sd * cell.corner_len[k]);
        if !toward {
            return false;
        }
        // |k × w| ≤ |k|·|w| bounds the origin-radius term, so most corners are decided
        // without its square root: yes when the plane part alone passes, no when even the
        // largest radius term cannot make it pass.
        (0..3).all(|e| {
            let (g, k) = (self.g[e], self.k[e]);
            let mut unsure = false;
            for (w, wl) in cell.corners.iter().zip(cell.corner_len) {
                let lhs = g.dot(*w);
                let rhs = -sd * wl * (self.g_len[e] + self.r * self.k_len[e]);
                if lhs >= rhs {
                    return true;
                }
                unsure |= lhs + self.r * self.k_len[e] * wl * (1.0 + 1e-12) >= rhs;
            }
            unsure
                && cell.corners.iter().zip(cell.corner_len).any(|(w, wl)| {
                    g.dot(*w) + self.r * k.cross(*w).length()
                        >= -sd * wl * (self.g_len[e] + self.r * self.k_len[e])
                })
        })
    }

    /// Lower bound on the distance to the triangle's plane along directions within δ
    /// of the cell: `(h − r) / max(w·n)` over the cell.
    pub fn plane_dmin(&self, cell: &CellCone) -> f64 {
        // cos(max(0, ang − b)) with ang = angle(toward, m), b = β + δ, without an acos:
        // cos(ang − b) = cos ang·cos b + sin ang·sin b where ang > b, else 1. Raised by
        // 1e-12 against rounding: a larger cosine only lowers the bound.
        let ca = self.toward.dot(cell.m).clamp(-1.0, 1.0);
        let sa = (1.0 - ca * ca).max(0.0).sqrt();
        let cb = cell.cos_b * self.cos_d - cell.sin_b * self.sin_d;
        let sb = cell.sin_b * self.cos_d + cell.cos_b * self.sin_d;
        let cos_max = if sb >= 0.0 && ca < cb { ((ca * cb + sa * sb) * (1.0 + 1e-12)).min(1.0) } else { 1.0 };
        if cos_max > 1e-9 {
            (self.h - self.r) / cos_max
        } else {
            self.h - self.r
        }
    }

    /// When every ray from the sphere with a direction within `delta` of the cell hits the
    /// triangle, an upper bound on the hit distance.
    pub fn covers(&self, cell: &CellCone) -> Option<f64> {
        let sd = self.sin_d;
        for e in 0..3 {
            for (w, wl) in cell.corners.iter().zip(cell.corner_len) {
                let plane = self.g[e].dot(*w) - sd * wl * (self.g_len[e] + self.r * self.k_len[e]);
                if !(plane > 0.0) {
                    return None;
                }
                // The radius term's square root only when its bound |k|·|w| is not enough.
                if plane > self.r * self.k_len[e] * wl * (1.0 + 1e-12) {
                    continue;
                }
                if !(plane - self.r * self.k[e].cross(*w).length() > 0.0) {
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
        Some(ArcBound { e0, e1, n, cos_t: theta.cos(), sin_t: theta.sin() })
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
        // β > θ
        if cell.cos_b < self.cos_t {
            return false;
        }
        // cos(θ − β) = cosθ·cosβ + sinθ·sinβ
        self.cos_dist(cell.m) >= self.cos_t * cell.cos_b + self.sin_t * cell.sin_b
    }

    /// True when the widened bound meets the cell (angle(m, arc) ≤ θ + β).
    pub fn meets(&self, cell: &CellCone) -> bool {
        // θ + β ≥ π, as cosines: cos β ≤ cos(π − θ).
        if cell.cos_b <= -self.cos_t {
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
    use crate::coherence::cells::{cell_cone, edge_coord, face_dir};
    use crate::coherence::cube::cube_face_cell;
    use crate::coherence::testutil::{rng, unit};

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
            let Some(te) = TriEdges::new(c, r, &v, 0.0, 1e-6) else { continue };
            for _ in 0..50 {
                let p = c + unit(&mut s) * r * rng(&mut s).sqrt();
                let (a, b) = (rng(&mut s), rng(&mut s));
                let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                let q = v[0] + a * (v[1] - v[0]) + b * (v[2] - v[0]);
                let w = (q - p).normalize();
                let [face, iu, iv] = cube_face_cell(w.as_vec3(), n);
                let cell = cell_cone(face as usize, iu, iv, n);
                assert!(te.meets(&cell), "edge bound missed a hitting direction");
            }
            // Covered cells: rays from sampled origin points through sampled cell directions hit.
            for face in 0..6 {
                for iv in 0..n {
                    for iu in 0..n {
                        let cell = cell_cone(face, iu, iv, n);
                        if let Some(t_far) = te.covers(&cell) {
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

    /// The square-root shortcuts of `meets` and `covers` decide as the full edge formula
    /// does (the bound |k × w| ≤ |k|·|w| only skips work), for origins with a radius.
    #[test]
    fn edge_shortcuts_agree_with_the_full_formula() {
        let mut s = 4242u64;
        let n = 12;
        let (mut met, mut covered) = (0, 0);
        for _ in 0..400 {
            let c = unit(&mut s) * 0.3;
            let r = rng(&mut s) * 0.2;
            let base = unit(&mut s) * (1.0 + rng(&mut s));
            let v = [base, base + unit(&mut s) * 3.0, base + unit(&mut s) * 3.0];
            let Some(te) = TriEdges::new(c, r, &v, 0.0, 1e-3) else { continue };
            let sd = te.sin_d;
            for face in 0..6 {
                for iv in 0..n {
                    for iu in 0..n {
                        let cell = cell_cone(face, iu, iv, n);
                        let corners = cell.corners.iter().zip(cell.corner_len);
                        let toward = corners.clone().any(|(w, wl)| te.toward.dot(*w) >= -sd * wl);
                        let full_meets = toward
                            && (0..3).all(|e| {
                                corners.clone().any(|(w, wl)| {
                                    te.g[e].dot(*w) + te.r * te.k[e].cross(*w).length()
                                        >= -sd * wl * (te.g_len[e] + te.r * te.k_len[e])
                                })
                            });
                        let full_inside = (0..3).all(|e| {
                            corners.clone().all(|(w, wl)| {
                                te.g[e].dot(*w)
                                    - te.r * te.k[e].cross(*w).length()
                                    - sd * wl * (te.g_len[e] + te.r * te.k_len[e])
                                    > 0.0
                            })
                        });
                        let min_cos =
                            cell.corners.iter().map(|w| te.toward.dot(w.normalize())).fold(1.0, f64::min)
                                - sd;
                        let full_covers = full_inside && min_cos > 1e-6;
                        assert_eq!(te.meets(&cell), full_meets);
                        assert_eq!(te.covers(&cell).is_some(), full_covers);
                        met += full_meets as u32;
                        covered += te.covers(&cell).is_some() as u32;
                    }
                }
            }
        }
        assert!(met > 1000 && covered > 50, "too few cases: {met} met, {covered} covered");
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
                let [face, iu, iv] = cube_face_cell(w.as_vec3(), n);
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
