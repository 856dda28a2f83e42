//! The kernels' parameters ([`Params`], WGSL `Params` in `shaders/shared/layout.wgsl`): the one
//! module that writes their fields. A render's params are made in layers, each from what it
//! depends on:
//!
//! - the scene's part ([`Params::of_scene`]): the camera's frame for the image, the
//!   background, ambient light, counts, the spawn offset and the environment's frame;
//! - what the accelerators add: the tables' origins ([`Params::point_at_tables`]), the BVH
//!   ([`Params::set_bvh`]), whether rays leaving surfaces take the surface walk
//!   ([`Params::set_surface_walk`]), the f64 spawn offset ([`Params::set_f64_spawn`]);
//! - the job's part ([`Params::with_job`]): the grid, the region, the sample lattice, the
//!   depth; and an AOV pass's output ([`Params::set_aov`]);
//! - the queues' sizes the buffers were made with ([`Params::set_queues`]);
//! - per tile and per sample, on their way to the GPU ([`Params::for_tile`],
//!   [`Params::for_sample`]).
//!
//! The preview moves the camera ([`Params::with_camera_of`]) and traces coarse images
//! ([`Params::coarse`]) from the same layers.

use glam::DVec3;

use super::structs::{Params, AOV_DEPTH, AOV_ID, AOV_NORMAL};
use crate::arith::spawn::SpawnPolicy;
use crate::coherence::FlatTables;
use crate::job::RenderOptions;
use crate::output::Aov;
use crate::sampling::{self, Sampling};
use crate::scene::{Projection, Scene};

fn v3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

impl Params {
    /// The scene's part for a `width`×`height` image whose rays spawn under `spawn`: the
    /// camera's frame (positions are relative to the eye, which is the origin), the
    /// background and ambient light, the counts, the inline shadow budget and the
    /// environment's frame (its texels follow the materials' textures').
    pub fn of_scene(scene: &Scene, width: u32, height: u32, spawn: SpawnPolicy) -> Params {
        let cam = &scene.camera;
        // screen_offsets is affine in (x, y): its scale is the difference of unit steps.
        let (x0, _) = cam.screen_offsets(0.0, 0.0, width, height);
        let (x1, _) = cam.screen_offsets(1.0, 0.0, width, height);
        let (spawn_rel, spawn_abs) = spawn.rel_abs();
        let mut params = Params {
            cam_forward: v3(cam.forward),
            cam_scale: (x1 - x0) as f32,
            cam_right: v3(cam.right),
            half_w: width as f32 * 0.5,
            cam_up: v3(cam.up),
            half_h: height as f32 * 0.5,
            background: v3(scene.background),
            ortho: matches!(cam.projection, Projection::Orthographic { .. }) as u32,
            ambient: v3(scene.ambient),
            prim_count: scene.primitives.len() as u32,
            light_count: scene.lights.len() as u32,
            shadow_inline: super::budget::shadow_inline(scene),
            spawn_rel,
            spawn_abs,
            ..Params::default()
        };
        if let Some(env) = &scene.environment {
            params.env_texture = scene.textures.len() as u32 + 1;
            params.env_intensity = env.intensity as f32;
            params.env_x = v3(env.front);
            params.env_y = v3(env.up);
            params.env_z = v3(env.side());
        }
        params
    }

    /// The spawn offset scaled to f64's rounding, for the F64 kernel variant
    /// ([`SpawnPolicy::rel_abs_f64`]).
    pub fn set_f64_spawn(&mut self, spawn: SpawnPolicy) {
        (self.spawn_rel, self.spawn_abs) = spawn.rel_abs_f64();
    }

    /// The BVH of `node_count` nodes, whose inline shadow walks get `inline` loop iterations
    /// ([`super::budget::bvh_shadow_inline`]).
    pub fn set_bvh(&mut self, node_count: u32, inline: u32) {
        self.bvh_node_count = node_count;
        self.bvh_inline = inline;
    }

    /// Points the params at the tables' eye and fallback origins.
    pub fn point_at_tables(&mut self, flat: &FlatTables) {
        self.eye_origin = flat.eye_origin;
        self.fallback_origin = flat.fallback_origin;
    }

    /// Whether the tables send the rays leaving surfaces to the surface walk (the BVH's or
    /// ray queries').
    pub fn set_surface_walk(&mut self, on: bool) {
        self.surface_walk = on as u32;
    }

    /// The primitives in each binding they are split over (`SPLIT_PRIMS`); 0: one binding.
    pub fn set_prims_per_binding(&mut self, n: u32) {
        self.prims_per_binding = n;
    }

    /// The jobs each ray queue and each shadow queue of the buffers holds.
    pub fn set_queues(&mut self, ray_queue: u32, shadow_queue: u32) {
        self.ray_queue = ray_queue;
        self.shadow_queue = shadow_queue;
    }

    /// These params with what a render job sets: the grid of eye-ray points, the region it
    /// traces, the sample lattice and seed, the depth, and samples `0..spp`.
    pub fn with_job(self, opts: &RenderOptions) -> Params {
        let (grid_w, grid_h) = opts.grid();
        let win = opts.grid_region();
        Params {
            grid_w,
            grid_h,
            win_x: win.origin.0,
            win_y: win.origin.1,
            win_w: win.size.0,
            own_w: win.owned.0,
            own_h: win.owned.1,
            spp: opts.spp,
            lattice_g: if opts.spp > 1 { sampling::lattice_generator(opts.spp) } else { 1 },
            seed_hash: sampling::seed_hash(opts.seed),
            corners: (opts.sampling == Sampling::Corners) as u32,
            max_depth: opts.max_depth,
            sample_first: 0,
            sample_end: opts.spp,
            ..self
        }
    }

    /// What the `aov` kernel writes.
    pub fn set_aov(&mut self, aov: Aov) {
        self.aov = match aov {
            Aov::Depth => AOV_DEPTH,
            Aov::Normal => AOV_NORMAL,
            Aov::Id => AOV_ID,
        };
    }

    /// The ray trees' depth.
    pub fn set_max_depth(&mut self, max_depth: u32) {
        self.max_depth = max_depth;
    }

    /// These params for the tile of points `first..first + count`.
    pub fn for_tile(&self, first: u32, count: u32) -> Params {
        Params { first_point: first, point_count: count, ..*self }
    }

    /// These params for sample `sample` of the lattice alone (a preview pass).
    pub fn for_sample(&self, sample: u32) -> Params {
        Params { sample_first: sample, sample_end: sample + 1, ..*self }
    }

    /// These params with the eye-dependent parts of `moved` (freshly made for another
    /// camera): its camera frame, the tables' origins, the BVH and the surface walk.
    pub fn with_camera_of(&self, moved: &Params) -> Params {
        Params {
            cam_forward: moved.cam_forward,
            cam_scale: moved.cam_scale,
            cam_right: moved.cam_right,
            cam_up: moved.cam_up,
            half_w: moved.half_w,
            half_h: moved.half_h,
            ortho: moved.ortho,
            eye_origin: moved.eye_origin,
            fallback_origin: moved.fallback_origin,
            bvh_node_count: moved.bvh_node_count,
            bvh_inline: moved.bvh_inline,
            surface_walk: moved.surface_walk,
            ..*self
        }
    }

    /// The params of a coarse image with one eye ray per `block`×`block` pixels of the
    /// image these params are for, traced with `opts` (one sample at each point's centre,
    /// of a grid the size of the coarse image): grid point (i, j) takes the ray through the
    /// centre of pixel (i·b + b/2, j·b + b/2), the very ray (bit for bit: `block` is a
    /// power of two) of that pixel in a full pass with one sample at the pixel centres. The
    /// kernels place grid point i at i + 1/2, so the image's centre moves to (half − 1/2)/b
    /// and a grid step spans b pixels.
    pub fn coarse(&self, block: u32, opts: &RenderOptions) -> Params {
        let b = block as f32;
        let camera = Params {
            half_w: (self.half_w - 0.5) / b,
            half_h: (self.half_h - 0.5) / b,
            cam_scale: self.cam_scale * b,
            ..*self
        };
        camera.with_job(opts).for_sample(0)
    }
}
