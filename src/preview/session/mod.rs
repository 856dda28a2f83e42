//! Progressive rendering on the GPU, independent of any window: a [`Session`] runs the
//! headless renderer's wavefront kernels one sample pass at a time, tile by tile, and adds
//! each finished tile to a whole-image accumulation buffer.
//!
//! Pass `k` renders sample `σ(k)` of the same `spp`-sample lattice and seed as
//! `cuberay render --spp N`, where `σ` is a golden-ratio permutation of `0..spp`: any
//! prefix of passes is spread over the pixel (not only its left part), and after `spp`
//! passes the accumulation holds the same samples as the headless render, summed in
//! another order (equal up to f32 rounding).
//!
//! The tiles, waves and their pacing are the headless renderer's own schedule
//! ([`crate::gpu::schedule`]) with adaptive pacing. Only [`Session::set_camera`] does the work
//! that depends on the eye (packing the geometry relative to the eye again), and it restarts
//! the accumulation. With the direction-cube tables, a move never waits for the eye's table:
//! the session traces with the BVH at once (its kernels compiled when the session starts)
//! while a worker thread rebuilds the eye's table for the new camera; [`Session::advance`]
//! swaps the tables in between two passes once they match the camera (a newer move sends
//! the worker's tables back for another rebuild). Every accelerator gives the same pixels,
//! so the swap shows only in speed.
//!
//! - this module: the session, its camera moves and effect changes, the uploads they make,
//!   and the steps that refine it;
//! - `eye_table`: the eye's table rebuilt on a worker thread after a camera move;
//! - `coarse`: the coarse image of a moving camera, and what the window shows;
//! - `accumulate`: the accumulation pass and the order of the passes' samples.

mod accumulate;
mod coarse;
mod eye_table;

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::coherence::reach::WalkBounds;
use crate::coherence::{FlatTables, Tables};
use crate::error::{Error, Result};
use crate::gpu::bindings::SceneBinding;
use crate::gpu::buffers::BufferSizes;
use crate::gpu::kernels::StagePipeline;
use crate::gpu::prepare::{self, queue_sizes, Prepared, Purpose, TableSet};
use crate::gpu::schedule::{Pacing, Schedule, WavePlan};
use crate::gpu::shaders::{Accel, Kernel, Variant};
use crate::gpu::{GpuRenderer, SceneBuffers};
use crate::job::{grid_image, KernelForm, Precision, RenderOptions};
use crate::layout::budget::{check_loop_budget, retry_passes, MAX_DEPTH};
use crate::layout::{pack, pack_moved, Packed, Params};
use crate::output::Image;
use crate::scene::{Camera, Effects, Scene, Transfer};
use accumulate::{accumulation, step_tile, Accumulator};
pub use accumulate::{pass_sample, Tile, ACCUMULATE_WORKGROUP};
use coarse::Coarse;
pub use coarse::{Shown, COARSE_TARGET};
pub use eye_table::EyeTable;
use eye_table::{make_room_for_eye_tables, EyeBuild};

/// The wall time one submission should take; tiles shrink or grow towards it.
const STEP_TARGET: Duration = Duration::from_millis(30);

/// Which of the scene's effects are switched on (all at first). Refraction rays are
/// spawned beside reflection rays: with reflection off there is no refraction either.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Toggles {
    pub shadows: bool,
    pub reflection: bool,
    pub refraction: bool,
}

impl Default for Toggles {
    fn default() -> Self {
        Toggles { shadows: true, reflection: true, refraction: true }
    }
}

impl Toggles {
    /// The scene's effects with the switched-off ones removed.
    pub fn apply(&self, mut e: Effects) -> Effects {
        e.shadows &= self.shadows;
        e.reflection &= self.reflection;
        e.refraction &= self.refraction && self.reflection;
        e
    }
}

/// A scene on the GPU being refined pass by pass.
pub struct Session {
    gpu: Arc<GpuRenderer>,
    scene: Scene,
    opts: RenderOptions,
    toggles: Toggles,
    /// Passes after which the session is complete (at most `opts.spp`).
    limit: u32,
    /// The wavefront kernels of the current effects and depth.
    pipelines: Vec<StagePipeline>,
    /// The accelerator the kernels trace with: the tables, the BVH, brute force or ray
    /// queries (the BVH while the tables are rebuilt for a new eye, or when they could not
    /// be).
    accel: Accel,
    /// The direction-cube tables (`--accel cube`, the default), or `None`.
    tables: Option<Tables>,
    /// How long the kernels' walks may be (`None`: brute force), for the passes a depth takes.
    walks: Option<WalkBounds>,
    buffers: SceneBuffers,
    /// Params of the whole image (camera, sizes, sampling); tiles fill in the rest.
    base: Params,
    grid: (u32, u32),
    accum: wgpu::Buffer,
    accumulator: Accumulator,
    /// The bind group that adds the output's tiles to `accum`.
    accum_bind: wgpu::BindGroup,
    schedule: Schedule,
    /// Passes complete.
    passes: u32,
    /// Time of the last eye-dependent update.
    pub last_eye_update: Duration,
    /// Whether the session traces with the candidate tables when it can (`--accel cube`,
    /// `auto`): while their eye table is rebuilt it traces with the BVH.
    wants_tables: bool,
    /// The eye table being rebuilt on a worker thread, if any.
    eye_build: Option<EyeBuild>,
    /// Tables rebuilt for the current camera, waiting for the end of a pass.
    eye_ready: Option<Tables>,
    /// Camera changes so far; a build for an older one is rebuilt for the newest.
    camera_generation: u64,
    /// Grid points traced (of every pass) since the session started.
    points_traced: u64,
    /// When the camera last moved.
    last_move: Instant,
    /// The coarse image of a moving camera, once one was traced.
    coarse: Option<Coarse>,
}

/// The kernels' variant for the session's toggles and depth, traced with `accel`.
fn variant(scene: &Scene, opts: &RenderOptions, toggles: Toggles, max_depth: u32, accel: Accel) -> Variant {
    prepare::variant(scene, opts, toggles.apply(scene.effects()), max_depth, accel)
}

/// The walks the kernels of `packed` take: the tables' (if any), and the BVH's where rays
/// walk it (the BVH a preview keeps for camera moves is not walked beside the tables when
/// no ray leaves a surface).
fn traced_walks(tables: Option<&WalkBounds>, packed: &Packed) -> Option<WalkBounds> {
    match tables {
        Some(t) if packed.params.surface_walk == 0 => Some(*t),
        t => prepare::walk_bounds(t, packed),
    }
}

/// Gives `packed` (of `scene`) a BVH, and room after it for the BVH of any camera (a wide
/// tree over n primitives has at most n − 1 nodes, one a node of the binary tree it is
/// collapsed from, and a tree over one primitive one), so that a camera move
/// writes its BVH into the buffers in place: new buffers would cost the zeroing of a
/// tile's queues, a stall of about 50 ms on lavapipe. The tables' kernels ignore it.
fn make_room_for_moves(packed: &mut Packed, scene: &Scene) {
    if packed.bvh.is_none() {
        packed.add_bvh(scene);
    }
    if let Some(b) = packed.bvh.as_mut() {
        let most = scene.primitives.len().saturating_sub(1).max(1);
        b.nodes.resize(b.nodes.len().max(most), Default::default());
        b.parents.resize(b.nodes.len(), crate::layout::bvh::BVH_NO_PARENT);
    }
}

/// `scene` packed for a `w`×`h` image under `opts` (in f64 for `--precision f64`): all of it
/// (`fixed`), or for a camera move only what depends on the eye ([`pack_moved`]).
fn pack_scene(scene: &Scene, opts: &RenderOptions, w: u32, h: u32, fixed: bool) -> Packed {
    let mut packed = if fixed { pack(scene, w, h, opts.spawn) } else { pack_moved(scene, w, h, opts.spawn) };
    if opts.precision == Precision::F64 {
        packed.use_f64(scene, opts.spawn);
    }
    packed
}

/// How the preview paces its passes: each step near [`STEP_TARGET`].
const PACING: Pacing = Pacing::Adaptive { target: STEP_TARGET };

/// Uploads what `p` prepared for `scene`, with room for what a camera move rewrites in place
/// (the BVH's boxes, the eye's table), and returns the buffers and the tables kept for the
/// eye's rebuilds (`None`: the session traces none).
fn upload_with_room(
    gpu: &GpuRenderer,
    p: &mut Prepared,
    scene: &Scene,
) -> Result<(SceneBuffers, Option<Tables>)> {
    let mut tables = p.tables.take().and_then(TableSet::built);
    if tables.is_some() || p.variant.accel == Accel::Bvh {
        make_room_for_moves(&mut p.packed, scene);
    }
    if let Some(t) = tables.as_mut() {
        make_room_for_eye_tables(&mut t.flat, gpu.caps.max_binding);
    }
    let buffers = gpu.upload(&p.packed, tables.as_ref().map(|t| &t.flat), p.sizes)?;
    Ok((buffers, tables))
}

impl Session {
    /// Uploads `scene` for `opts` (the image size, the lattice `opts.spp` and seed, the
    /// depth), prepared as every render is ([`prepare::prepare`]), with room for what a
    /// camera move rewrites in place; the session completes after `limit` passes (at most
    /// `opts.spp`).
    pub fn new(
        gpu: Arc<GpuRenderer>,
        scene: Scene,
        opts: RenderOptions,
        toggles: Toggles,
        limit: u32,
    ) -> Result<Session> {
        let effects = toggles.apply(scene.effects());
        let mut p = prepare::prepare(&scene, &opts, &gpu.caps, Purpose::Preview { effects }, None)?;
        let (buffers, tables) = upload_with_room(&gpu, &mut p, &scene)?;
        let wants_tables = tables.is_some();
        let base = p.packed.params;
        let pipelines = compile(&gpu, p.variant, p.opts.form, &buffers, &base)?;
        if wants_tables {
            // The kernels a camera move traces with while the eye's table is rebuilt.
            let bvh = variant(&scene, &p.opts, toggles, p.opts.max_depth, Accel::Bvh);
            compile(&gpu, bvh, p.opts.form, &buffers, &base)?;
        }
        let (ctx, grid) = (&gpu.ctx, p.opts.grid());
        let total = grid.0 as u64 * grid.1 as u64;
        let accum = accumulation(ctx, "preview accumulation", total)?;
        let accumulator = Accumulator::new(ctx)?;
        let accum_bind = accumulator.bind(ctx, &buffers, &accum);
        let plan = WavePlan::new(p.variant, p.opts.max_depth, p.retries, p.opts.form);
        let schedule = Schedule::new(ctx, total, buffers.tile, Some(plan), PACING, false);
        let mut s = Session {
            base,
            gpu,
            limit: limit.min(p.opts.spp),
            scene,
            opts: p.opts,
            toggles,
            pipelines,
            accel: p.variant.accel,
            tables,
            walks: p.walks,
            buffers,
            grid,
            accum,
            accumulator,
            accum_bind,
            schedule,
            passes: 0,
            last_eye_update: Duration::ZERO,
            wants_tables,
            eye_build: None,
            eye_ready: None,
            camera_generation: 0,
            points_traced: 0,
            last_move: Instant::now(),
            coarse: None,
        };
        s.restart();
        Ok(s)
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    pub fn options(&self) -> &RenderOptions {
        &self.opts
    }

    /// How the window and screenshots encode the values.
    pub fn transfer(&self) -> Transfer {
        self.opts.transfer_for(&self.scene)
    }

    pub fn toggles(&self) -> Toggles {
        self.toggles
    }

    /// The grid of accumulated points (pixels, or pixel corners with SPD sampling).
    pub fn grid(&self) -> (u32, u32) {
        self.grid
    }

    /// The accumulation: one `vec4<f32>` per grid point, the radiance summed over the
    /// passes done (RGB).
    pub fn accumulation(&self) -> &wgpu::Buffer {
        &self.accum
    }

    /// Passes complete (samples per pixel accumulated).
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// The pass count the session stops at.
    pub fn limit(&self) -> u32 {
        self.limit
    }

    pub fn is_complete(&self) -> bool {
        self.passes >= self.limit
    }

    /// The one place where a camera change is handled: the geometry is re-centred on the
    /// new eye and uploaded, and the accumulation restarts. With the direction-cube tables
    /// the session traces with the BVH until a worker thread has rebuilt the eye's table
    /// ([`Session::advance`] swaps it in); light and object data are kept. Returns the time
    /// the update took on the caller's thread.
    pub fn set_camera(&mut self, camera: Camera) -> Duration {
        let start = Instant::now();
        self.scene.camera = camera;
        self.camera_generation += 1;
        self.last_move = Instant::now();
        if let Some(tables) = self.eye_ready.take() {
            // Rebuilt for the camera before this one: rebuilt again once this one rests.
            self.tables = Some(tables);
        }
        if let Some(c) = self.coarse.as_mut() {
            c.complete = false;
        }
        if let Err(e) = self.update_eye() {
            log::error!("cannot update the view: {e}");
        }
        self.last_eye_update = start.elapsed();
        self.restart();
        self.last_eye_update
    }

    /// Grid points traced since the session started, over all passes.
    pub fn points_traced(&self) -> u64 {
        self.points_traced
    }

    /// What of the scene depends on the current camera, packed: what a camera move writes in
    /// place; `install` adds the rest only if it must upload anew.
    fn pack_moved(&self) -> Packed {
        pack_scene(&self.scene, &self.opts, self.opts.width, self.opts.height, false)
    }

    fn update_eye(&mut self) -> Result<()> {
        if self.accel == Accel::RayQuery {
            // The driver's structure is built over eye-relative boxes: built anew.
            let mut packed = self.pack_moved();
            packed.add_rq(&self.scene);
            return self.install(Accel::RayQuery, packed, None);
        }
        if self.wants_tables || self.accel == Accel::Bvh {
            // The BVH over the re-centred scene (in milliseconds) traces at once; with the
            // tables, the eye's table follows from a worker thread once the camera rests.
            let t0 = Instant::now();
            let mut packed = self.pack_moved();
            make_room_for_moves(&mut packed, &self.scene);
            let t1 = Instant::now();
            self.install(Accel::Bvh, packed, None)?;
            log::debug!(
                "camera move: packed with the BVH in {:.1} ms, uploaded in {:.1} ms",
                (t1 - t0).as_secs_f64() * 1e3,
                t1.elapsed().as_secs_f64() * 1e3
            );
            return Ok(());
        }
        // Brute force: only the geometry moves.
        let packed = self.pack_moved();
        let queue = &self.gpu.ctx.queue;
        if !packed.prims.is_empty() {
            queue.write_buffer(&self.buffers[SceneBinding::Prims], 0, packed.prim_bytes());
        }
        if !packed.lights.is_empty() {
            queue.write_buffer(&self.buffers[SceneBinding::Lights], 0, bytemuck::cast_slice(&packed.lights));
        }
        self.set_base(&packed.params);
        Ok(())
    }

    /// Traces with `accel` over `packed` (and `tables`) from now on. The loop budget is
    /// checked and the kernels compiled first, so that a failure leaves the session as it
    /// was; then `packed` and `tables` are written into the buffers in place where they fit
    /// (new buffers cost the zeroing of a tile's queues, a stall of about 50 ms on
    /// lavapipe), else into new ones, the tables' made with room
    /// ([`make_room_for_eye_tables`]); the waves' plan and the params follow. Between
    /// passes the accumulation stays valid: every accelerator gives the same pixels.
    fn install(&mut self, accel: Accel, mut packed: Packed, mut tables: Option<&mut Tables>) -> Result<()> {
        let walks = traced_walks(tables.as_ref().map(|t| &t.walks), &packed);
        if self.gpu.caps.lavapipe {
            check_loop_budget(&self.scene, walks.as_ref(), Some(MAX_DEPTH))?;
        }
        let v = variant(&self.scene, &self.opts, self.toggles, self.opts.max_depth, accel);
        let pipelines = compile(&self.gpu, v, self.opts.form, &self.buffers, &self.base)?;
        let ctx = &self.gpu.ctx;
        let in_place = tables.as_ref().is_none_or(|t| self.buffers.rewrite_tables(ctx, &t.flat))
            && self.buffers.rewrite_moved(ctx, &packed);
        if !in_place {
            log::debug!("new buffers for the {} kernels", accel.name());
            if let Some(t) = tables.as_mut() {
                make_room_for_eye_tables(&mut t.flat, self.gpu.caps.max_binding);
            }
            packed.add_fixed(&self.scene);
            self.buffers = self.upload(&packed, tables.as_ref().map(|t| &t.flat))?;
            self.accum_bind = self.accumulator.bind(&self.gpu.ctx, &self.buffers, &self.accum);
        }
        self.pipelines = pipelines;
        self.accel = accel;
        self.walks = walks;
        let retries = retry_passes(&self.scene, self.walks.as_ref());
        self.schedule.set_plan(&self.gpu.ctx, WavePlan::new(v, self.opts.max_depth, retries, self.opts.form));
        self.set_base(&packed.params);
        Ok(())
    }

    /// The camera, table and BVH parts of `p` (freshly packed) into the session's params,
    /// with the queues of the current buffers.
    fn set_base(&mut self, p: &Params) {
        self.base = self.base.with_camera_of(p);
        self.base.set_queues(self.buffers.ray_queue, self.buffers.shadow_queue);
    }

    /// Uploads `packed` (with `tables`) into buffers with the queues of the scene's every
    /// effect (the wavefront form's), for tiles as large as the current ones.
    fn upload(&self, packed: &Packed, tables: Option<&FlatTables>) -> Result<SceneBuffers> {
        let every = Variant::for_effects(self.scene.effects(), MAX_DEPTH);
        let queues = (self.opts.form != KernelForm::Tree).then(|| queue_sizes(&self.scene, every));
        let max_binding = self.gpu.caps.max_binding;
        let sizes = BufferSizes::fit(self.buffers.tile, queues, true, packed.job_bytes(), max_binding);
        self.gpu.upload(packed, tables, sizes)
    }

    /// Switches effects on or off and sets the maximum depth; restarts the
    /// accumulation. The kernels of a new combination are compiled on first use.
    pub fn set_effects(&mut self, toggles: Toggles, max_depth: u32) -> Result<()> {
        let mut opts = self.opts.clone();
        opts.max_depth = max_depth;
        crate::gpu::check(&self.scene, &opts)?;
        let v = variant(&self.scene, &opts, toggles, max_depth, self.accel);
        self.use_kernel(v)?;
        self.toggles = toggles;
        self.opts = opts;
        if let Some(c) = self.coarse.as_mut() {
            // The coarse image shows the old effects: not shown again.
            c.complete = false;
        }
        self.base.set_max_depth(max_depth);
        let retries = retry_passes(&self.scene, self.walks.as_ref());
        let plan = WavePlan::new(v, max_depth, retries, self.opts.form);
        self.schedule.set_plan(&self.gpu.ctx, plan);
        self.restart();
        Ok(())
    }

    /// Traces with the wavefront kernels of `v` from now on, compiled and warmed up on first
    /// use.
    fn use_kernel(&mut self, v: Variant) -> Result<()> {
        self.pipelines = compile(&self.gpu, v, self.opts.form, &self.buffers, &self.base)?;
        Ok(())
    }

    /// Drops the accumulation and starts again from pass 0.
    pub fn restart(&mut self) {
        let mut enc = self.gpu.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&self.accum, 0, None);
        self.gpu.ctx.queue.submit([enc.finish()]);
        self.passes = 0;
        self.schedule.restart();
    }

    /// Runs steps while another one is expected to end within `budget` (at least one
    /// step unless complete). Returns whether any work was done.
    pub fn advance(&mut self, budget: Duration) -> Result<bool> {
        let start = Instant::now();
        self.poll_eye_table(false)?;
        let mut worked = false;
        while !self.is_complete() && (!worked || start.elapsed() + self.schedule.last_submit() < budget) {
            crate::interrupt::check()?;
            if worked {
                self.poll_eye_table(false)?;
            }
            self.step()?;
            worked = true;
        }
        Ok(worked)
    }

    /// Runs passes until complete.
    pub fn finish(&mut self) -> Result<()> {
        while !self.is_complete() {
            crate::interrupt::check()?;
            self.poll_eye_table(false)?;
            self.step()?;
        }
        Ok(())
    }

    /// One submission of the wavefront kernels over the current tile of pass `passes`
    /// (sample `pass_sample(passes)` of the lattice); a finished tile is added to the
    /// accumulation.
    fn step(&mut self) -> Result<()> {
        let sample = pass_sample(self.passes, self.opts.spp);
        let base = self.base.for_sample(sample);
        let pass_done = step_tile(
            &self.gpu.ctx,
            &mut self.schedule,
            &self.pipelines,
            &self.buffers,
            &base,
            &self.accumulator,
            &self.accum_bind,
            &mut self.points_traced,
        )?;
        if pass_done {
            self.passes += 1;
        }
        Ok(())
    }

    /// The first `grid` points of accumulation `buffer`, read back.
    fn read_grid(&self, buffer: &wgpu::Buffer, grid: (u32, u32)) -> Result<Vec<u8>> {
        let bytes = grid.0 as u64 * grid.1 as u64 * 16;
        let ctx = &self.gpu.ctx;
        let read = ctx.readback_buffer("accumulation readback", bytes);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buffer, 0, &read, 0, bytes);
        ctx.queue.submit([enc.finish()]);
        ctx.read(&read, bytes)
    }

    /// Rays traced since the session started (all kinds).
    pub fn rays(&self) -> Result<u64> {
        Ok(self.gpu.counters(&self.buffers)?.0.rays.iter().sum())
    }

    /// The average of the passes done as a linear image, computed as the headless
    /// renderer computes its result (f64 average of the grid points).
    pub fn image(&self) -> Result<Image> {
        if self.passes == 0 {
            return Err(Error::Options("no sample has been accumulated yet".into()));
        }
        let data = self.read_grid(&self.accum, self.grid)?;
        Ok(grid_image(&self.opts, &self.scene, bytemuck::cast_slice(&data), self.passes))
    }
}

/// The wavefront kernels of `v`, compiled and warmed up on first use.
fn compile(
    gpu: &GpuRenderer,
    v: Variant,
    form: KernelForm,
    buffers: &SceneBuffers,
    base: &Params,
) -> Result<Vec<StagePipeline>> {
    let pipelines = gpu.pipelines(&Kernel::traced(form, v, false), v)?;
    gpu.warm_up(v, &pipelines, buffers, base)?;
    Ok(pipelines)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toggles_remove_effects() {
        let all = Effects { shadows: true, reflection: true, refraction: true, ..Effects::default() };
        let t = Toggles { reflection: false, ..Toggles::default() };
        let e = t.apply(all);
        assert!(e.shadows && !e.reflection && !e.refraction);
    }
}
