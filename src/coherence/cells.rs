//! Direction-cube cells in f64: each cell's bounding cone, cones of directions, and the cell
//! tests (Test A to build, exact Test B to validate), for the builder to rasterise bounds.
//!
//! Conventions (shared with the lookup, [`super::cube::cube_face_cell`]): face `f = 2·ax + neg`; on that
//! face a direction is `w[ax] = ±1, w[(ax+1)%3] = u, w[(ax+2)%3] = v` (unnormalised), and cell
//! `(iu, iv)` spans `u ∈ [−1 + 2·iu/n, −1 + 2·(iu+1)/n]`, `v` likewise. The gnomonic projection
//! maps great circles to lines, so a cell is a convex spherical quadrilateral.
//!
//! Every test is conservative in the direction that keeps rendering exact: "meets" may say yes
//! for a cell the object cannot be seen through (costs time), never no for one it can;
//! "contains" may say no for a cell inside the cone, never yes for one that is not.

// `!(a > b)` is deliberate: a NaN must fail these tests, not pass them.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::DVec3;

/// A unit vector along axis `ax` of face `face`, and the two in-face axes, as world vectors:
/// `dir(u, v) = s·e[ax] + u·e[i1] + v·e[i2]`.
#[inline]
pub fn face_dir(face: usize, u: f64, v: f64) -> DVec3 {
    let s = if face % 2 == 1 { -1.0 } else { 1.0 };
    // A match rather than indexing an array by `ax`: this runs for every block a bound is
    // rasterised into.
    match face / 2 {
        0 => DVec3::new(s, u, v),
        1 => DVec3::new(v, s, u),
        _ => DVec3::new(u, v, s),
    }
}

/// The `u` (or `v`) coordinate of cell boundary `k` on an `n`-cell face.
#[inline]
pub fn edge_coord(k: u32, n: u32) -> f64 {
    -1.0 + 2.0 * k as f64 / n as f64
}

/// A cell's bounding cone: unit centre direction and the cosine/sine of the largest angle β
/// to its corners. Also the four corners, unnormalised (on the face plane), and their lengths.
#[derive(Clone, Copy, Debug)]
pub struct CellCone {
    pub m: DVec3,
    pub cos_b: f64,
    pub sin_b: f64,
    pub corners: [DVec3; 4],
    pub corner_len: [f64; 4],
}

impl CellCone {
    /// Half-angle β of the bounding cone. Computed when asked (an `acos`): the cell tests
    /// compare cosines instead.
    pub fn beta(&self) -> f64 {
        self.cos_b.acos()
    }
}

/// Computes the geometry of cell `(iu, iv)` on `face` of an `n`-cube.
pub fn cell_cone(face: usize, iu: u32, iv: u32, n: u32) -> CellCone {
    region_cone(face, [iu, iv, iu, iv], n)
}

/// The same for the block of cells `iu0..=iu1` × `iv0..=iv1` (`r = [iu0, iv0, iu1, iv1]`):
/// a gnomonic rectangle is a convex spherical quadrilateral, so every test written for a
/// cell holds for a block.
pub fn region_cone(face: usize, r: [u32; 4], n: u32) -> CellCone {
    region_cone_with(face, r, n, None)
}

/// [`region_cone`], with the corners' lengths (corners `(u0, v0)`, `(u1, v0)`, `(u1, v1)`,
/// `(u0, v1)`) from a caller's table when given: they must equal `face_dir(..).length()`.
#[inline]
pub fn region_cone_with(face: usize, r: [u32; 4], n: u32, lens: Option<[f64; 4]>) -> CellCone {
    let (u0, u1) = (edge_coord(r[0], n), edge_coord(r[2] + 1, n));
    let (v0, v1) = (edge_coord(r[1], n), edge_coord(r[3] + 1, n));
    let m = face_dir(face, 0.5 * (u0 + u1), 0.5 * (v0 + v1)).normalize();
    let corners = region_corners(face, r, n);
    let corner_len = lens.unwrap_or_else(|| corners.map(|c| c.length()));
    let cos_b = (0..4).map(|k| m.dot(corners[k]) / corner_len[k]).fold(1.0, f64::min).clamp(-1.0, 1.0);
    CellCone { m, cos_b, sin_b: (1.0 - cos_b * cos_b).max(0.0).sqrt(), corners, corner_len }
}

/// The corners `(u0, v0)`, `(u1, v0)`, `(u1, v1)`, `(u0, v1)` of the block of cells
/// `r = [iu0, iv0, iu1, iv1]`, unnormalised (on the face plane).
#[inline]
pub fn region_corners(face: usize, r: [u32; 4], n: u32) -> [DVec3; 4] {
    let (u0, u1) = (edge_coord(r[0], n), edge_coord(r[2] + 1, n));
    let (v0, v1) = (edge_coord(r[1], n), edge_coord(r[3] + 1, n));
    [face_dir(face, u0, v0), face_dir(face, u1, v0), face_dir(face, u1, v1), face_dir(face, u0, v1)]
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
        self.meets_axis(cell.m, cell.cos_b, cell.sin_b)
    }

    /// Test A for a cell given by its cone alone: centre `m` and the cosine and sine of β
    /// (the test reads nothing else, so a caller need not compute the corners).
    #[inline]
    pub fn meets_axis(&self, m: DVec3, cos_b: f64, sin_b: f64) -> bool {
        // θ + β ≥ π, as cosines: cos β ≤ cos(π − θ).
        if cos_b <= -self.cos_t {
            return true;
        }
        // cos(θ + β) = cosθ·cosβ − sinθ·sinβ
        self.axis.dot(m) >= self.cos_t * cos_b - self.sin_t * sin_b
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
        // The face's pyramid is where s·w[ax] ≥ |w[i1]|, |w[i2]|: a unit direction in it has
        // s·w[ax] ≥ 1/√3. A cap that stays below misses the face (with a margin far above
        // rounding: the lookup's f32 directions are within δ of the cap, inside it here).
        if k_hi < PYRAMID_MIN {
            return None;
        }
        // The ratios over the cap's directions in the pyramid, where s·w[ax] ≥ 1/√3 even when
        // the cap reaches the plane w[ax] = 0.
        let k_lo = k_lo.max(PYRAMID_MIN);
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

/// The smallest `s·w[ax]` of a unit direction in face `f`'s pyramid is 1/√3; less a margin.
const PYRAMID_MIN: f64 = 0.577_350_269_189_625_8 - 1e-6;

/// The cell index range `[lo, hi]` (inclusive) covering coordinates `[a, b]`, widened by
/// [`SPAN_SLACK`] of a cell on each side, so that a bound ending on a cell boundary keeps the
/// cells on both sides. The rectangles spanned are already conservative in f64 for caps
/// widened by δ, which covers the f32 lookup; the slack covers only the rounding of this
/// product. (It was a whole cell: a target under a cell then tested 9–16 cells to emit 1–4.)
#[inline]
pub fn cell_span(a: f64, b: f64, n: u32) -> (u32, u32) {
    let nf = n as f64;
    let lo = ((a + 1.0) * 0.5 * nf - SPAN_SLACK).floor().clamp(0.0, nf - 1.0) as u32;
    let hi = ((b + 1.0) * 0.5 * nf + SPAN_SLACK).floor().clamp(0.0, nf - 1.0) as u32;
    (lo, hi)
}

/// How far past a rectangle [`cell_span`] reaches, in cells.
pub const SPAN_SLACK: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coherence::testutil::{rng, unit};

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

    /// A cap that stays out of a face's pyramid gets no rectangle there, though it reaches
    /// past the plane 90° from the face's centre; one that enters it gets a rectangle inside
    /// the face, not the whole face.
    #[test]
    fn face_rect_of_caps_beside_a_face() {
        // 8° around +y: out of the +x and −x pyramids, though w[x] takes both signs.
        let side = Cone::new(DVec3::Y, 0.14);
        assert!(side.face_rect(0).is_none() && side.face_rect(1).is_none());
        assert!(side.face_rect(2).is_some());
        // 60° around +y reaches into +x's pyramid along its +u edge only.
        let wide = Cone::new(DVec3::Y, 1.05);
        let r = wide.face_rect(0).expect("the cap enters +x's pyramid");
        assert!(r[1] == 1.0 && r[0] > 0.3, "{r:?}");
    }

    /// Caps smaller than a cell, up to a few cells, anywhere on the cube (at cell boundaries
    /// and cube edges too): every direction sampled in the cap, and every cell near the span
    /// that the cap meets exactly, lies in the spans of the face rectangles.
    #[test]
    fn spans_hold_small_caps() {
        let mut s = 0x6a09e667u64;
        for round in 0..3000 {
            let n = [7, 64, 339, 1024, 16384][round % 5];
            let cell = 2.0 / n as f64;
            let mut axis = unit(&mut s);
            if round % 3 == 0 {
                // On a cell boundary line of some face, or on a cube edge.
                let i = (rng(&mut s) * 3.0) as usize % 3;
                let m = axis.abs().max_element();
                let k = ((axis[(i + 1) % 3] / m + 1.0) / cell).round();
                axis[(i + 1) % 3] = (-1.0 + k * cell) * m;
                if round % 9 == 0 {
                    axis[(i + 2) % 3] = axis[i].abs().copysign(axis[(i + 2) % 3]);
                }
                axis = axis.normalize();
            }
            let cone = Cone::new(axis, rng(&mut s) * 3.0 * cell + 1e-9);
            let rects: Vec<_> = (0..6).map(|f| cone.face_rect(f)).collect();
            let in_span = |f: usize, iu: u32, iv: u32| {
                rects[f].is_some_and(|r| {
                    let (lu, hu) = cell_span(r[0], r[1], n);
                    let (lv, hv) = cell_span(r[2], r[3], n);
                    lu <= iu && iu <= hu && lv <= iv && iv <= hv
                })
            };
            for _ in 0..20 {
                // A direction in the cap, and every cell whose closed square holds it.
                let t = cone.theta * rng(&mut s).sqrt();
                let side = cone.axis.any_orthonormal_vector().rotate_axis(cone.axis, rng(&mut s) * 6.3);
                let w = cone.axis * t.cos() + side * t.sin();
                for f in 0..6 {
                    let (ax, sg) = (f / 2, if f % 2 == 1 { -1.0 } else { 1.0 });
                    let m = sg * w[ax];
                    if m <= 0.0 || m < w[(ax + 1) % 3].abs() || m < w[(ax + 2) % 3].abs() {
                        continue;
                    }
                    let (u, v) = (w[(ax + 1) % 3] / m, w[(ax + 2) % 3] / m);
                    let (iu, iv) = (((u + 1.0) / cell).floor(), ((v + 1.0) / cell).floor());
                    let (iu, iv) =
                        (iu.clamp(0.0, n as f64 - 1.0) as u32, iv.clamp(0.0, n as f64 - 1.0) as u32);
                    assert!(in_span(f, iu, iv), "a direction of the cap lies outside the span (n {n})");
                }
            }
            for (f, r) in rects.iter().enumerate() {
                let Some(r) = r else { continue };
                let (lu, hu) = cell_span(r[0], r[1], n);
                let (lv, hv) = cell_span(r[2], r[3], n);
                for iv in lv.saturating_sub(2)..=(hv + 2).min(n - 1) {
                    for iu in lu.saturating_sub(2)..=(hu + 2).min(n - 1) {
                        if cone.meets_exact(&cell_cone(f, iu, iv, n)) {
                            assert!(
                                in_span(f, iu, iv),
                                "cell ({iu}, {iv}) of face {f} meets the cap (n {n})"
                            );
                        }
                    }
                }
            }
        }
    }

    /// Caps of every size up to nearly the whole sphere: every cell the cap meets lies in the
    /// span of the face's rectangle.
    #[test]
    fn face_rect_contains_cap_cells() {
        let mut s = 12345u64;
        let n = 16;
        for round in 0..600 {
            let cone = Cone::new(unit(&mut s), rng(&mut s) * if round % 2 == 0 { 1.5 } else { 3.1 });
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
}
