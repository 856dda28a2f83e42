//! What a table build may be told: the resolutions, the spawn-offset policy the tables must
//! be conservative for, and the effects they serve.

use super::walk::OriginKey;
use crate::arith::spawn::{offset_bound, SpawnPolicy};
use crate::scene::{Effects, Scene};

/// Build parameters. [`BuildParams::default`] is what `cuberay` uses.
#[derive(Clone, Debug)]
pub struct BuildParams {
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
    /// The image size primary rays are made for: the eye table covers only that frustum.
    /// `None`: the scene's resolution, or the camera's default.
    pub image: Option<(u32, u32)>,
    /// Image pixels per eye cell, along one axis (default 2).
    pub eye_pixels_per_cell: f64,
    /// Cells a light's table aims for over the directions where objects are (default 2^18).
    pub light_cells: usize,
    /// The effects the tables serve (`None`: the scene's): light tables only with shadows.
    pub effects: Option<Effects>,
    /// Origins left without a table (`--accel auto` where one would not pay for its build):
    /// their rays walk what rays leaving surfaces walk (the BVH). Default: none.
    pub untabled: Vec<OriginKey>,
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            delta: 2e-5,
            spawn: SpawnPolicy::Scaled,
            spawn_offset: None,
            eye_n: None,
            light_n: None,
            image: None,
            eye_pixels_per_cell: 2.0,
            light_cells: 1 << 18,
            effects: None,
            untabled: Vec::new(),
        }
    }
}

impl BuildParams {
    /// The image size the eye table is built for.
    pub fn eye_image(&self, scene: &Scene) -> (u32, u32) {
        self.image.or(scene.resolution).unwrap_or_else(|| scene.camera.default_resolution())
    }

    /// Whether the origin `key` gets a table (if the scene calls for one).
    pub fn tables(&self, key: OriginKey) -> bool {
        !self.untabled.contains(&key)
    }

    /// The spawn offset the origins are inflated by.
    pub fn spawn_offset(&self, scene: &Scene) -> f64 {
        self.spawn_offset.unwrap_or_else(|| offset_bound(scene, self.spawn))
    }
}
