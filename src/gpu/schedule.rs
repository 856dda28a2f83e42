//! The one dispatch schedule, shared by `render` and the preview: a grid of points (pixels,
//! or pixel corners with SPD sampling) is worked through tile by tile; a stepped kernel
//! advances each point of a tile by one ray per dispatch, and dispatches are repeated until
//! no point of the tile has work left (the kernel counts them in `active`).
//!
//! Each grid point keeps its ray tree as a stack of pending rays in its state. A single
//! invocation looping over its whole ray tree was the first design, but lavapipe ends all
//! loops of an invocation after 65535 iterations in total (a safety limit in Mesa's gallivm),
//! which silently cut ray trees short on scenes of a few hundred primitives; and real GPUs
//! kill dispatches that run for seconds. So a step does a bounded amount of work (see
//! [`crate::layout::budget`]), and tiles bound both a dispatch's length and the states'
//! memory.
//!
//! [`Pacing::Fixed`] (headless renders) submits one dispatch at a time and measures each
//! with timestamp queries; its tiles start at a quarter of the buffers' capacity and are
//! halved after a tile whose longest submission passed [`SUBMIT_LIMIT`] (grown back when
//! well under), because the static estimate of a step's work ([`crate::layout::budget`])
//! cannot see how long secondary rays' walks really are. [`Pacing::Adaptive`] (the
//! preview) grows or shrinks the tile and the dispatches per submission so that one
//! submission takes about a target time, keeping the window responsive.

use std::time::{Duration, Instant};

use super::buffers::SceneBuffers;
use super::GpuContext;
use crate::error::Result;
use crate::layout::{Params, PointState, WORKGROUP};

/// How submissions are sized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pacing {
    /// One dispatch per submission over tiles as large as the buffers allow.
    Fixed,
    /// Tiles and dispatches per submission adapted towards `target` per submission.
    Adaptive { target: Duration },
}

/// The smallest adaptive tile (grid points).
const MIN_TILE: u64 = WORKGROUP as u64;

/// The most dispatches in one adaptive submission.
const MAX_DISPATCHES: u32 = 16;

/// The first tile of an adaptive schedule holds at most this many points.
const FIRST_ADAPTIVE_TILE: u64 = 4096;

/// The longest a fixed-pacing submission should take. Real GPUs reset a device whose
/// submission runs for about 2 s; lavapipe on two cores is slower than any of them, so
/// keeping its submissions to a quarter of that keeps every device's well under.
pub const SUBMIT_LIMIT: Duration = Duration::from_millis(500);

/// `points` rounded up to whole workgroups, at least one.
fn whole_groups(points: u64) -> u64 {
    points.div_ceil(MIN_TILE).max(1) * MIN_TILE
}

/// What a [`Schedule::step`] got done.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// The current tile still has work.
    Stepping,
    /// The tile of points `first..first + count` is done (its results are in the `out`
    /// buffer); `pass_done` when it was the last of the grid (the next step starts over).
    TileDone { first: u64, count: u32, pass_done: bool },
}

/// Timestamp queries around the dispatches of one submission.
struct Timer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    period_s: f64,
}

/// Where a kernel's run over a grid stands.
pub struct Schedule {
    total: u64,
    /// Points the buffers hold (the largest tile).
    capacity: u64,
    tile_size: u64,
    dispatches: u32,
    pacing: Pacing,
    stepped: bool,
    next_point: u64,
    current: Option<(u64, u32)>,
    active_read: wgpu::Buffer,
    timer: Option<Timer>,
    gpu_s: f64,
    last_submit: Duration,
    longest_submit: Duration,
    /// The longest submission of the current tile.
    tile_longest: Duration,
}

/// Dispatches `pipeline` once over no points (it writes nothing), so that a driver that
/// compiles kernels at their first dispatch (lavapipe) does so here rather than inside a timed
/// schedule; returns how long the dispatch took, compilation included.
pub fn warm_up(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    buffers: &SceneBuffers,
    base: &Params,
) -> Result<Duration> {
    let p = Params { first_point: 0, point_count: 0, ..*base };
    ctx.queue.write_buffer(&buffers.params, 0, bytemuck::bytes_of(&p));
    let read = ctx.readback_buffer("warm-up readback", 4);
    let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("kernel warm-up"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &buffers.bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    enc.copy_buffer_to_buffer(&buffers.active, 0, &read, 0, 4);
    let start = Instant::now();
    ctx.queue.submit([enc.finish()]);
    ctx.read(&read, 4)?;
    Ok(start.elapsed())
}

impl Schedule {
    /// A schedule over `total` grid points for buffers of `capacity` points; `stepped`: the
    /// kernel advances points step by step (`render`) rather than in one dispatch (`aov`);
    /// `timed`: measure the kernel time with timestamp queries (when the adapter has them).
    pub fn new(
        ctx: &GpuContext,
        total: u64,
        capacity: u64,
        stepped: bool,
        pacing: Pacing,
        timed: bool,
    ) -> Schedule {
        let device = &ctx.device;
        let timer = (timed && ctx.timestamps).then(|| Timer {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("kernel times"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: ctx.readback_buffer("timestamps readback", 16),
            period_s: ctx.queue.get_timestamp_period() as f64 * 1e-9,
        });
        let tile_size = match pacing {
            Pacing::Fixed => whole_groups(capacity / 4),
            Pacing::Adaptive { .. } => capacity.min(FIRST_ADAPTIVE_TILE),
        };
        Schedule {
            total,
            capacity,
            tile_size,
            dispatches: 1,
            pacing,
            stepped,
            next_point: 0,
            current: None,
            active_read: ctx.readback_buffer("active readback", 4),
            timer,
            gpu_s: 0.0,
            last_submit: Duration::ZERO,
            longest_submit: Duration::ZERO,
            tile_longest: Duration::ZERO,
        }
    }

    /// Drops the current tile and starts again from the first point.
    pub fn restart(&mut self) {
        self.tile_longest = Duration::ZERO;
        self.next_point = 0;
        self.current = None;
    }

    /// Kernel time measured so far (seconds), when timed.
    pub fn gpu_s(&self) -> Option<f64> {
        self.timer.as_ref().map(|_| self.gpu_s)
    }

    /// How long the last submission took, from submit to its readback.
    pub fn last_submit(&self) -> Duration {
        self.last_submit
    }

    /// The longest submission so far.
    pub fn longest_submit(&self) -> Duration {
        self.longest_submit
    }

    /// One submission: starts the next tile when none is under way (writing `base` with the
    /// tile's points into the params and clearing the tile's point states), runs the kernel,
    /// and reads how many points have work left.
    pub fn step(
        &mut self,
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        buffers: &SceneBuffers,
        base: &Params,
    ) -> Result<Progress> {
        let (device, queue) = (&ctx.device, &ctx.queue);
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        let (first, count) = match self.current {
            Some(c) => c,
            None => {
                let count = self.tile_size.min(self.total - self.next_point) as u32;
                let p = Params { first_point: self.next_point as u32, point_count: count, ..*base };
                queue.write_buffer(&buffers.params, 0, bytemuck::bytes_of(&p));
                if self.stepped {
                    let state_bytes = std::mem::size_of::<PointState>() as u64;
                    enc.clear_buffer(&buffers.states, 0, Some(count as u64 * state_bytes));
                }
                self.current = Some((self.next_point, count));
                (self.next_point, count)
            }
        };
        // Several dispatches per submission save a wait each; dispatches after a tile is done
        // change nothing (`active` counts the last one).
        for k in 0..self.dispatches {
            enc.clear_buffer(&buffers.active, 0, None);
            // The first pass writes the start time, the last the end time.
            let (first_pass, last_pass) = (k == 0, k + 1 == self.dispatches);
            let timestamp_writes = self.timer.as_ref().filter(|_| first_pass || last_pass).map(|t| {
                wgpu::ComputePassTimestampWrites {
                    query_set: &t.set,
                    beginning_of_pass_write_index: first_pass.then_some(0),
                    end_of_pass_write_index: last_pass.then_some(1),
                }
            });
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("kernel step"),
                timestamp_writes,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &buffers.bind, &[]);
            pass.dispatch_workgroups(count.div_ceil(WORKGROUP), 1, 1);
        }
        enc.copy_buffer_to_buffer(&buffers.active, 0, &self.active_read, 0, 4);
        if let Some(t) = &self.timer {
            enc.resolve_query_set(&t.set, 0..2, &t.resolve, 0);
            enc.copy_buffer_to_buffer(&t.resolve, 0, &t.read, 0, 16);
        }
        let start = Instant::now();
        queue.submit([enc.finish()]);
        let left = u32::from_le_bytes(ctx.read(&self.active_read, 4)?.try_into().expect("4 bytes"));
        self.last_submit = start.elapsed();
        self.longest_submit = self.longest_submit.max(self.last_submit);
        self.tile_longest = self.tile_longest.max(self.last_submit);
        if let Some(t) = &self.timer {
            let ts = ctx.read(&t.read, 16)?;
            let ts: &[u64] = bytemuck::cast_slice(&ts);
            self.gpu_s += ts[1].saturating_sub(ts[0]) as f64 * t.period_s;
        }
        log::trace!(
            "step: {count} points x {} dispatches, {:.1} ms, {left} left",
            self.dispatches,
            self.last_submit.as_secs_f64() * 1e3
        );
        self.adapt();
        if self.stepped && left > 0 {
            return Ok(Progress::Stepping);
        }
        self.current = None;
        self.fit_tile_to_submit_limit();
        self.next_point = first + count as u64;
        let pass_done = self.next_point == self.total;
        if pass_done {
            self.next_point = 0;
        }
        Ok(Progress::TileDone { first, count, pass_done })
    }

    /// Fixed pacing, at the end of a tile: the next tile is half as large when this one's
    /// longest submission passed [`SUBMIT_LIMIT`], twice as large (up to the capacity) when
    /// it stayed under a quarter of it.
    fn fit_tile_to_submit_limit(&mut self) {
        let longest = std::mem::take(&mut self.tile_longest);
        if self.pacing != Pacing::Fixed {
            return;
        }
        if longest > SUBMIT_LIMIT {
            self.tile_size = whole_groups(self.tile_size / 2);
        } else if longest < SUBMIT_LIMIT / 4 {
            self.tile_size = (self.tile_size * 2).min(self.capacity);
        }
    }

    /// Adaptive pacing: towards the target, larger tiles first, then more dispatches per
    /// submission.
    fn adapt(&mut self) {
        let Pacing::Adaptive { target } = self.pacing else { return };
        let took = self.last_submit;
        if took > target * 2 {
            if self.dispatches > 1 {
                self.dispatches /= 2;
            } else {
                self.tile_size = (self.tile_size / 2).max(MIN_TILE);
            }
        } else if took < target / 2 {
            if self.tile_size < self.capacity {
                self.tile_size = (self.tile_size * 2).min(self.capacity);
            } else {
                self.dispatches = (self.dispatches * 2).min(MAX_DISPATCHES);
            }
        }
    }
}
