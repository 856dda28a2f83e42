//! What a table build may be told: the memory budget, the resolutions and clustering, the
//! spawn-offset policy the tables must be conservative for, and the effects they serve.

use super::groups::GROUP_MIN_LIST;
use crate::arith::spawn::{offset_bound, SpawnPolicy};
use crate::scene::{Effects, Scene};

/// Where shadow rays are looked up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShadowMode {
    /// Light-buffer style: each point or spot light has a table; a shadow ray is traced from
    /// the light toward the shaded point with `t_max = |P − L|·(1 − ε)`.
    LightBuffer,
    /// From the shaded point toward the light, through the beams: every primitive spawns
    /// rays that the beams classify.
    HitObject,
}

/// Build parameters. [`BuildParams::default`] is what `cuberay` uses.
#[derive(Clone, Debug)]
pub struct BuildParams {
    /// Total bytes the flattened tables should stay under (default 96 MiB): the beams stop
    /// subdividing when the eye's, the lights' and their own tables reach it. Each buffer
    /// also stays under wgpu's 128 MiB binding limit, or the build fails.
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
    /// The image size primary rays are made for: the eye table covers only that frustum.
    /// `None`: the scene's resolution, or the camera's default.
    pub image: Option<(u32, u32)>,
    pub shadow_mode: ShadowMode,
    /// Image pixels per eye cell, along one axis (default 2).
    pub eye_pixels_per_cell: f64,
    /// Cells a light's table aims for over the directions where objects are (default 2^18).
    pub light_cells: usize,
    /// Beam lists at least this long name primitive groups instead of their members
    /// (default [`GROUP_MIN_LIST`]; `usize::MAX`: never).
    pub group_min_list: usize,
    /// The deepest ray the render traces (the eye ray is depth 1; default 5): the pilot
    /// pass follows the ray trees that deep.
    pub max_depth: u32,
    /// About how many eye rays the pilot pass traces, on a lattice over the whole image
    /// (default 2^15; 0: no pilot, every beam keeps the roots' lists).
    pub pilot_rays: usize,
    /// The beams split until the pilot's rays test at most this many candidates on average
    /// (default 4).
    pub beam_target: f64,
    /// The effects the tables serve (`None`: the scene's): light tables only with shadows,
    /// beams for reflecting and transmitting surfaces only with reflection.
    pub effects: Option<Effects>,
    /// Whether rays leaving surfaces are classified into beams (`--accel beams`); without
    /// them (the default, `--accel cube`) such rays walk the BVH.
    pub beams: bool,
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
            image: None,
            shadow_mode: ShadowMode::LightBuffer,
            eye_pixels_per_cell: 2.0,
            light_cells: 1 << 18,
            group_min_list: GROUP_MIN_LIST,
            max_depth: 5,
            pilot_rays: 1 << 15,
            beam_target: 4.0,
            effects: None,
            beams: false,
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
