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
//! that depends on the eye (packing the geometry relative to the eye again and, with the
//! direction-cube tables, rebuilding the eye's table), and it restarts the accumulation.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::coherence::reach::WalkBounds;
use crate::coherence::{FlatTables, Tables};
use crate::error::{Error, Result};
use crate::gpu::buffers::check_limits;
use crate::gpu::kernels::compute_pipeline;
use crate::gpu::schedule::{Pacing, Pipelines, Progress, Schedule, WavePlan};
use crate::gpu::shaders::{Kernel, Queries, Stage, Variant};
use crate::gpu::{self, GpuRenderer, SceneBuffers};
use crate::job::{grid_image, Precision, RenderOptions};
use crate::layout::budget::{retry_passes, tile_points, MAX_DEPTH, TESTS_PER_DISPATCH};
use crate::layout::{job_params, pack, Packed, Params};
use crate::output::Image;
use crate::scene::{Camera, Effects, Scene, Transfer};

/// The wall time one submission should take; tiles shrink or grow towards it.
const STEP_TARGET: Duration = Duration::from_millis(30);

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

/// `scene` packed for a `w`×`h` image under `opts` (in f64 for `--precision f64`).
fn pack_scene(scene: &Scene, opts: &RenderOptions, w: u32, h: u32) -> Packed {
    let mut packed = pack(scene, w, h, opts.spawn);
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
        gpu::check(&scene, &opts)?;
        if opts.precision == Precision::F64 && !gpu.ctx.f64 {
            return Err(Error::Options(format!(
                "--precision f64 needs 64-bit floats in shaders (SHADER_F64), which {} does not offer",
                gpu.ctx.info.name
            )));
        }
        let mut packed = pack_scene(&scene, &opts, opts.width, opts.height);
        // Tables for every effect the scene has at any depth, so that toggling one back on
        // or deepening the trees needs none.
        let all = GpuRenderer::variant(scene.effects(), MAX_DEPTH, opts.accel);
        if all.queries == Queries::Bvh {
            packed = packed.with_bvh(&scene);
        }
        let tables = gpu.tables(&scene, &opts, all, &mut packed)?;
        let walks = gpu::walk_bounds(tables.as_ref().map(|t| &t.walks), &packed);
        gpu.check_loop_budget(&scene, walks.as_ref(), Some(MAX_DEPTH))?;
        let first = variant(&scene, &opts, toggles, opts.max_depth, all.queries);
        let tile = tile_points(&scene, walks.as_ref(), TESTS_PER_DISPATCH);
        let sizes = gpu::queue_sizes(&scene, all);
        let buffers = gpu.upload(&packed, tables.as_ref().map(|t| &t.flat), tile, Some(sizes))?;
        buffers.size_queues(&mut packed.params);
        let pipelines = compile(&gpu, first, &buffers, &packed.params)?;
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

    /// The one place where a camera change is handled: the eye-dependent data are
    /// rebuilt (the geometry re-centred on the new eye and uploaded; with the
    /// direction-cube tables, the eye table) and the accumulation restarts. Light and
    /// object data are kept. Returns the time the rebuild took.
    pub fn set_camera(&mut self, camera: Camera) -> Duration {
        let start = Instant::now();
        self.scene.camera = camera;
        if let Err(e) = self.update_eye() {
            log::error!("cannot update the view: {e}");
        }
        self.last_eye_update = start.elapsed();
        self.restart();
        self.last_eye_update
    }

    fn update_eye(&mut self) -> Result<()> {
        let (w, h) = (self.opts.width, self.opts.height);
        let mut packed;
        if let Some(mut tables) = self.tables.take() {
            // The eye's table is rebuilt (the light and surface tables kept while they hold)
            // and uploaded with the re-centred scene.
            packed = pack_scene(&self.scene, &self.opts, w, h);
            let all = Variant::for_effects(self.scene.effects(), MAX_DEPTH).with_queries(Queries::Tables);
            let params = GpuRenderer::variant_build_params(&self.scene, &self.opts, all);
            let eye_only = match tables.rebuild_eye(&self.scene, &params) {
                Ok(eye_only) => eye_only,
                Err(e) => {
                    // Without tables the session falls back to brute force.
                    let brute =
                        variant(&self.scene, &self.opts, self.toggles, self.opts.max_depth, Queries::Brute);
                    self.queries = Queries::Brute;
                    self.walks = None;
                    self.buffers = self.upload(&mut packed, None)?;
                    self.use_kernel(brute)?;
                    self.rebind();
                    return Err(Error::Scene(format!("cannot rebuild the candidate tables: {e}")));
                }
            };
            gpu::point_at(&mut packed.params, &tables.flat);
            gpu::add_surface_bvh(&mut packed, &self.scene, &params);
            self.walks = gpu::walk_bounds(Some(&tables.walks), &packed);
            self.gpu.check_loop_budget(&self.scene, self.walks.as_ref(), Some(MAX_DEPTH))?;
            log::debug!("tables for the new eye in {:.3} s (eye table only: {eye_only})", tables.build_s);
            self.buffers = self.upload(&mut packed, Some(&tables.flat))?;
            self.tables = Some(tables);
            self.rebind();
        } else if self.queries == Queries::Bvh {
            // The BVH is rebuilt over the re-centred scene (in milliseconds) and uploaded with it.
            packed = pack_scene(&self.scene, &self.opts, w, h).with_bvh(&self.scene);
            self.walks = gpu::walk_bounds(None, &packed);
            self.gpu.check_loop_budget(&self.scene, self.walks.as_ref(), Some(MAX_DEPTH))?;
            self.buffers = self.upload(&mut packed, None)?;
            self.rebind();
        } else {
            // Brute force: only the geometry moves (textures do not depend on the eye).
            let textures = std::mem::take(&mut self.scene.textures);
            packed = pack_scene(&self.scene, &self.opts, w, h);
            self.scene.textures = textures;
            let queue = &self.gpu.ctx.queue;
            if !packed.prims.is_empty() {
                queue.write_buffer(&self.buffers.prims, 0, packed.prim_bytes());
            }
            if !packed.lights.is_empty() {
                queue.write_buffer(&self.buffers.lights, 0, bytemuck::cast_slice(&packed.lights));
            }
        }
        let p = &packed.params;
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
        Ok(())
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
        let mut worked = false;
        while !self.is_complete() && (!worked || start.elapsed() + self.schedule.last_submit() < budget) {
            crate::interrupt::check()?;
            self.step()?;
            worked = true;
        }
        Ok(worked)
    }

    /// Runs passes until complete.
    pub fn finish(&mut self) -> Result<()> {
        while !self.is_complete() {
            crate::interrupt::check()?;
            self.step()?;
        }
        Ok(())
    }

    /// One submission of the wavefront kernels over the current tile of pass `passes`
    /// (sample `pass_sample(passes)` of the lattice); a finished tile is added to the
    /// accumulation.
    fn step(&mut self) -> Result<()> {
        let sample = pass_sample(self.passes, self.opts.spp);
        let base = Params { sample_first: sample, sample_end: sample + 1, ..self.base };
        let kernels = Pipelines::Wavefront(&self.pipelines);
        let Progress::TileDone { first, count, pass_done } =
            self.schedule.step(&self.gpu.ctx, &kernels, &self.buffers, &base)?
        else {
            return Ok(());
        };
        let (device, queue) = (&self.gpu.ctx.device, &self.gpu.ctx.queue);
        let tile = Tile { first_point: first as u32, point_count: count, ..Tile::default() };
        queue.write_buffer(&self.tile_buffer, 0, bytemuck::bytes_of(&tile));
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.accumulate);
            pass.set_bind_group(0, &self.accumulate_bind, &[]);
            pass.dispatch_workgroups(count.div_ceil(ACCUMULATE_WORKGROUP), 1, 1);
        }
        queue.submit([enc.finish()]);
        if pass_done {
            self.passes += 1;
        }
        Ok(())
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
        let (gw, gh) = self.grid;
        let bytes = gw as u64 * gh as u64 * 16;
        let ctx = &self.gpu.ctx;
        let read = ctx.readback_buffer("accumulation readback", bytes);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&self.accum, 0, &read, 0, bytes);
        ctx.queue.submit([enc.finish()]);
        let data = ctx.read(&read, bytes)?;
        Ok(grid_image(&self.opts, &self.scene, bytemuck::cast_slice(&data), self.passes))
    }
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
