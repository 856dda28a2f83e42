//! The one dispatch schedule, shared by `render` and the preview: the wavefront kernels
//! worked through a grid of points (pixels, or pixel corners with SPD sampling) tile by tile.
//!
//! A tile is a run of grid points. For each of its samples (a *wave*), the first pass of
//! `nearest` makes and traces the eye ray of every point (one invocation a point; a separate
//! kernel writing them to a queue for it to read took 9 % of tetra_s6's kernel time); then,
//! depth by depth, passes of `nearest` trace a queue of rays and push those that hit into the
//! hit queue, a pass of `shade` adds what the hits send to their points and pushes the rays
//! they spawn into the next depth's queue, and passes of `shadow` trace the shadow rays too
//! long to trace inline. (Shading apart from tracing, over hits only: lavapipe runs the code
//! of both sides of a branch for every group of lanes, so shading inside `nearest` cost the
//! rays that missed as much as those that hit.) A walk longer than a pass allows
//! ([`crate::coherence::walk::WALK_CHUNK`] iterations: lavapipe ends an invocation's loops
//! after 65535 iterations in all, and real GPUs kill long dispatches) goes into a retry
//! queue, which the next pass of the same depth works through; a wave holds as many retry
//! passes as [`crate::coherence::reach::WalkBounds::planned`] asks for. The queues' lengths stay on the GPU and drive indirect dispatches; the host
//! encodes each wave's passes ahead ([`WavePlan::passes`]) and reads back once per tile: the
//! `resolve` kernel's colours, and whether a queue overflowed (the tile is then run again in
//! smaller tiles) or a walk outlasted its passes (again, with more passes).
//!
//! Radiance is summed in 64-bit fixed point (exact, so that the breadth-first order of the
//! additions, unlike the ray trees', changes nothing). The statistics counters are saved
//! before a tile and restored when it runs again.
//!
//! [`Pacing::Fixed`] (headless renders) times every pass with timestamp queries and sizes each
//! tile to a third of [`PASS_LIMIT`] (`TILE_SHARE`) at the costliest rate per point seen so far;
//! [`Pacing::Adaptive`] (the preview) sizes tiles so that one submission (a wave) takes about
//! a target time, keeping the window responsive.

use std::time::{Duration, Instant};

use super::bindings::SceneBinding;
use super::buffers::SceneBuffers;
use super::kernels::Pipelines;
pub use super::plan::{Pass, WavePlan};
use super::shaders::Kernel;
use super::GpuContext;
use crate::error::{Error, Result};
use crate::layout::{
    fresh_queues, Params, PassDesc, MAX_DEPTH, OVERFLOW_FULL, OVERFLOW_UNFINISHED, QUEUE_ARGS,
    QUEUE_OVERFLOW, QUEUE_WORDS, WORKGROUP,
};

/// How tiles are sized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pacing {
    /// Tiles as large as the buffers allow, while a pass stays under [`PASS_LIMIT`].
    Fixed,
    /// Tiles adapted towards `target` per submission (one wave).
    Adaptive { target: Duration },
}

/// The longest a pass (one dispatch) should take. Real GPUs reset a device whose
/// submission runs for about 2 s; lavapipe on two cores is slower than any of them.
pub const PASS_LIMIT: Duration = Duration::from_millis(100);

/// The smallest tile (grid points).
const MIN_TILE: u64 = WORKGROUP as u64;

/// The share of [`PASS_LIMIT`] a tile is sized for at the costliest rate per point seen so
/// far: a later band of the image may cost this many times more per point before a pass
/// outlasts the limit. A half let gears_s4 reach 114-143 ms on Mesa 22.3; a third kept every
/// SPD canonical scene under 100 ms, for about the same kernel time.
const TILE_SHARE: f64 = 1.0 / 3.0;

/// Tiles of fewer points do not set the rate per point the tiles are sized by.
const MIN_RATE_TILE: u64 = 512;

/// The first tile of a schedule holds at most this many points (it shrinks or grows after).
/// Small enough that its passes stay under [`PASS_LIMIT`] on lavapipe before any pass has
/// been timed (at 16384 points the first pass of reflection rays took up to 211 ms on
/// balls_s4); later tiles are sized by [`Schedule::fit_tile`].
const FIRST_TILE: u64 = 1024;

/// `points` rounded up to whole workgroups, at least one.
pub fn whole_groups(points: u64) -> u64 {
    points.div_ceil(MIN_TILE).max(1) * MIN_TILE
}

/// What a [`Schedule::step`] got done.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// The current tile still has waves to run.
    Stepping,
    /// The tile of points `first..first + count` is done (its colours are in the `out`
    /// buffer); `pass_done` when it was the last of the grid (the next step starts over).
    TileDone { first: u64, count: u32, pass_done: bool },
}

/// Timestamp queries around every pass of a wave.
struct Timer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    period_s: f64,
}

/// The tile under way: its points, the samples its points take (a wave each), the waves
/// run, and the longest pass so far.
#[derive(Clone, Copy, Debug)]
struct Tile {
    first: u64,
    count: u32,
    samples: (u32, u32),
    wave: u32,
    longest_pass: f64,
}

/// Where a run of the wavefront kernels over a grid stands.
pub struct Schedule {
    total: u64,
    /// Points the buffers hold (the largest tile).
    capacity: u64,
    tile_size: u64,
    pacing: Pacing,
    /// The waves' passes, or `None`: one dispatch of a single kernel per tile.
    plan: Option<WavePlan>,
    next_point: u64,
    current: Option<Tile>,
    /// The descriptors of a wave's passes, copied into `pass_desc` one by one; room for
    /// `per_wave` passes (and as many timestamp pairs).
    table: wgpu::Buffer,
    per_wave: usize,
    queues_read: wgpu::Buffer,
    counters_saved: wgpu::Buffer,
    timed: bool,
    timer: Option<Timer>,
    gpu_s: f64,
    /// Kernel time by kernel: nearest, shade, shadow, resolve (or the single kernel), tree.
    kernel_s: [f64; 5],
    /// The wavefront kernels' time by depth (index depth − 1): nearest, shade, shadow.
    depth_s: [[f64; 3]; MAX_DEPTH as usize],
    last_submit: Duration,
    longest_submit: Duration,
    /// The longest pass so far, seconds (from the timestamps).
    longest_pass: f64,
    /// The most seconds per point any tile's longest pass took (fixed pacing): tiles never
    /// hold more points than [`TILE_SHARE`] of [`PASS_LIMIT`] allows at that rate.
    pass_cost: f64,
    /// Tiles run again (a queue overflowed, or a walk outlasted its passes).
    redone: u32,
}

/// Index of a wavefront kernel in [`Schedule::kernel_s`].
fn kernel_slot(k: Kernel) -> usize {
    match k {
        Kernel::Nearest => 0,
        Kernel::Shade => 1,
        Kernel::Shadow => 2,
        Kernel::Tree => 4,
        _ => 3,
    }
}

/// Dispatches `pipeline` once over no points (it writes nothing: empty queues, no tile
/// points), so that a driver that compiles kernels at their first dispatch (lavapipe) does
/// so here rather than inside a timed schedule; returns how long the dispatch took,
/// compilation included.
pub fn warm_up(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    buffers: &SceneBuffers,
    base: &Params,
) -> Result<Duration> {
    let p = Params { first_point: 0, point_count: 0, ..*base };
    ctx.queue.write_buffer(&buffers[SceneBinding::Params], 0, bytemuck::bytes_of(&p));
    ctx.queue.write_buffer(&buffers[SceneBinding::Queues], 0, bytemuck::cast_slice(&fresh_queues()));
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
    let start = Instant::now();
    ctx.queue.submit([enc.finish()]);
    ctx.wait()?;
    Ok(start.elapsed())
}

impl Schedule {
    /// A schedule over `total` grid points for buffers of `capacity` points, with waves laid
    /// out by `plan` (`None`: a single kernel dispatched once per tile); kernel times are
    /// measured with timestamp queries when the adapter has them and `timed`. Each point
    /// takes the samples `sample_first..sample_end` of the params its tile starts with.
    pub fn new(
        ctx: &GpuContext,
        total: u64,
        capacity: u64,
        plan: Option<WavePlan>,
        pacing: Pacing,
        timed: bool,
    ) -> Schedule {
        let mut s = Schedule {
            total,
            capacity,
            tile_size: capacity.min(FIRST_TILE),
            pacing,
            plan,
            next_point: 0,
            current: None,
            table: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pass table"),
                size: 4,
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            per_wave: 0,
            queues_read: ctx.readback_buffer("queues readback", 4 * QUEUE_WORDS as u64),
            counters_saved: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("counters saved"),
                size: crate::layout::counters::COUNTER_BYTES,
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            timed,
            timer: None,
            gpu_s: 0.0,
            kernel_s: [0.0; 5],
            depth_s: [[0.0; 3]; MAX_DEPTH as usize],
            last_submit: Duration::ZERO,
            longest_submit: Duration::ZERO,
            longest_pass: 0.0,
            pass_cost: 0.0,
            redone: 0,
        };
        s.make_room(ctx);
        s
    }

    /// Makes the pass table and the timestamp queries large enough for the waves of the
    /// deepest plan (with eight retry passes per depth more than the plan's).
    fn make_room(&mut self, ctx: &GpuContext) {
        let per_wave = self.plan.map_or(1, |p| {
            WavePlan { max_depth: crate::layout::MAX_DEPTH, retries: p.retries + 8, ..p }.passes(0).len() + 1
        });
        if per_wave <= self.per_wave {
            return;
        }
        self.per_wave = per_wave;
        let device = &ctx.device;
        let per_wave = per_wave as u64;
        self.table = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pass table"),
            size: std::mem::size_of::<PassDesc>() as u64 * per_wave,
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.timer = (self.timed && ctx.timestamps).then(|| Timer {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass times"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * per_wave as u32,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: 16 * per_wave,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: ctx.readback_buffer("timestamps readback", 16 * per_wave),
            period_s: ctx.queue.get_timestamp_period() as f64 * 1e-9,
        });
    }

    /// Lays the waves out by `plan` from now on (the preview's depth or effects changed);
    /// the schedule starts again.
    pub fn set_plan(&mut self, ctx: &GpuContext, plan: WavePlan) {
        if let Some(p) = self.plan.as_mut() {
            *p = WavePlan { retries: p.retries.max(plan.retries), ..plan };
        }
        self.make_room(ctx);
        self.restart();
    }

    /// Whether the next step starts a pass at its first point (no tile in flight).
    pub fn at_pass_start(&self) -> bool {
        self.next_point == 0 && self.current.is_none()
    }

    /// Drops the current tile and starts again from the first point.
    pub fn restart(&mut self) {
        self.next_point = 0;
        self.current = None;
    }

    /// Kernel time measured so far (seconds), when timed.
    pub fn gpu_s(&self) -> Option<f64> {
        self.timer.as_ref().map(|_| self.gpu_s)
    }

    /// Kernel time by kernel (nearest, shade, shadow, resolve, tree; a single kernel counts
    /// as resolve), when timed.
    pub fn kernel_s(&self) -> Option<[f64; 5]> {
        self.timer.as_ref().map(|_| self.kernel_s)
    }

    /// The wavefront kernels' time by depth (index depth − 1: nearest, shade, shadow), when
    /// timed.
    pub fn depth_s(&self) -> Option<[[f64; 3]; MAX_DEPTH as usize]> {
        self.timer.as_ref().map(|_| self.depth_s)
    }

    /// How long the last submission took, from submit to its end.
    pub fn last_submit(&self) -> Duration {
        self.last_submit
    }

    /// The longest submission so far.
    pub fn longest_submit(&self) -> Duration {
        self.longest_submit
    }

    /// Tiles run again so far (a queue overflowed, or a walk outlasted its passes).
    pub fn tiles_run_again(&self) -> u32 {
        self.redone
    }

    /// The longest pass (one dispatch) so far, seconds, when timed.
    pub fn longest_pass(&self) -> Option<f64> {
        self.timer.as_ref().map(|_| self.longest_pass)
    }

    /// One submission: a wave of the current tile (starting the next tile when none is
    /// under way), and after its last wave the tile's colours and a check of its queues.
    pub fn step(
        &mut self,
        ctx: &GpuContext,
        pipelines: &Pipelines,
        buffers: &SceneBuffers,
        base: &Params,
    ) -> Result<Progress> {
        let (device, queue) = (&ctx.device, &ctx.queue);
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        let mut tile = match self.current {
            Some(t) => t,
            None => self.start_tile(queue, &mut enc, buffers, base),
        };
        let sample = tile.samples.0 + tile.wave;
        let passes = self.plan.map_or_else(Vec::new, |p| p.passes(sample));
        let descs: Vec<PassDesc> = passes.iter().map(|p| p.desc).collect();
        queue.write_buffer(&self.table, 0, bytemuck::cast_slice(&descs));
        let last_wave = self.plan.is_none() || sample + 1 >= tile.samples.1;
        let groups = tile.count.div_ceil(WORKGROUP);
        // Each dispatch's kernel and depth (0: none, the resolve pass).
        let mut kernels = self.encode_passes(&mut enc, &passes, pipelines, buffers, groups);
        if last_wave {
            // The tile's colours (`resolve`), or the single kernel's pass.
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("resolve"),
                timestamp_writes: self.timestamps(kernels.len()),
            });
            pass.set_pipeline(pipelines.of(Kernel::Resolve, 0));
            pass.set_bind_group(0, &buffers.bind, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
            drop(pass);
            kernels.push((Kernel::Resolve, 0));
            enc.copy_buffer_to_buffer(
                &buffers[SceneBinding::Queues],
                0,
                &self.queues_read,
                0,
                4 * QUEUE_WORDS as u64,
            );
        }
        if let Some(t) = &self.timer {
            let n = 2 * kernels.len() as u32;
            enc.resolve_query_set(&t.set, 0..n, &t.resolve, 0);
            enc.copy_buffer_to_buffer(&t.resolve, 0, &t.read, 0, 8 * n as u64);
        }
        let start = Instant::now();
        queue.submit([enc.finish()]);
        ctx.wait()?;
        self.last_submit = start.elapsed();
        self.longest_submit = self.longest_submit.max(self.last_submit);
        self.read_timestamps(ctx, &kernels, &mut tile)?;
        log::trace!(
            "wave {} of {} points: {} passes, {:.1} ms",
            tile.wave,
            tile.count,
            kernels.len(),
            self.last_submit.as_secs_f64() * 1e3
        );
        tile.wave += 1;
        self.current = Some(tile);
        self.adapt();
        if !last_wave {
            return Ok(Progress::Stepping);
        }
        self.current = None;
        let words = ctx.read(&self.queues_read, 4 * QUEUE_WORDS as u64)?;
        let overflow = bytemuck::cast_slice::<u8, u32>(&words)[QUEUE_OVERFLOW as usize];
        if overflow != 0 {
            self.redo(ctx, buffers, tile, overflow)?;
            return Ok(Progress::Stepping);
        }
        self.fit_tile(tile.longest_pass, tile.count);
        self.next_point = tile.first + tile.count as u64;
        let pass_done = self.next_point == self.total;
        if pass_done {
            self.next_point = 0;
        }
        Ok(Progress::TileDone { first: tile.first, count: tile.count, pass_done })
    }

    /// Encodes a wave's `passes` over `groups` workgroups (indirect where a pass's queue may
    /// have overflowed the tile), each after copying its descriptor and resetting its
    /// queues; returns each dispatch's kernel and depth.
    fn encode_passes(
        &self,
        enc: &mut wgpu::CommandEncoder,
        passes: &[Pass],
        pipelines: &Pipelines,
        buffers: &SceneBuffers,
        groups: u32,
    ) -> Vec<(Kernel, u32)> {
        let desc_bytes = std::mem::size_of::<PassDesc>() as u64;
        let mut kernels: Vec<(Kernel, u32)> = Vec::with_capacity(passes.len() + 1);
        for (i, p) in passes.iter().enumerate() {
            enc.copy_buffer_to_buffer(
                &self.table,
                i as u64 * desc_bytes,
                &buffers[SceneBinding::PassDesc],
                0,
                desc_bytes,
            );
            for &q in &p.resets {
                enc.clear_buffer(&buffers[SceneBinding::Queues], 4 * q as u64, Some(4));
                enc.clear_buffer(&buffers[SceneBinding::Queues], 4 * (QUEUE_ARGS + 3 * q) as u64, Some(4));
            }
            if let Some(q) = p.over {
                enc.copy_buffer_to_buffer(
                    &buffers[SceneBinding::Queues],
                    4 * (QUEUE_ARGS + 3 * q) as u64,
                    &buffers.indirect,
                    0,
                    12,
                );
            }
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(p.kernel.name()),
                timestamp_writes: self.timestamps(kernels.len()),
            });
            pass.set_pipeline(pipelines.of(p.kernel, p.desc.depth));
            pass.set_bind_group(0, &buffers.bind, &[]);
            match p.over {
                Some(_) => pass.dispatch_workgroups_indirect(&buffers.indirect, 0),
                None => pass.dispatch_workgroups(groups, 1, 1),
            }
            drop(pass);
            kernels.push((p.kernel, p.desc.depth));
        }
        kernels
    }

    /// Starts the next tile: its params and fresh queues written, its radiance sums cleared
    /// (wavefront), the counters saved for a redo.
    fn start_tile(
        &mut self,
        queue: &wgpu::Queue,
        enc: &mut wgpu::CommandEncoder,
        buffers: &SceneBuffers,
        base: &Params,
    ) -> Tile {
        let count = self.tile_size.min(self.total - self.next_point) as u32;
        let p = Params { first_point: self.next_point as u32, point_count: count, ..*base };
        queue.write_buffer(&buffers[SceneBinding::Params], 0, bytemuck::bytes_of(&p));
        queue.write_buffer(&buffers[SceneBinding::Queues], 0, bytemuck::cast_slice(&fresh_queues()));
        if self.plan.is_some() {
            enc.clear_buffer(&buffers[SceneBinding::Accum], 0, Some(count as u64 * 24));
        }
        let bytes = crate::layout::counters::COUNTER_BYTES;
        enc.copy_buffer_to_buffer(&buffers[SceneBinding::Counters], 0, &self.counters_saved, 0, bytes);
        let samples = (base.sample_first, base.sample_end.max(base.sample_first + 1));
        Tile { first: self.next_point, count, samples, wave: 0, longest_pass: 0.0 }
    }

    /// Adds the timed passes of a wave (`kernels`: each dispatch's kernel and depth) to the
    /// kernel times, by kernel and depth, and to the longest pass, when timed.
    fn read_timestamps(
        &mut self,
        ctx: &GpuContext,
        kernels: &[(Kernel, u32)],
        tile: &mut Tile,
    ) -> Result<()> {
        let Some(t) = &self.timer else { return Ok(()) };
        let n = 2 * kernels.len() as u64;
        let (ts, period_s) = (ctx.read(&t.read, 8 * n)?, t.period_s);
        let ts: &[u64] = bytemuck::cast_slice(&ts);
        for (&(k, depth), pair) in kernels.iter().zip(ts.chunks_exact(2)) {
            let s = pair[1].saturating_sub(pair[0]) as f64 * period_s;
            self.gpu_s += s;
            let slot = kernel_slot(k);
            self.kernel_s[slot] += s;
            if depth >= 1 && slot < 3 {
                self.depth_s[depth as usize - 1][slot] += s;
            }
            tile.longest_pass = tile.longest_pass.max(s);
            self.longest_pass = self.longest_pass.max(s);
        }
        Ok(())
    }

    /// The timestamp writes of pass `i` of a wave, when timed.
    fn timestamps(&self, i: usize) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.timer.as_ref().map(|t| wgpu::ComputePassTimestampWrites {
            query_set: &t.set,
            beginning_of_pass_write_index: Some(2 * i as u32),
            end_of_pass_write_index: Some(2 * i as u32 + 1),
        })
    }

    /// A tile that overflowed a queue or outlasted its passes: its counts are restored and
    /// it runs again, in a tile half as large (a full queue) or with another pass per depth.
    fn redo(&mut self, ctx: &GpuContext, buffers: &SceneBuffers, tile: Tile, overflow: u32) -> Result<()> {
        let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        let bytes = crate::layout::counters::COUNTER_BYTES;
        enc.copy_buffer_to_buffer(&self.counters_saved, 0, &buffers[SceneBinding::Counters], 0, bytes);
        ctx.queue.submit([enc.finish()]);
        ctx.wait()?;
        if overflow & OVERFLOW_FULL != 0 {
            if tile.count as u64 <= MIN_TILE {
                return Err(Error::Gpu(format!(
                    "the ray queues overflow even for {MIN_TILE} points: a ray tree this wide does not fit \
                     the GPU's buffers; render with a smaller --max-depth or with --backend cpu"
                )));
            }
            self.tile_size = whole_groups(tile.count as u64 / 2);
            self.capacity = self.tile_size;
        }
        if let (true, Some(plan)) = (overflow & OVERFLOW_UNFINISHED != 0, self.plan.as_mut()) {
            plan.retries += 1;
            log::debug!("a walk outlasted its passes: {} retry passes per depth", plan.retries);
            self.make_room(ctx);
        }
        log::debug!("tile of {} points runs again ({overflow:#b})", tile.count);
        self.redone += 1;
        self.next_point = tile.first;
        Ok(())
    }

    /// At the end of a tile of `points` whose longest pass took `longest` seconds (fixed
    /// pacing): the next tile holds as many points as [`TILE_SHARE`] of [`PASS_LIMIT`] allows at the
    /// costliest rate per point seen so far, and at most twice as many as this one. The
    /// costliest rate, not the last: a tile of sky would otherwise let the tiles grow until
    /// the next one full of mirrors took several times the limit.
    fn fit_tile(&mut self, longest: f64, points: u32) {
        if self.pacing != Pacing::Fixed || self.timer.is_none() {
            return;
        }
        // A small tile (the grid's last) is mostly a pass's fixed cost: no measure of a rate.
        if points as u64 >= MIN_RATE_TILE {
            self.pass_cost = self.pass_cost.max(longest / points as f64);
        }
        let fit = if self.pass_cost > 0.0 {
            (TILE_SHARE * PASS_LIMIT.as_secs_f64() / self.pass_cost) as u64
        } else {
            u64::MAX
        };
        self.tile_size = whole_groups(fit.min(2 * self.tile_size)).min(self.capacity);
    }

    /// Adaptive pacing: tiles grow or shrink towards the target per submission.
    fn adapt(&mut self) {
        let Pacing::Adaptive { target } = self.pacing else { return };
        let took = self.last_submit;
        if took > target * 2 {
            self.tile_size = whole_groups(self.tile_size / 2);
        } else if took < target / 2 {
            self.tile_size = (self.tile_size * 2).min(self.capacity);
        }
    }
}
