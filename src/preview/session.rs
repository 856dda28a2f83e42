//! Progressive rendering on the GPU, independent of any window: a [`Session`] runs the
//! headless renderer's `render` kernel one sample pass at a time, tile by tile and step
//! by step, and adds each finished tile to a whole-image accumulation buffer.
//!
//! Pass `k` renders sample `σ(k)` of the same `spp`-sample lattice and seed as
//! `cuberay render --spp N`, where `σ` is a golden-ratio permutation of `0..spp`: any
//! prefix of passes is spread over the pixel (not only its left part), and after `spp`
//! passes the accumulation holds the same samples as the headless render, summed in
//! another order (equal up to f32 rounding).
//!
//! Only [`Session::set_camera`] does the work that depends on the eye (today: packing the
//! geometry relative to the eye again; with direction-cube tables: rebuilding the eye
//! table), and it restarts the accumulation.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::error::{Error, Result};
use crate::gpu::layout::{self, Params, PointState};
use crate::gpu::shader::Variant;
use crate::gpu::{self, GpuRenderer, GpuTables, Kernels, SceneBuffers, MAX_DEPTH, WORKGROUP};
use crate::job::RenderOptions;
use crate::output::Image;
use crate::sampling::{self, Sampling};
use crate::scene::{Camera, Effects, Scene};

/// The WGSL of the preview's own passes (accumulation and display).
pub const SHADER: &str = include_str!("../../shaders/preview.wgsl");

/// Primitive tests per dispatch the tile buffers are sized for (as the headless renderer).
const TESTS_PER_DISPATCH: u64 = 1 << 24;

/// The wall time one step should take; tiles shrink or grow towards it.
const STEP_TARGET: Duration = Duration::from_millis(30);

/// The smallest tile (grid points).
const MIN_TILE: u64 = WORKGROUP as u64;

/// The most `render` dispatches in one submission.
const MAX_DISPATCHES: u32 = 16;

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
    kernels: Arc<Kernels>,
    /// The direction-cube tables (`--accel cube`, the default), or `None` for brute force.
    tables: Option<GpuTables>,
    buffers: SceneBuffers,
    /// Params of the whole image (camera, sizes, sampling); tiles fill in the rest.
    base: Params,
    grid: (u32, u32),
    accum: wgpu::Buffer,
    tile_uniform: wgpu::Buffer,
    accumulate: wgpu::ComputePipeline,
    accumulate_bind: wgpu::BindGroup,
    active_read: wgpu::Buffer,
    counters_read: wgpu::Buffer,
    /// Passes complete.
    passes: u32,
    /// The first point of the current or next tile, and the current tile's size (0: none
    /// started).
    next_point: u64,
    tile_count: u64,
    /// Points of the next tile and dispatches per submission, adapted to [`STEP_TARGET`].
    tile_size: u64,
    dispatches: u32,
    /// How long the last submission took to finish.
    last_step: Duration,
    /// Time of the last eye-dependent update.
    pub last_eye_update: Duration,
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
        let cube = gpu::uses_tables(opts.accel);
        let mut packed = layout::pack(&scene, opts.width, opts.height);
        // Tables for every effect the scene has at any depth, so that toggling one back on
        // or deepening the trees needs none.
        let all = Variant::for_effects(scene.effects(), MAX_DEPTH).with_cube(cube);
        let tables = gpu.tables(&scene, opts.width, opts.height, all, &mut packed.params)?;
        gpu.check_loop_budget(&scene, tables.as_ref(), Some(MAX_DEPTH))?;
        let variant = Variant::for_effects(toggles.apply(scene.effects()), opts.max_depth).with_cube(cube);
        let kernels = gpu.kernels(variant)?;
        let tile = gpu::tile_points(&scene, tables.as_ref(), TESTS_PER_DISPATCH);
        let buffers = gpu.upload(&packed, tables.as_ref(), tile, true);
        let corners = opts.sampling == Sampling::Corners;
        let grid = if corners { (opts.width + 1, opts.height + 1) } else { (opts.width, opts.height) };
        let device = &gpu.ctx.device;
        let total = grid.0 as u64 * grid.1 as u64;
        let accum = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("preview accumulation"),
            size: total * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let tile_uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("preview tile"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cuberay preview"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let accumulate = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("accumulate"),
            layout: None,
            module: &module,
            entry_point: Some("accumulate"),
            compilation_options: Default::default(),
            cache: None,
        });
        let accumulate_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("accumulate"),
            layout: &accumulate.get_bind_group_layout(0),
            entries: &[(0, &tile_uniform), (1, &buffers.out), (2, &accum)]
                .map(|(binding, b)| wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }),
        });
        let read_buffer = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let active_read = read_buffer("active readback", 4);
        let counters_read = read_buffer("counters readback", (gpu::COUNTER_SLOTS * 8) as u64);
        let seed_hash = sampling::seed_hash(opts.seed);
        let base = Params {
            grid_w: grid.0,
            grid_h: grid.1,
            spp: opts.spp,
            lattice_g: if opts.spp > 1 { sampling::lattice_generator(opts.spp) } else { 1 },
            seed_hash,
            corners: corners as u32,
            max_depth: opts.max_depth,
            ..packed.params
        };
        let mut s = Session {
            gpu,
            limit: limit.min(opts.spp),
            scene,
            opts,
            toggles,
            kernels,
            tables,
            buffers,
            base,
            grid,
            accum,
            tile_uniform,
            accumulate,
            accumulate_bind,
            active_read,
            counters_read,
            passes: 0,
            next_point: 0,
            tile_count: 0,
            tile_size: tile.min(4096),
            dispatches: 1,
            last_step: Duration::ZERO,
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
        let queue = &self.gpu.ctx.queue;
        let mut packed;
        if let Some(old) = self.tables.take() {
            // The eye's table is rebuilt (the light and surface tables kept while they hold)
            // and uploaded with the re-centred scene.
            packed = layout::pack(&self.scene, w, h);
            let all = Variant::for_effects(self.scene.effects(), MAX_DEPTH).with_cube(true);
            let (tables, eye_only) = match old.rebuild_eye(&self.scene, w, h, all) {
                Ok(t) => t,
                Err(e) => {
                    // Without tables the session falls back to brute force.
                    let variant =
                        Variant::for_effects(self.toggles.apply(self.scene.effects()), self.opts.max_depth);
                    self.kernels = self.gpu.kernels(variant)?;
                    self.buffers = self.gpu.upload(&packed, None, self.buffers.tile, true);
                    self.rebind();
                    return Err(Error::Scene(format!("cannot rebuild the candidate tables: {e}")));
                }
            };
            packed.params.eye_origin = tables.flat.eye_origin;
            packed.params.fallback_origin = tables.fallback;
            self.gpu.check_loop_budget(&self.scene, Some(&tables), Some(MAX_DEPTH))?;
            log::debug!("tables for the new eye in {:.3} s (eye table only: {eye_only})", tables.build_s);
            self.buffers = self.gpu.upload(&packed, Some(&tables), self.buffers.tile, true);
            self.tables = Some(tables);
            self.rebind();
        } else {
            // Brute force: only the geometry moves (textures do not depend on the eye).
            let textures = std::mem::take(&mut self.scene.textures);
            packed = layout::pack(&self.scene, w, h);
            self.scene.textures = textures;
            if !packed.prims.is_empty() {
                queue.write_buffer(&self.buffers.prims, 0, bytemuck::cast_slice(&packed.prims));
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
            ..self.base
        };
        Ok(())
    }

    /// Points the accumulation pass at the current output buffer.
    fn rebind(&mut self) {
        self.accumulate_bind = self.gpu.ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("accumulate"),
            layout: &self.accumulate.get_bind_group_layout(0),
            entries: &[(0, &self.tile_uniform), (1, &self.buffers.out), (2, &self.accum)]
                .map(|(binding, b)| wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }),
        });
    }

    /// Switches effects on or off and sets the maximum depth; restarts the
    /// accumulation. The kernels of a new combination are compiled on first use.
    pub fn set_effects(&mut self, toggles: Toggles, max_depth: u32) -> Result<()> {
        let mut opts = self.opts.clone();
        opts.max_depth = max_depth;
        gpu::check(&self.scene, &opts)?;
        let variant = Variant::for_effects(toggles.apply(self.scene.effects()), max_depth)
            .with_cube(self.tables.is_some());
        self.kernels = self.gpu.kernels(variant)?;
        self.toggles = toggles;
        self.opts = opts;
        self.base.max_depth = max_depth;
        self.restart();
        Ok(())
    }

    /// Drops the accumulation and starts again from pass 0.
    pub fn restart(&mut self) {
        let mut enc = self.gpu.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&self.accum, 0, None);
        self.gpu.ctx.queue.submit([enc.finish()]);
        self.passes = 0;
        self.next_point = 0;
        self.tile_count = 0;
    }

    /// Runs steps while another one is expected to end within `budget` (at least one
    /// step unless complete). Returns whether any work was done.
    pub fn advance(&mut self, budget: Duration) -> Result<bool> {
        let start = Instant::now();
        let mut worked = false;
        while !self.is_complete() && (!worked || start.elapsed() + self.last_step < budget) {
            self.step()?;
            worked = true;
        }
        Ok(worked)
    }

    /// Runs passes until complete.
    pub fn finish(&mut self) -> Result<()> {
        while !self.is_complete() {
            self.step()?;
        }
        Ok(())
    }

    /// One dispatch of the `render` kernel over the current tile (starting it if
    /// needed); a finished tile is added to the accumulation.
    fn step(&mut self) -> Result<()> {
        let device = &self.gpu.ctx.device;
        let queue = &self.gpu.ctx.queue;
        let total = self.grid.0 as u64 * self.grid.1 as u64;
        let mut enc = device.create_command_encoder(&Default::default());
        if self.tile_count == 0 {
            self.tile_count = self.tile_size.min(total - self.next_point);
            let sample = pass_sample(self.passes, self.opts.spp);
            let p = Params {
                first_point: self.next_point as u32,
                point_count: self.tile_count as u32,
                sample_first: sample,
                sample_end: sample + 1,
                ..self.base
            };
            queue.write_buffer(&self.buffers.params, 0, bytemuck::bytes_of(&p));
            let state_bytes = std::mem::size_of::<PointState>() as u64;
            enc.clear_buffer(&self.buffers.states, 0, Some(self.tile_count * state_bytes));
        }
        let count = self.tile_count as u32;
        // Several dispatches per submission save a wait each; dispatches after a tile is
        // done change nothing (`active` counts the last one).
        for _ in 0..self.dispatches {
            enc.clear_buffer(&self.buffers.active, 0, None);
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(self.kernels.render());
            pass.set_bind_group(0, &self.buffers.bind, &[]);
            pass.dispatch_workgroups(count.div_ceil(WORKGROUP), 1, 1);
        }
        enc.copy_buffer_to_buffer(&self.buffers.active, 0, &self.active_read, 0, 4);
        let start = Instant::now();
        queue.submit([enc.finish()]);
        let left = u32::from_le_bytes(self.gpu.read(&self.active_read, 4)?.try_into().expect("4 bytes"));
        let took = start.elapsed();
        self.last_step = took;
        log::trace!(
            "step: {count} points x {} dispatches, {:.1} ms, {left} left",
            self.dispatches,
            took.as_secs_f64() * 1e3
        );
        // Aim at the step target: larger tiles first, then more dispatches per submission.
        if took > STEP_TARGET * 2 {
            if self.dispatches > 1 {
                self.dispatches /= 2;
            } else {
                self.tile_size = (self.tile_size / 2).max(MIN_TILE);
            }
        } else if took < STEP_TARGET / 2 {
            if self.tile_size < self.buffers.tile {
                self.tile_size = (self.tile_size * 2).min(self.buffers.tile);
            } else {
                self.dispatches = (self.dispatches * 2).min(MAX_DISPATCHES);
            }
        }
        if left == 0 {
            let tile = [self.next_point as u32, count, 0, 0];
            queue.write_buffer(&self.tile_uniform, 0, bytemuck::cast_slice(&tile));
            let mut enc = device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(&self.accumulate);
                pass.set_bind_group(0, &self.accumulate_bind, &[]);
                pass.dispatch_workgroups(count.div_ceil(64), 1, 1);
            }
            queue.submit([enc.finish()]);
            self.next_point += self.tile_count;
            self.tile_count = 0;
            if self.next_point == total {
                self.next_point = 0;
                self.passes += 1;
            }
        }
        Ok(())
    }

    /// Rays traced since the session started (all kinds).
    pub fn rays(&self) -> Result<u64> {
        let bytes = (gpu::COUNTER_SLOTS * 8) as u64;
        let mut enc = self.gpu.ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&self.buffers.counters, 0, &self.counters_read, 0, bytes);
        self.gpu.ctx.queue.submit([enc.finish()]);
        let c = gpu::decode_counters(&self.gpu.read(&self.counters_read, bytes)?);
        Ok(c.rays.iter().sum())
    }

    /// The average of the passes done as a linear image, computed as the headless
    /// renderer computes its result (f64 average of the grid points).
    pub fn image(&self) -> Result<Image> {
        if self.passes == 0 {
            return Err(Error::Options("no sample has been accumulated yet".into()));
        }
        let (gw, gh) = self.grid;
        let bytes = gw as u64 * gh as u64 * 16;
        let (w, h) = (self.opts.width, self.opts.height);
        let device = &self.gpu.ctx.device;
        let read = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("accumulation readback"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&self.accum, 0, &read, 0, bytes);
        self.gpu.ctx.queue.submit([enc.finish()]);
        let data = self.gpu.read(&read, bytes)?;
        let values: &[[f32; 4]] = bytemuck::cast_slice(&data);
        let at = |i: u32, j: u32, c: usize| values[(j * gw + i) as usize][c] as f64;
        let corners = self.opts.sampling == Sampling::Corners;
        let mut image = Image::new(w, h, false);
        for j in 0..h {
            for i in 0..w {
                let mut px = [0.0f32, 0.0, 0.0, 1.0];
                for (c, v) in px.iter_mut().take(3).enumerate() {
                    *v = if corners {
                        (at(i, j, c) + at(i + 1, j, c) + at(i, j + 1, c) + at(i + 1, j + 1, c)) * 0.25
                    } else {
                        at(i, j, c) / self.passes as f64
                    } as f32;
                }
                image.pixels[(j * w + i) as usize] = px;
            }
        }
        Ok(image)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preview_shader_validates() {
        let module =
            naga::front::wgsl::parse_str(SHADER).unwrap_or_else(|e| panic!("{}", e.emit_to_string(SHADER)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(SHADER)));
    }

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
