//! What a table build may be told: the memory budget, the resolutions and clustering, the
//! spawn-offset policy the tables must be conservative for, and the effects they serve.

use super::groups::GROUP_MIN_LIST;
use crate::kernel::spawn::{offset_bound, SpawnPolicy};
use crate::scene::{Effects, Scene};

/// Where shadow rays are looked up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShadowMode {
    /// Light-buffer style: each point or spot light has a table; a shadow ray is traced from
    /// the light toward the shaded point with `t_max = |P − L|·(1 − ε)`.
    LightBuffer,
    /// From the hit object's table toward the light: every primitive belongs to a surface
    /// origin.
    HitObject,
}

/// Build parameters. [`BuildParams::default`] is what `cuberay` uses.
#[derive(Clone, Debug)]
pub struct BuildParams {
    /// Total bytes the flattened tables should stay under; the builder picks the surface
    /// resolution and cluster size to fit (default 96 MiB: three quarters of the 128 MiB
    /// target, leaving room for the error of the sampled estimate). Each buffer also stays
    /// under wgpu's 128 MiB binding limit, or the build fails.
    pub budget_bytes: usize,
    /// Angular widening of every bound, radians (default 2e-5): covers the f32 cell lookup.
    pub delta: f64,
    /// How far the kernels move spawned rays off their surfaces: the tables are
    /// conservative for this policy's offsets (default [`SpawnPolicy::Scaled`]).
    pub spawn: SpawnPolicy,
    /// Largest distance between a ray origin and the surface point it leaves from (the
    /// spawn offset) plus f32 rounding of the geometry, which inflates every origin. `None`:
    /// [`offset_bound`] of `spawn` for the image.
    pub spawn_offset: Option<f64>,
    /// Cells per face edge for the eye; `None`: about two image pixels per cell.
    pub eye_n: Option<u32>,
    /// Cells per face edge for lights; `None`: from `light_cells`.
    pub light_n: Option<u32>,
    /// Cells per face edge for surface origins; `None`: chosen by the budget.
    pub surface_n: Option<u32>,
    /// Primitives per surface origin cluster; `None`: chosen by the budget.
    pub cluster_size: Option<usize>,
    /// The image size primary rays are made for: the eye table covers only that frustum.
    /// `None`: the scene's resolution, or the camera's default.
    pub image: Option<(u32, u32)>,
    pub shadow_mode: ShadowMode,
    /// A target meeting at least this fraction of a surface origin's cells goes to its
    /// always-test list (default 0.6).
    pub always_fraction: f64,
    /// Image pixels per eye cell, along one axis (default 2).
    pub eye_pixels_per_cell: f64,
    /// Cells a light's table aims for over the directions where objects are (default 2^18).
    pub light_cells: usize,
    /// Limit on surface origins × primitives, which bounds the build time: the cluster size
    /// grows until the product fits (default 3·10^6).
    pub pair_budget: usize,
    /// Surface-origin candidate lists at least this long name primitive groups instead of
    /// their members (default [`GROUP_MIN_LIST`]; `usize::MAX`: never).
    pub group_min_list: usize,
    /// The effects the tables serve (`None`: the scene's): light tables only with shadows,
    /// tables for reflecting and transmitting surfaces only with reflection.
    pub effects: Option<Effects>,
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            budget_bytes: 96 << 20,
            delta: 2e-5,
            spawn: SpawnPolicy::Scaled,
            spawn_offset: None,
            eye_n: None,
            light_n: None,
            surface_n: None,
            cluster_size: None,
            image: None,
            shadow_mode: ShadowMode::LightBuffer,
            always_fraction: 0.6,
            eye_pixels_per_cell: 2.0,
            light_cells: 1 << 18,
            pair_budget: 3_000_000,
            group_min_list: GROUP_MIN_LIST,
            effects: None,
        }
    }
}

impl BuildParams {
    /// The image size the eye table is built for.
    pub fn eye_image(&self, scene: &Scene) -> (u32, u32) {
        self.image.or(scene.resolution).unwrap_or_else(|| scene.camera.default_resolution())
    }

    /// The spawn offset the origins are inflated by.
    pub fn spawn_offset(&self, scene: &Scene) -> f64 {
        self.spawn_offset.unwrap_or_else(|| offset_bound(scene, self.spawn))
    }
}
