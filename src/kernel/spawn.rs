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

/// The relative offset of [`SpawnPolicy::Scaled`], `2⁻¹⁶`: about 128 f32 rounding units of
/// the magnitude behind the hit point.
pub const SPAWN_OFFSET_REL: f32 = 1.0 / 65536.0;

/// How far spawned rays start from their surface.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SpawnPolicy {
    /// [`SPAWN_OFFSET_REL`] times the magnitude of the numbers behind the hit point.
    #[default]
    Scaled,
    /// The same distance everywhere (a scene-wide epsilon, as many renderers use).
    Fixed(f32),
}

impl SpawnPolicy {
    /// `(rel, abs)`: the offset is `scale·rel + abs`.
    pub fn rel_abs(self) -> (f32, f32) {
        match self {
            SpawnPolicy::Scaled => (SPAWN_OFFSET_REL, 0.0),
            SpawnPolicy::Fixed(e) => (0.0, e),
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

/// The largest distance [`spawn_origin`] moves a hit point in a `width`×`height` render of
/// `scene` re-centred on the camera, plus f32 rounding of the geometry: what every origin
/// sphere of the tables is inflated by.
///
/// With every coordinate that matters (scene bounds, positional lights, the corners of an
/// orthographic camera's image plane) at most `M` in magnitude, a ray starts within `M` of
/// the eye (|o|∞ ≤ M) and travels at most `2·√3·M` to its hit, so `scale ≤ (1 + 2√3)·M`.
pub fn offset_bound(scene: &Scene, width: u32, height: u32, policy: SpawnPolicy) -> f64 {
    let eye = scene.camera.eye;
    let mut m = recentred_magnitude(scene);
    let (w, h) = (width as f64, height as f64);
    for (x, y) in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)] {
        m = m.max((scene.camera.ray(x, y, width, height).0 - eye).abs().max_element());
    }
    let (rel, abs) = policy.rel_abs();
    let spawn = ((1.0 + 2.0 * 3f64.sqrt()) * m * rel as f64 + abs as f64) * 1.01;
    spawn + 8.0 * m * f32::EPSILON as f64
}
