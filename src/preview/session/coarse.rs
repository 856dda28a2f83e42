//! The coarse image of a moving camera: one eye ray per block of pixels, traced whole in one
//! frame into an accumulation of its own, its block and depth adapted to [`COARSE_TARGET`];
//! and what the window shows, that image or the full accumulation.

use std::time::{Duration, Instant};

use super::accumulate::{accumulation, step_tile};
use super::{variant, Session, STEP_TARGET};
use crate::error::Result;
use crate::gpu::schedule::{Pacing, Schedule, WavePlan};
use crate::job::{grid_image, RenderOptions};
use crate::layout::budget::{retry_passes, MAX_DEPTH};
use crate::layout::Params;
use crate::output::Image;
use crate::sampling::Sampling;

/// The time a moving camera's coarse image should take; its block grows or shrinks towards
/// it.
pub const COARSE_TARGET: Duration = Duration::from_millis(20);
/// Pixels per coarse block edge: the first, and the range it adapts in.
const FIRST_BLOCK: u32 = 8;
const MIN_BLOCK: u32 = 2;
const MAX_BLOCK: u32 = 32;

/// The coarse image of a moving camera: one eye ray per `block`×`block` pixels, traced whole
/// in one frame into an accumulation of its own.
pub(super) struct Coarse {
    /// The block and the depth the next coarse image takes.
    block: u32,
    depth: u32,
    /// The last time of a coarse image at each depth with this block.
    depth_took: [Option<Duration>; MAX_DEPTH as usize + 1],
    /// The block, grid and schedule of the image in `accum`.
    traced: u32,
    grid: (u32, u32),
    schedule: Schedule,
    accum: wgpu::Buffer,
    /// Whether `accum` holds a complete image of the current camera.
    pub(super) complete: bool,
}

/// What the window shows (`Session::shown`): an accumulation, its grid width, samples per
/// point, pixels per block edge, and whether it holds pixel corners.
pub struct Shown<'a> {
    pub buffer: &'a wgpu::Buffer,
    pub grid_w: u32,
    pub samples: u32,
    pub block: u32,
    pub corners: bool,
}

impl Session {
    /// Traces the coarse image of the current camera, one eye ray per block of pixels, to
    /// its end (a moving camera's frame: it shows the whole view at once, and the full image
    /// starts again when the camera rests). The block, and where even the largest block
    /// takes too long the depth, adapt to keep such a pass within [`COARSE_TARGET`].
    /// Returns the block and the depth traced.
    pub fn trace_coarse(&mut self) -> Result<(u32, u32)> {
        let start = Instant::now();
        let block = self.coarse.as_ref().map_or(FIRST_BLOCK, |c| c.block);
        let depth = self.coarse.as_ref().map_or(self.opts.max_depth, |c| c.depth).min(self.opts.max_depth);
        let (mut params, grid) = self.coarse_params(block);
        params.set_max_depth(depth);
        let ctx = &self.gpu.ctx;
        let plan = WavePlan::new(
            variant(&self.scene, &self.opts, self.toggles, self.opts.max_depth, self.accel),
            depth,
            retry_passes(&self.scene, self.walks.as_ref()),
            self.opts.form,
        );
        if self.coarse.as_ref().is_none_or(|c| c.grid != grid) {
            let (w, h) = (self.opts.width, self.opts.height);
            let capacity = (w.div_ceil(MIN_BLOCK) + 1) as u64 * (h.div_ceil(MIN_BLOCK) + 1) as u64;
            let accum = match self.coarse.take() {
                Some(c) => c.accum,
                None => accumulation(ctx, "preview coarse accumulation", capacity)?,
            };
            let total = grid.0 as u64 * grid.1 as u64;
            let schedule = Schedule::new(
                ctx,
                total,
                self.buffers.tile,
                Some(plan),
                Pacing::Adaptive { target: STEP_TARGET },
                false,
            );
            self.coarse = Some(Coarse {
                block,
                depth,
                depth_took: Default::default(),
                traced: block,
                grid,
                schedule,
                accum,
                complete: false,
            });
        }
        let c = self.coarse.as_mut().expect("made above");
        // The depth, the effects or the queries may have changed since the last image.
        c.schedule.set_plan(ctx, plan);
        let bind = self.accumulator.bind(ctx, &self.buffers, &c.accum);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&c.accum, 0, None);
        ctx.queue.submit([enc.finish()]);
        loop {
            crate::interrupt::check()?;
            let done = step_tile(
                ctx,
                &mut c.schedule,
                &self.pipelines,
                &self.buffers,
                &params,
                &self.accumulator,
                &bind,
                &mut self.points_traced,
            )?;
            if done {
                break;
            }
        }
        c.complete = true;
        c.traced = block;
        log::debug!(
            "coarse image: {block}x{block} blocks, depth {depth}, {:.1} ms, tiles run again so far {}",
            start.elapsed().as_secs_f64() * 1e3,
            c.schedule.tiles_run_again()
        );
        // A pass over 4× the points takes up to 4× as long, and a depth more can cost
        // several times one less (its rays leave surfaces and walk the BVH).
        // Each depth's last time at this block is kept, so that a depth found too slow is
        // not tried again (each try would be a slow frame).
        let took = start.elapsed();
        c.depth_took[depth as usize] = Some(took);
        let fast = |t: Option<Duration>| t.is_none_or(|t| t <= COARSE_TARGET);
        if took > COARSE_TARGET {
            // Far over (3× the target or more): a larger step, so that few frames are slow.
            let far = took > 3 * COARSE_TARGET;
            if block < MAX_BLOCK {
                c.block = (block * if far { 4 } else { 2 }).min(MAX_BLOCK);
                c.depth_took = Default::default();
            } else if depth > 1 {
                c.depth = if far { 1 } else { depth - 1 };
            }
        } else if took * 8 < COARSE_TARGET {
            // Well under: a deeper or finer pass may cost several times this one.
            if depth < self.opts.max_depth && fast(c.depth_took[depth as usize + 1]) {
                c.depth = depth + 1;
            } else if depth == self.opts.max_depth && block > MIN_BLOCK {
                c.block = block / 2;
                c.depth_took = Default::default();
            }
        }
        Ok((block, depth))
    }

    /// The params and grid of the coarse image with one eye ray per `block`×`block` pixels
    /// ([`Params::coarse`]).
    fn coarse_params(&self, block: u32) -> (Params, (u32, u32)) {
        let (w, h) = (self.opts.width, self.opts.height);
        let grid = (w.div_ceil(block), h.div_ceil(block));
        (self.base.coarse(block, &self.coarse_options(grid)), grid)
    }

    /// The options of a coarse image of `grid` points: one sample at each point's centre.
    fn coarse_options(&self, grid: (u32, u32)) -> RenderOptions {
        RenderOptions {
            width: grid.0,
            height: grid.1,
            spp: 1,
            sampling: Sampling::Pixels,
            ..self.opts.clone()
        }
    }

    /// What the window shows: the full accumulation once a pass of the current camera is
    /// in it, else the coarse image of the current camera, if there is one.
    pub fn shown(&self) -> Shown<'_> {
        if self.passes == 0 {
            if let Some(c) = self.coarse.as_ref().filter(|c| c.complete) {
                return Shown {
                    buffer: &c.accum,
                    grid_w: c.grid.0,
                    samples: 1,
                    block: c.traced,
                    corners: false,
                };
            }
        }
        Shown {
            buffer: &self.accum,
            grid_w: self.grid.0,
            samples: self.passes,
            block: 1,
            corners: self.opts.sampling == Sampling::Corners,
        }
    }

    /// The coarse image of the current camera as a linear image of `grid` size (tests).
    pub fn coarse_image(&self) -> Result<Option<Image>> {
        let Some(c) = self.coarse.as_ref().filter(|c| c.complete) else { return Ok(None) };
        let data = self.read_grid(&c.accum, c.grid)?;
        Ok(Some(grid_image(&self.coarse_options(c.grid), &self.scene, bytemuck::cast_slice(&data), 1)))
    }
}
