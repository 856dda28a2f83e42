//! The one spawn-offset model of the f32 kernels: a ray leaving a surface starts at the hit
//! point moved along the geometric normal, to the side the ray goes to, by
//! `scale·rel + abs`. The [`SpawnPolicy`] sets `rel` and `abs`; the default scales with the
//! magnitude of the numbers behind the hit point (`scale`, see
//! [`super::geometry::surface`]), so that scenes far from the origin get offsets as large as
//! their rounding and scenes near it offsets as small.
//!
//! The candidate tables are conservative only for the offsets they were built for: every
//! origin sphere is inflated by [`offset_bound`] of the render's policy. The WGSL twin is
//! `spawn_origin` in `shaders/shared/geometry.wgsl` (keep them in sync), reading `rel` and
//! `abs` from `Params::spawn_rel` and `Params::spawn_abs`. The f64 CPU reference has its own,
//! much smaller offset: it is the independent yardstick.

use glam::Vec3;

use super::geometry::Surface;
use crate::scene::{LightKind, Scene};

/// The relative offset of [`SpawnPolicy::Scaled`], `2⁻²¹`: 4 f32 ulps of the magnitude behind
/// the hit point, about pbrt-v4's worst-case bound on the rounding error of a point computed
/// from the primitive (`γ₇·Σ|bᵢpᵢ|` on a triangle, `γ₅·|p|` on a reprojected sphere).
///
/// Measured with `examples/self_hits` on the SPD canonical scenes (256², corners), acne (the
/// self-hits jump by orders of magnitude and the blocked shadow rays move with them) starts
/// at `2⁻²⁴` (mount_s6 816 self-hits, rings_s7 2,011): an 8× margin. Larger offsets only widen the zone where a neighbour that
/// touches the surface lies within the self-hit counter's reach, and leak light at contacts.
pub const SPAWN_OFFSET_REL: f32 = 1.0 / 2_097_152.0;

/// The relative offset of [`SpawnPolicy::Scaled`] in the F64 kernel variant, `2⁻⁵⁰`: the
/// same 4 ulps of the magnitude behind the hit point, of f64 (its primitives, hit points and
/// queued ray origins are f64 end to end, so nothing rounds them to f32).
pub const SPAWN_OFFSET_REL_F64: f32 = 1.0 / 1_125_899_906_842_624.0;

/// How far spawned rays start from their surface.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SpawnPolicy {
    /// [`SPAWN_OFFSET_REL`] times the magnitude of the numbers behind the hit point.
    #[default]
    Scaled,
    /// This fraction of the magnitude behind the hit point (`Scaled` is
    /// `Relative(SPAWN_OFFSET_REL)`): for sweeps of the offset.
    Relative(f32),
    /// The same distance everywhere (a scene-wide epsilon, as many renderers use).
    Fixed(f32),
}

impl SpawnPolicy {
    /// `(rel, abs)`: the offset is `scale·rel + abs`.
    pub fn rel_abs(self) -> (f32, f32) {
        match self {
            SpawnPolicy::Scaled => (SPAWN_OFFSET_REL, 0.0),
            SpawnPolicy::Relative(r) => (r, 0.0),
            SpawnPolicy::Fixed(e) => (0.0, e),
        }
    }

    /// [`SpawnPolicy::rel_abs`] for the F64 kernel variant: `Scaled` takes
    /// [`SPAWN_OFFSET_REL_F64`]; an offset the user set stays as set.
    pub fn rel_abs_f64(self) -> (f32, f32) {
        match self {
            SpawnPolicy::Scaled => (SPAWN_OFFSET_REL_F64, 0.0),
            other => other.rel_abs(),
        }
    }
}

/// The origin of a ray leaving surface `s` towards `dir` under `policy`.
pub fn spawn_origin(s: &Surface, dir: Vec3, policy: SpawnPolicy) -> Vec3 {
    let side = if dir.dot(s.ng) >= 0.0 { s.ng } else { -s.ng };
    s.p + side * spawn_offset(s, policy)
}

/// How far [`spawn_origin`] moves a ray's origin off surface `s` under `policy`.
pub fn spawn_offset(s: &Surface, policy: SpawnPolicy) -> f32 {
    let (rel, abs) = policy.rel_abs();
    s.scale * rel + abs
}

/// The largest coordinate magnitude of the scene re-centred on the camera: its bounds and
/// its positional lights.
pub fn recentred_magnitude(scene: &Scene) -> f64 {
    let eye = scene.camera.eye;
    let b = scene.bounds();
    let mut m: f64 = 0.0;
    if !b.is_empty() {
        m = m.max((b.min - eye).abs().max_element()).max((b.max - eye).abs().max_element());
    }
    for l in &scene.lights {
        if l.kind != LightKind::Directional {
            m = m.max((l.position - eye).abs().max_element());
        }
    }
    m
}

/// The largest distance [`spawn_origin`] moves a hit point of `scene` re-centred on the
/// camera, plus f32 rounding of the geometry: what every origin sphere of the tables is
/// inflated by.
///
/// A hit's `scale` is the magnitude of its point and of its primitive's defining points
/// ([`super::geometry::surface`]), all inside the scene's bounds, so it is at most the
/// [`recentred_magnitude`] `M` (the 1% covers rounding).
pub fn offset_bound(scene: &Scene, policy: SpawnPolicy) -> f64 {
    let m = recentred_magnitude(scene);
    let (rel, abs) = policy.rel_abs();
    let spawn = (m * rel as f64 + abs as f64) * 1.01;
    spawn + 8.0 * m * f32::EPSILON as f64
}
