//! Surface patches: a large, well-shaped reflecting or transmitting triangle (an SPD ground
//! polygon under a mirror finish) is split by a barycentric grid into patches, each an origin
//! of its own, and a ray's origin point picks its patch ([`triangle_patch`], the same lookup
//! as the WGSL's `triangle_patch` in `shaders/shared/tables.wgsl`; keep them in sync).

use glam::{DVec3, Vec3};

use super::targets::{Shape, Target};

/// A surface patch is about this many times the median target radius across.
const PATCH_SCALE: f64 = 4.0;
/// At most `m×m` patches per triangle.
const MAX_PATCH_SIDE: u32 = 16;
/// At most this many patch origins in a scene.
const MAX_PATCHES: u32 = 1024;

/// How many patches per side each primitive's origin is split into (1: not split).
///
/// A large reflecting or transmitting triangle (an SPD ground polygon under a mirror finish)
/// is a poor origin: its bounding sphere holds the objects standing on it, so they would be
/// candidates with `d_min = 0` in every cell. Such a triangle is split by a barycentric grid
/// into patches about `PATCH_SCALE` median target radii across, each an origin of its own.
pub fn patch_counts(surface_ids: &[u32], targets: &[Target]) -> Vec<u32> {
    let mut m = vec![1u32; targets.len()];
    if targets.is_empty() {
        return m;
    }
    let mut radii: Vec<f64> = targets.iter().map(|t| t.radius).collect();
    let mid = radii.len() / 2;
    let (_, median, _) = radii.select_nth_unstable_by(mid, f64::total_cmp);
    let unit = PATCH_SCALE * *median;
    if unit.is_nan() || unit <= 0.0 {
        return m;
    }
    let mut total = 0u64;
    for &id in surface_ids {
        let t = &targets[id as usize];
        let Shape::Triangle { v } = t.shape else { continue };
        // Well-shaped triangles only (no angle under 30° at v[0], the corner the barycentric
        // grid spans): a sliver's patches would be slivers too.
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let (l1, l2) = (e1.length_squared(), e2.length_squared());
        let den = l1 * l2 - e1.dot(e2).powi(2);
        if den.is_nan() || den < 0.25 * l1 * l2 {
            continue;
        }
        // Size by area: a patch is about `unit` across.
        let size = (0.5 * den.sqrt()).sqrt();
        let side = (size / unit).ceil().clamp(1.0, MAX_PATCH_SIDE as f64) as u32;
        m[id as usize] = side;
        total += (side * side) as u64;
    }
    if total > MAX_PATCHES as u64 {
        // Scale every side down alike.
        let k = (MAX_PATCHES as f64 / total as f64).sqrt();
        for x in m.iter_mut().filter(|x| **x > 1) {
            *x = ((*x as f64 * k).floor() as u32).max(1);
        }
    }
    m
}

/// The point of triangle `v` at barycentrics `(b1, b2)` (weights of `v[1]`, `v[2]`).
fn barycentric_point(v: &[DVec3; 3], b1: f64, b2: f64) -> DVec3 {
    v[0] + (v[1] - v[0]) * b1 + (v[2] - v[0]) * b2
}

/// Bounding sphere of patch `(i, j)` of the `m×m` barycentric grid: the square
/// `b1 ∈ [i/m, (i+1)/m] × b2 ∈ [j/m, (j+1)/m]`, which holds every point the lookup
/// [`triangle_patch`] assigns to the patch (it may reach past the hypotenuse).
pub fn patch_sphere(v: &[DVec3; 3], m: u32, i: u32, j: u32) -> (DVec3, f64) {
    let s = 1.0 / m as f64;
    let (b1, b2) = (i as f64 * s, j as f64 * s);
    let corners =
        [(b1, b2), (b1 + s, b2), (b1, b2 + s), (b1 + s, b2 + s)].map(|(a, b)| barycentric_point(v, a, b));
    let c = corners.iter().copied().sum::<DVec3>() / 4.0;
    let r = corners.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
    (c, r)
}

/// How far an f32 barycentric lookup may misplace a point of triangle `v` (its rounding,
/// relative to the coordinates' magnitude and the triangle's size), with a wide margin.
pub fn patch_rounding(v: &[DVec3; 3]) -> f64 {
    let mag = v.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max);
    let edge = (0..3).map(|k| (v[(k + 1) % 3] - v[k]).length()).fold(0.0, f64::max);
    1e-5 * (mag + edge)
}

/// The surface patch of triangle `v` (split into an `m×m` barycentric grid) holding point
/// `at` (a ray origin on or just off the triangle, f32 and camera-relative as on the GPU):
/// `j·m + i` for the grid square `b1 ∈ [i/m, (i+1)/m)`, `b2 ∈ [j/m, (j+1)/m)`, clamped into
/// the triangle's squares (`i + j < m`). Rounding may put a point near a square's edge into
/// its neighbour; [`patch_rounding`] inflates each patch's origin sphere for that.
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
