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

use std::sync::mpsc::{self, Receiver, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::coherence::reach::WalkBounds;
use crate::coherence::{BuildParams, FlatTables, Tables};
use crate::error::{Error, Result};
use crate::gpu::buffers::check_limits;
use crate::gpu::kernels::compute_pipeline;
use crate::gpu::schedule::{Pacing, Pipelines, Progress, Schedule, WavePlan};
use crate::gpu::shaders::{Kernel, Queries, Stage, Variant};
use crate::gpu::{self, GpuRenderer, SceneBuffers};
use crate::job::{grid_image, Precision, RenderOptions};
use crate::layout::budget::{retry_passes, tile_points, MAX_DEPTH, TESTS_PER_DISPATCH};
use crate::layout::bvh::BVH_ORDERS;
use crate::layout::{job_params, pack, pack_moved, Packed, Params};
use crate::output::Image;
use crate::sampling::Sampling;
use crate::scene::{Camera, Effects, Scene, Transfer};

/// The wall time one submission should take; tiles shrink or grow towards it.
const STEP_TARGET: Duration = Duration::from_millis(30);

/// The time a moving camera's coarse image should take; its block grows or shrinks towards
/// it.
pub const COARSE_TARGET: Duration = Duration::from_millis(20);
/// How long the camera rests before the eye's table is rebuilt for it.
const REST_BEFORE_REBUILD: Duration = Duration::from_millis(100);
/// Pixels per coarse block edge: the first, and the range it adapts in.
const FIRST_BLOCK: u32 = 8;
const MIN_BLOCK: u32 = 2;
const MAX_BLOCK: u32 = 32;

/// Which points of the image a finished tile holds, read by the `accumulate` kernel (WGSL
/// `Tile` in `shaders/accumulate.wgsl`, keep them in sync).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Tile {
    pub first_point: u32,
    pub point_count: u32,
    pub pad0: u32,
    pub pad1: u32,
}

/// Invocations per workgroup of the `accumulate` kernel (WGSL `ACCUMULATE_WORKGROUP`).
pub const ACCUMULATE_WORKGROUP: u32 = 64;

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

/// The pass order: `σ(k) = k·g mod n` with `g` coprime to `n` and near `n/φ`.
fn golden_step(n: u32) -> u32 {
    if n <= 2 {
        return 1;
    }
    let gcd = |mut a: u32, mut b: u32| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let g0 = ((n as f64) * 0.618_033_988_749_895).round() as u32;
    (0..n)
        .flat_map(|d| [g0 + d, g0.saturating_sub(d)])
        .find(|&g| g > 0 && g < n && gcd(g, n) == 1)
        .unwrap_or(1)
}

/// The sample rendered by pass `k` of `n`.
pub fn pass_sample(k: u32, n: u32) -> u32 {
    ((k as u64 * golden_step(n) as u64) % n.max(1) as u64) as u32
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
    pipelines: Vec<(Stage, Arc<wgpu::ComputePipeline>)>,
    /// The queries the kernels trace: the tables, the BVH, or brute force (also when the
    /// tables could not be rebuilt for a new eye).
    queries: Queries,
    /// The direction-cube tables (`--accel cube`, the default), or `None`.
    tables: Option<Tables>,
    /// How long the kernels' walks may be (`None`: brute force), for the passes a depth takes.
    walks: Option<WalkBounds>,
    buffers: SceneBuffers,
    /// Params of the whole image (camera, sizes, sampling); tiles fill in the rest.
    base: Params,
    grid: (u32, u32),
    accum: wgpu::Buffer,
    tile_buffer: wgpu::Buffer,
    accumulate: wgpu::ComputePipeline,
    accumulate_bind: wgpu::BindGroup,
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

/// An eye-table rebuild running on a worker thread for camera change `generation`.
struct EyeBuild {
    generation: u64,
    result: Receiver<Result<Tables>>,
}

/// The coarse image of a moving camera: one eye ray per `block`×`block` pixels, traced whole
/// in one frame into an accumulation of its own.
struct Coarse {
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
    complete: bool,
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

/// What the preview's eye table is doing, for the title and the frame log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EyeTable {
    /// Rebuilding for a moved camera; the BVH traces meanwhile.
    Building,
    /// The tables trace.
    Ready,
    /// The session traces without tables (`--accel bvh` or `brute`, or a failed rebuild).
    None,
}

impl EyeTable {
    pub fn name(self) -> &'static str {
        match self {
            EyeTable::Building => "building",
            EyeTable::Ready => "ready",
            EyeTable::None => "none",
        }
    }
}

/// The kernels' variant for the session's toggles and depth.
fn variant(
    scene: &Scene,
    opts: &RenderOptions,
    toggles: Toggles,
    max_depth: u32,
    queries: Queries,
) -> Variant {
    let v = Variant::for_effects(toggles.apply(scene.effects()), max_depth)
        .with_queries(queries)
        .with_f64(opts.precision == Precision::F64);
    GpuRenderer::for_scene(scene, opts, v)
}

/// The build parameters of the session's tables: every effect the scene has, at any depth,
/// so that toggling one back on or deepening the trees needs no new table.
fn eye_build_params(scene: &Scene, opts: &RenderOptions) -> BuildParams {
    let all = Variant::for_effects(scene.effects(), MAX_DEPTH).with_queries(Queries::Tables);
    GpuRenderer::variant_build_params(scene, opts, all)
}

/// The walks the kernels of `packed` take: the tables' (if any), and the BVH's where rays
/// walk it (the BVH a preview keeps for camera moves is not walked beside the tables when
/// no ray leaves a surface).
fn traced_walks(tables: Option<&WalkBounds>, packed: &Packed) -> Option<WalkBounds> {
    match tables {
        Some(t) if packed.params.surface_bvh == 0 => Some(*t),
        t => gpu::walk_bounds(t, packed),
    }
}

/// Gives `packed` (of `scene`) a BVH, and room after it for the BVH of any camera (a binary
/// tree over n primitives has at most 2n − 1 nodes in each order), so that a camera move
/// writes its BVH into the buffers in place: new buffers would cost the zeroing of a
/// tile's queues, a stall of about 50 ms on lavapipe. The tables' kernels ignore it.
fn make_room_for_moves(packed: &mut Packed, scene: &Scene) {
    if packed.bvh.is_none() {
        packed.add_bvh(scene);
    }
    if let Some(b) = packed.bvh.as_mut() {
        let most = BVH_ORDERS * (2 * scene.primitives.len()).saturating_sub(1);
        b.nodes.resize(b.nodes.len().max(most), Default::default());
    }
}

/// Gives the candidate list of `flat` room after its end (a quarter more, within the
/// adapter's binding limit), so that the eye's table rebuilt for another camera, whose list
/// may come out longer, is written into the same buffer. The walks never read past a
/// cell's own entries.
fn make_room_for_eye_tables(flat: &mut FlatTables, limits: &wgpu::Limits) {
    let entry = std::mem::size_of::<crate::coherence::flat::GpuEntry>() as u64;
    let most = (limits.max_storage_buffer_binding_size.min(limits.max_buffer_size) / entry) as usize;
    let len = flat.entries.len();
    flat.entries.resize((len + len / 4 + 64).min(most).max(len), Default::default());
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

impl Session {
    /// Uploads `scene` for `opts` (the image size, the lattice `opts.spp` and seed, the
    /// depth); the session completes after `limit` passes (at most `opts.spp`).
    pub fn new(
        gpu: Arc<GpuRenderer>,
        scene: Scene,
        opts: RenderOptions,
        toggles: Toggles,
        limit: u32,
    ) -> Result<Session> {
        let opts = opts.resolved(&scene);
        gpu::check(&scene, &opts)?;
        gpu::check_f64(&gpu.ctx, &opts)?;
        let mut packed = pack_scene(&scene, &opts, opts.width, opts.height, true);
        // Tables for every effect the scene has at any depth, so that toggling one back on
        // or deepening the trees needs none.
        let all = GpuRenderer::variant(scene.effects(), MAX_DEPTH, opts.accel);
        if all.queries == Queries::Bvh {
            packed = packed.with_bvh(&scene);
        }
        let mut tables = gpu.tables(&scene, &opts, all, &mut packed)?;
        let walks = gpu::walk_bounds(tables.as_ref().map(|t| &t.walks), &packed);
        gpu.check_loop_budget(&scene, walks.as_ref(), Some(MAX_DEPTH))?;
        let first = variant(&scene, &opts, toggles, opts.max_depth, all.queries);
        let tile = tile_points(&scene, walks.as_ref(), TESTS_PER_DISPATCH);
        let sizes = gpu::queue_sizes(&scene, all);
        let wants_tables = all.queries == Queries::Tables && tables.is_some();
        if wants_tables || all.queries == Queries::Bvh {
            make_room_for_moves(&mut packed, &scene);
        }
        if wants_tables {
            if let Some(t) = tables.as_mut() {
                make_room_for_eye_tables(&mut t.flat, &gpu.ctx.device.limits());
            }
        }
        let buffers = gpu.upload(&packed, tables.as_ref().map(|t| &t.flat), tile, Some(sizes))?;
        buffers.size_queues(&mut packed.params);
        let pipelines = compile(&gpu, first, &buffers, &packed.params)?;
        if wants_tables {
            // The kernels a camera move traces with while the eye's table is rebuilt.
            compile(
                &gpu,
                variant(&scene, &opts, toggles, opts.max_depth, Queries::Bvh),
                &buffers,
                &packed.params,
            )?;
        }
        let grid = opts.grid();
        let ctx = &gpu.ctx;
        let total = grid.0 as u64 * grid.1 as u64;
        check_limits(&[("preview accumulation", total * 16)], &ctx.device.limits())?;
        let accum = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("preview accumulation"),
            size: total * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let tile_buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("accumulate tile"),
            size: std::mem::size_of::<Tile>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let accumulate = compute_pipeline(ctx, Kernel::Accumulate, Variant::default(), None)?;
        let accumulate_bind = accumulate_bind(ctx, &accumulate, &tile_buffer, &buffers, &accum);
        let plan = WavePlan::new(first, opts.max_depth, retry_passes(&scene, walks.as_ref()));
        let schedule = Schedule::new(
            ctx,
            total,
            buffers.tile,
            Some(plan),
            Pacing::Adaptive { target: STEP_TARGET },
            false,
        );
        let mut s = Session {
            base: job_params(&opts, packed.params),
            gpu,
            limit: limit.min(opts.spp),
            scene,
            opts,
            toggles,
            pipelines,
            queries: all.queries,
            tables,
            walks,
            buffers,
            grid,
            accum,
            tile_buffer,
            accumulate,
            accumulate_bind,
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

    /// What the eye's table is doing.
    pub fn eye_table(&self) -> EyeTable {
        if self.eye_build.is_some()
            || self.eye_ready.is_some()
            || (self.wants_tables && self.queries != Queries::Tables)
        {
            EyeTable::Building
        } else if self.queries == Queries::Tables {
            EyeTable::Ready
        } else {
            EyeTable::None
        }
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
        if self.wants_tables || self.queries == Queries::Bvh {
            // The BVH over the re-centred scene (in milliseconds) traces at once; with the
            // tables, the eye's table follows from a worker thread once the camera rests.
            let t0 = Instant::now();
            let mut packed = self.pack_moved();
            make_room_for_moves(&mut packed, &self.scene);
            let t1 = Instant::now();
            self.install(Queries::Bvh, packed, None)?;
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
            queue.write_buffer(&self.buffers.prims, 0, packed.prim_bytes());
        }
        if !packed.lights.is_empty() {
            queue.write_buffer(&self.buffers.lights, 0, bytemuck::cast_slice(&packed.lights));
        }
        self.set_base(&packed.params);
        Ok(())
    }

    /// Rebuilds the eye's table of `tables` for the current camera on a worker thread.
    fn start_eye_build(&mut self, mut tables: Tables) {
        let generation = self.camera_generation;
        // The tables never read the textures: the worker gets the scene without them.
        let textures = std::mem::take(&mut self.scene.textures);
        let scene = self.scene.clone();
        self.scene.textures = textures;
        let opts = self.opts.clone();
        let (send, result) = mpsc::channel();
        let spawned = std::thread::Builder::new().name("eye table".into()).spawn(move || {
            let params = eye_build_params(&scene, &opts);
            let built = tables.rebuild_eye(&scene, &params).map(|eye_only| {
                log::debug!(
                    "eye table for camera change {generation} in {:.3} s (eye table only: {eye_only})",
                    tables.build_s
                );
                tables
            });
            let _ = send.send(built);
        });
        match spawned {
            Ok(_) => self.eye_build = Some(EyeBuild { generation, result }),
            Err(e) => {
                log::error!("cannot start the eye table's worker ({e}): tracing with the BVH");
                self.wants_tables = false;
            }
        }
    }

    /// Takes a finished eye-table build: tables for the current camera are swapped in at
    /// the next pass boundary, tables for an older camera go back for another rebuild.
    fn poll_eye_table(&mut self, force: bool) -> Result<()> {
        let resting = force || self.last_move.elapsed() >= REST_BEFORE_REBUILD;
        if self.wants_tables && self.eye_build.is_none() && self.queries != Queries::Tables && resting {
            // The camera rests (this runs between its frames' passes, not while it moves,
            // and once it has rested a while: a build a drag overtakes cannot be stopped
            // and takes a core from the kernels): the eye's table is rebuilt for it.
            if let Some(tables) = self.tables.take() {
                self.start_eye_build(tables);
            }
        }
        if let Some(build) = &self.eye_build {
            let built = match build.result.try_recv() {
                Ok(built) => Some(built),
                Err(TryRecvError::Empty) => None,
                Err(TryRecvError::Disconnected) => {
                    Some(Err(Error::Scene("the eye table's worker stopped without a result".into())))
                }
            };
            if let Some(built) = built {
                let generation = build.generation;
                self.take_build(generation, built);
            }
        }
        if self.eye_ready.is_some() && self.schedule.at_pass_start() {
            let mut tables = self.eye_ready.take().expect("checked");
            let mut packed = self.pack_moved();
            gpu::point_at(&mut packed.params, &tables.flat);
            gpu::add_surface_bvh(&mut packed, &self.scene, &eye_build_params(&self.scene, &self.opts));
            make_room_for_moves(&mut packed, &self.scene);
            if let Err(e) = self.install(Queries::Tables, packed, Some(&mut tables)) {
                log::warn!("cannot trace the rebuilt tables ({e}): tracing with the BVH");
                self.wants_tables = false;
            }
            self.tables = Some(tables);
        }
        Ok(())
    }

    /// The end of the eye-table build for camera change `generation`: tables for the
    /// current camera wait for a pass boundary, older ones go back for another rebuild, and
    /// a failed rebuild leaves the session on the BVH.
    fn take_build(&mut self, generation: u64, built: Result<Tables>) {
        self.eye_build = None;
        match built {
            Ok(tables) if generation == self.camera_generation => self.eye_ready = Some(tables),
            // The camera moved on: rebuilt again once it rests (`poll_eye_table`).
            Ok(tables) => self.tables = Some(tables),
            Err(e) => {
                log::warn!("cannot rebuild the candidate tables: {e}; tracing with the BVH");
                self.wants_tables = false;
            }
        }
    }

    /// Traces with `queries` over `packed` (and `tables`) from now on. The loop budget is
    /// checked and the kernels compiled first, so that a failure leaves the session as it
    /// was; then `packed` and `tables` are written into the buffers in place where they fit
    /// (new buffers cost the zeroing of a tile's queues, a stall of about 50 ms on
    /// lavapipe), else into new ones, the tables' made with room
    /// ([`make_room_for_eye_tables`]); the waves' plan and the params follow. Between
    /// passes the accumulation stays valid: every accelerator gives the same pixels.
    fn install(
        &mut self,
        queries: Queries,
        mut packed: Packed,
        mut tables: Option<&mut Tables>,
    ) -> Result<()> {
        let walks = traced_walks(tables.as_ref().map(|t| &t.walks), &packed);
        self.gpu.check_loop_budget(&self.scene, walks.as_ref(), Some(MAX_DEPTH))?;
        let v = variant(&self.scene, &self.opts, self.toggles, self.opts.max_depth, queries);
        let pipelines = compile(&self.gpu, v, &self.buffers, &self.base)?;
        let ctx = &self.gpu.ctx;
        let in_place = tables.as_ref().is_none_or(|t| self.buffers.rewrite_tables(ctx, &t.flat))
            && self.buffers.rewrite_moved(ctx, &packed);
        if in_place {
            self.buffers.size_queues(&mut packed.params);
        } else {
            log::debug!("new buffers for the {} kernels", queries.name());
            if let Some(t) = tables.as_mut() {
                make_room_for_eye_tables(&mut t.flat, &ctx.device.limits());
            }
            packed.add_fixed(&self.scene);
            self.buffers = self.upload(&mut packed, tables.as_ref().map(|t| &t.flat))?;
            self.rebind();
        }
        self.pipelines = pipelines;
        self.queries = queries;
        self.walks = walks;
        let retries = retry_passes(&self.scene, self.walks.as_ref());
        self.schedule.set_plan(&self.gpu.ctx, WavePlan::new(v, self.opts.max_depth, retries));
        self.set_base(&packed.params);
        Ok(())
    }

    /// The camera, table and BVH parts of `p` (freshly packed) into the session's params.
    fn set_base(&mut self, p: &Params) {
        self.base = Params {
            cam_forward: p.cam_forward,
            cam_scale: p.cam_scale,
            cam_right: p.cam_right,
            cam_up: p.cam_up,
            half_w: p.half_w,
            half_h: p.half_h,
            ortho: p.ortho,
            eye_origin: p.eye_origin,
            fallback_origin: p.fallback_origin,
            bvh_stride: p.bvh_stride,
            bvh_inline: p.bvh_inline,
            surface_bvh: p.surface_bvh,
            ray_queue: self.buffers.ray_queue,
            shadow_queue: self.buffers.shadow_queue,
            ..self.base
        };
    }

    /// Uploads `packed` (with `tables`) into buffers with the queues of the scene's every
    /// effect, for tiles as large as the current ones; sets the queues' sizes in `packed`.
    fn upload(&self, packed: &mut Packed, tables: Option<&FlatTables>) -> Result<SceneBuffers> {
        let all = GpuRenderer::variant(self.scene.effects(), MAX_DEPTH, self.opts.accel);
        let sizes = gpu::queue_sizes(&self.scene, all);
        let buffers = self.gpu.upload(packed, tables, self.buffers.tile, Some(sizes))?;
        buffers.size_queues(&mut packed.params);
        Ok(buffers)
    }

    /// Points the accumulation pass at the current output buffer.
    fn rebind(&mut self) {
        self.accumulate_bind =
            accumulate_bind(&self.gpu.ctx, &self.accumulate, &self.tile_buffer, &self.buffers, &self.accum);
    }

    /// Switches effects on or off and sets the maximum depth; restarts the
    /// accumulation. The kernels of a new combination are compiled on first use.
    pub fn set_effects(&mut self, toggles: Toggles, max_depth: u32) -> Result<()> {
        let mut opts = self.opts.clone();
        opts.max_depth = max_depth;
        gpu::check(&self.scene, &opts)?;
        let v = variant(&self.scene, &opts, toggles, max_depth, self.queries);
        self.use_kernel(v)?;
        self.toggles = toggles;
        self.opts = opts;
        if let Some(c) = self.coarse.as_mut() {
            // The coarse image shows the old effects: not shown again.
            c.complete = false;
        }
        self.base.max_depth = max_depth;
        let retries = retry_passes(&self.scene, self.walks.as_ref());
        let plan = WavePlan::new(v, max_depth, retries);
        self.schedule.set_plan(&self.gpu.ctx, plan);
        self.restart();
        Ok(())
    }

    /// Traces with the wavefront kernels of `v` from now on, compiled and warmed up on first
    /// use.
    fn use_kernel(&mut self, v: Variant) -> Result<()> {
        self.pipelines = compile(&self.gpu, v, &self.buffers, &self.base)?;
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

    /// Waits for the eye table's rebuild, if one runs, and traces with the tables from the
    /// next pass boundary on (tests, and a preview about to exit).
    pub fn wait_for_eye_table(&mut self) -> Result<()> {
        loop {
            self.poll_eye_table(true)?;
            let Some(build) = &self.eye_build else { return Ok(()) };
            let built = build
                .result
                .recv()
                .map_err(|_| Error::Scene("the eye table's worker stopped without a result".into()));
            let generation = build.generation;
            self.take_build(generation, built.and_then(|b| b));
        }
    }

    /// One submission of the wavefront kernels over the current tile of pass `passes`
    /// (sample `pass_sample(passes)` of the lattice); a finished tile is added to the
    /// accumulation.
    fn step(&mut self) -> Result<()> {
        let sample = pass_sample(self.passes, self.opts.spp);
        let base = Params { sample_first: sample, sample_end: sample + 1, ..self.base };
        let pass_done = step_tile(
            &self.gpu.ctx,
            &mut self.schedule,
            &self.pipelines,
            &self.buffers,
            &base,
            (&self.tile_buffer, &self.accumulate, &self.accumulate_bind),
            &mut self.points_traced,
        )?;
        if pass_done {
            self.passes += 1;
        }
        Ok(())
    }

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
        params.max_depth = depth;
        let ctx = &self.gpu.ctx;
        let plan = WavePlan::new(
            variant(&self.scene, &self.opts, self.toggles, self.opts.max_depth, self.queries),
            depth,
            retry_passes(&self.scene, self.walks.as_ref()),
        );
        if self.coarse.as_ref().is_none_or(|c| c.grid != grid) {
            let (w, h) = (self.opts.width, self.opts.height);
            let capacity = (w.div_ceil(MIN_BLOCK) + 1) as u64 * (h.div_ceil(MIN_BLOCK) + 1) as u64;
            let accum = match self.coarse.take() {
                Some(c) => c.accum,
                None => ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("preview coarse accumulation"),
                    size: capacity * 16,
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_SRC
                        | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
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
        let bind = accumulate_bind(ctx, &self.accumulate, &self.tile_buffer, &self.buffers, &c.accum);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&c.accum, 0, None);
        ctx.queue.submit([enc.finish()]);
        loop {
            crate::interrupt::check()?;
            let accumulate = (&self.tile_buffer, &self.accumulate, &bind);
            let done = step_tile(
                ctx,
                &mut c.schedule,
                &self.pipelines,
                &self.buffers,
                &params,
                accumulate,
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

    /// The params and grid of the coarse image with one eye ray per `block`×`block` pixels:
    /// grid point (i, j) takes the ray through the centre of pixel (i·b + b/2, j·b + b/2),
    /// the very ray (bit for bit: `block` is a power of two) of that pixel in a full pass
    /// with one sample at the pixel centres. The kernels place grid point i at i + 1/2, so
    /// the image's centre moves to (half − 1/2)/b and a grid step spans b pixels.
    fn coarse_params(&self, block: u32) -> (Params, (u32, u32)) {
        let (w, h) = (self.opts.width, self.opts.height);
        let grid = (w.div_ceil(block), h.div_ceil(block));
        let b = block as f32;
        let camera = Params {
            half_w: (self.base.half_w - 0.5) / b,
            half_h: (self.base.half_h - 0.5) / b,
            cam_scale: self.base.cam_scale * b,
            ..self.base
        };
        (Params { sample_first: 0, sample_end: 1, ..job_params(&self.coarse_options(grid), camera) }, grid)
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

/// One submission of `schedule` over the kernels `pipelines`; a finished tile is added
/// to the accumulation that `accumulate`'s bind group names, and its points to
/// `points_traced`. Returns whether the tile ended a pass.
fn step_tile(
    ctx: &gpu::GpuContext,
    schedule: &mut Schedule,
    pipelines: &[(Stage, Arc<wgpu::ComputePipeline>)],
    buffers: &SceneBuffers,
    base: &Params,
    accumulate: (&wgpu::Buffer, &wgpu::ComputePipeline, &wgpu::BindGroup),
    points_traced: &mut u64,
) -> Result<bool> {
    let (tile_buffer, pipeline, bind) = accumulate;
    let kernels = Pipelines::Wavefront(pipelines);
    let Progress::TileDone { first, count, pass_done } = schedule.step(ctx, &kernels, buffers, base)? else {
        return Ok(false);
    };
    let tile = Tile { first_point: first as u32, point_count: count, ..Tile::default() };
    ctx.queue.write_buffer(tile_buffer, 0, bytemuck::bytes_of(&tile));
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(count.div_ceil(ACCUMULATE_WORKGROUP), 1, 1);
    }
    ctx.queue.submit([enc.finish()]);
    *points_traced += count as u64;
    Ok(pass_done)
}

/// The wavefront kernels of `v`, compiled and warmed up on first use.
fn compile(
    gpu: &GpuRenderer,
    v: Variant,
    buffers: &SceneBuffers,
    base: &Params,
) -> Result<Vec<(Stage, Arc<wgpu::ComputePipeline>)>> {
    let pipelines = gpu.pipelines(&Kernel::wavefront(v), v)?;
    gpu.warm_up(v, &pipelines, buffers, base)?;
    Ok(pipelines)
}

/// The accumulation pass's bind group: the tile, the kernels' output, the
/// accumulation.
fn accumulate_bind(
    ctx: &gpu::GpuContext,
    accumulate: &wgpu::ComputePipeline,
    tile: &wgpu::Buffer,
    buffers: &SceneBuffers,
    accum: &wgpu::Buffer,
) -> wgpu::BindGroup {
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("accumulate"),
        layout: &accumulate.get_bind_group_layout(0),
        entries: &[(0, tile), (1, &buffers.out), (2, accum)]
            .map(|(binding, b)| wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_order_is_a_permutation() {
        for n in 1..200 {
            let mut seen = vec![false; n as usize];
            for k in 0..n {
                let s = pass_sample(k, n);
                assert!(!seen[s as usize], "n = {n}: sample {s} twice");
                seen[s as usize] = true;
            }
        }
    }

    #[test]
    fn early_passes_spread_over_the_pixel() {
        // The first quarter of the passes reaches both halves of the x strata.
        let n = 64;
        let first: Vec<u32> = (0..16).map(|k| pass_sample(k, n)).collect();
        assert!(first.iter().any(|&s| s < n / 2) && first.iter().any(|&s| s >= n / 2), "{first:?}");
    }

    #[test]
    fn toggles_remove_effects() {
        let all = Effects { shadows: true, reflection: true, refraction: true, ..Effects::default() };
        let t = Toggles { reflection: false, ..Toggles::default() };
        let e = t.apply(all);
        assert!(e.shadows && !e.reflection && !e.refraction);
    }
}
