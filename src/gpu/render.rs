//! The GPU renderer: uploads a packed scene (and, with `--accel cube`, the candidate tables
//! of [`super::tables`]), runs the composed kernels tile by tile and reads back the image,
//! the ray and test counters and the kernel times.
//!
//! `--accel auto` and `cube` trace the tables, `brute` tests every primitive, `bvh` is
//! refused (the BVH is the CPU reference's). Both query sets have the same WGSL entry
//! points, and a module contains only one of them ([`Variant::cube`]).
//!
//! Each grid point (pixel, or pixel corner with SPD sampling) keeps its ray tree as a
//! stack of pending rays in a storage buffer; one dispatch traces one ray of every point
//! of a tile (`render` in `shaders/trace.wgsl`), and the host repeats dispatches until no
//! point has work left. A single invocation looping over its whole ray tree was the first
//! design, but lavapipe ends all loops of an invocation after 65535 iterations in total
//! (a safety limit in Mesa's gallivm), which silently cut ray trees short on scenes of a
//! few hundred primitives. For the same reason a long walk (a candidate list, or brute
//! force's every primitive) is spread over several steps, [`WALK_CHUNK`] entries each, its
//! position kept in the point's state: on gears_s4 one 36610-entry reflection walk plus the
//! shadow walks, well under 65535 iterations by our count, already made lavapipe cut the
//! light loop short. A shadow ray with a long walk is a job on the same stack (pushed after
//! the hit's secondary rays, so traced first); short shadow walks are traced within the
//! step that found the hit ([`shadow_inline`]). Work is split into tiles of a bounded
//! number of points (short dispatches for real GPUs' watchdogs, bounded state memory), which also drive the
//! progress bar.

use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use glam::DVec3;
use indicatif::ProgressBar;
use wgpu::util::DeviceExt;

use super::layout::{self, Packed, Params, PointState, STACK_SIZE};
use super::shader::{self, Variant};
use super::tables::{self, GpuTables};
use super::GpuContext;
use crate::error::{Error, Result};
use crate::job::{simulated_effects, AccelKind, RenderOptions, Rendered};
use crate::output::{Aov, Image};
use crate::sampling::{self, Sampling};
use crate::scene::{Effects, Scene};
use crate::stats::{self, Counters, Stats};

/// The deepest ray tree the kernels' stack holds (`STACK_SIZE` in shade.wgsl).
pub const MAX_DEPTH: u32 = 16;

/// Invocations per workgroup (`@workgroup_size` in trace.wgsl).
pub const WORKGROUP: u32 = 64;

/// Rough budget of primitive tests per eye sample and dispatch, which sets the tile size.
const TESTS_PER_DISPATCH: u64 = 1 << 24;

/// The most grid points per dispatch: bounds the point states' memory (832 bytes each).
const MAX_TILE: u64 = 1 << 16;

/// Mesa's llvmpipe limit on the loop iterations of one invocation (all loops together).
const LAVAPIPE_LOOP_LIMIT: u64 = 65535;

/// Loop iterations (candidate-list entries and the members of group entries) one `render`
/// step spends on a walk, at most, before the last entry's group (`WALK_CHUNK` in cube.wgsl).
const WALK_CHUNK: u64 = 8192;

/// Shadow walks of at most this many entries are traced within the step that found the hit
/// (`params.shadow_inline`): as many as keep a step, with one whole walk and every light's
/// inline walk (each entry possibly a group of `GROUP_SIZE`), within lavapipe's loop limit.
/// Longer walks become jobs on the ray stack, one step each at least.
pub fn shadow_inline(scene: &Scene) -> u32 {
    let c = scene.counts();
    let per_test: u64 = if c.cylinders > 0 { 3 } else { 1 };
    let lights = scene.lights.len() as u64;
    let group = crate::coherence::groups::GROUP_SIZE as u64;
    let step = per_test * (WALK_CHUNK + group) + lights + COUNTER_SLOTS as u64 + 16;
    (LAVAPIPE_LOOP_LIMIT.saturating_sub(step) / (lights.max(1) * per_test * (1 + group))) as u32
}

/// Counter slots in the kernels (`COUNTER_COUNT` in common.wgsl), each 64-bit.
pub const COUNTER_SLOTS: usize = 22;

/// The two entry points of one composed module.
pub struct Kernels {
    render: wgpu::ComputePipeline,
    aov: wgpu::ComputePipeline,
}

impl Kernels {
    /// The stepped `render` entry point (one ray per grid point and dispatch).
    pub fn render(&self) -> &wgpu::ComputePipeline {
        &self.render
    }
}

/// A packed scene's buffers on the GPU with their bind group (the layout of
/// `shaders/common.wgsl`), sized for tiles of up to `tile` grid points. Positions are
/// relative to the eye: a camera move rewrites `prims`, `lights` and `params`.
pub struct SceneBuffers {
    pub params: wgpu::Buffer,
    pub prims: wgpu::Buffer,
    pub lights: wgpu::Buffer,
    /// One `vec4<f32>` per point of the tile: the radiance summed by `render` so far.
    pub out: wgpu::Buffer,
    /// The 64-bit counters (`COUNTER_SLOTS` of them, low word first).
    pub counters: wgpu::Buffer,
    /// One [`PointState`] per point of the tile (one only for the `aov` kernel).
    pub states: wgpu::Buffer,
    /// One `u32`: grid points with work left after a step.
    pub active: wgpu::Buffer,
    pub bind: wgpu::BindGroup,
    pub tile: u64,
}

/// An open device with its kernels, compiled once per [`Variant`] and cached.
pub struct GpuRenderer {
    pub ctx: GpuContext,
    bind_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    cache: Mutex<HashMap<Variant, Arc<Kernels>>>,
    compiles: AtomicUsize,
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl GpuRenderer {
    /// Opens the GPU (see [`GpuContext::new`]).
    pub fn new() -> Result<GpuRenderer> {
        Ok(Self::with_context(GpuContext::new()?))
    }

    pub fn with_context(ctx: GpuContext) -> GpuRenderer {
        let mut entries = vec![wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }];
        entries.extend((1..=6).map(|b| storage_entry(b, true)));
        entries.extend((7..=10).map(|b| storage_entry(b, false)));
        // The candidate tables (cube.wgsl); brute-force kernels leave them unused.
        entries.extend((11..=19).map(|b| storage_entry(b, true)));
        let bind_layout = ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cuberay scene"),
            entries: &entries,
        });
        let pipeline_layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cuberay"),
            bind_group_layouts: &[Some(&bind_layout)],
            immediate_size: 0,
        });
        GpuRenderer {
            ctx,
            bind_layout,
            pipeline_layout,
            cache: Mutex::new(HashMap::new()),
            compiles: AtomicUsize::new(0),
        }
    }

    /// How many modules have been compiled so far (each variant once).
    pub fn compiled_variants(&self) -> usize {
        self.compiles.load(Ordering::Relaxed)
    }

    /// The kernels of `variant`, compiled on first use.
    pub fn kernels(&self, variant: Variant) -> Result<Arc<Kernels>> {
        let mut cache = self.cache.lock().expect("kernel cache lock");
        if let Some(k) = cache.get(&variant) {
            return Ok(k.clone());
        }
        let source = shader::compose(variant)?;
        let device = &self.ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cuberay trace"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&self.pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let k = Arc::new(Kernels { render: pipeline("render"), aov: pipeline("aov") });
        self.compiles.fetch_add(1, Ordering::Relaxed);
        cache.insert(variant, k.clone());
        Ok(k)
    }

    /// What both entry points do first: check the options, pick and compile the kernels,
    /// then (timed as preprocessing) pack the scene and build the tables they trace.
    /// Checks, compiles and packs for a render (`aov`: the AOV pass, which traces eye rays
    /// only, so its kernels and tables have no effects).
    fn prepare(&self, scene: &Scene, opts: &RenderOptions, aov: bool) -> Result<Prepared> {
        check(scene, opts)?;
        let effects = if aov { Effects::default() } else { scene.effects() };
        let depth = if aov { 1 } else { opts.max_depth };
        let variant = Variant::for_effects(effects, depth).with_cube(uses_tables(opts.accel));
        let kernels = self.kernels(variant)?;
        let start = Instant::now();
        let mut packed = layout::pack(scene, opts.width, opts.height);
        let tables = self.tables(scene, opts.width, opts.height, variant, &mut packed.params)?;
        Ok(Prepared { variant, kernels, packed, tables, start })
    }

    /// Renders `scene` to linear radiance on the GPU.
    pub fn render(&self, scene: &Scene, opts: &RenderOptions, progress: &ProgressBar) -> Result<Rendered> {
        let (w, h) = (opts.width, opts.height);
        let Prepared { variant, kernels, mut packed, tables, start } = self.prepare(scene, opts, false)?;
        let corners = opts.sampling == Sampling::Corners;
        let (gw, gh) = if corners { (w + 1, h + 1) } else { (w, h) };
        let seed_hash = sampling::seed_hash(opts.seed);
        packed.params = Params {
            grid_w: gw,
            grid_h: gh,
            spp: opts.spp,
            lattice_g: if opts.spp > 1 { sampling::lattice_generator(opts.spp) } else { 1 },
            seed_hash,
            corners: corners as u32,
            max_depth: opts.max_depth,
            sample_first: 0,
            sample_end: opts.spp,
            ..packed.params
        };
        let preprocess_s = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let run = self.run(
            &kernels.render,
            Some(opts.max_depth),
            scene,
            &packed,
            tables.as_ref(),
            gw,
            gh,
            progress,
        )?;
        let trace_s = start.elapsed().as_secs_f64();

        let mut image = Image::new(w, h, false);
        let px = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32, 1.0];
        let at = |i: u32, j: u32| {
            let p = run.values[(j * gw + i) as usize];
            DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
        };
        for j in 0..h {
            for i in 0..w {
                let v = if corners {
                    (at(i, j) + at(i + 1, j) + at(i, j + 1) + at(i + 1, j + 1)) * 0.25
                } else {
                    at(i, j) / opts.spp as f64
                };
                image.pixels[(j * w + i) as usize] = px(v);
            }
        }
        let stats = Stats::new(
            opts.settings("gpu", accel_name(variant)),
            simulated_effects(scene, opts.max_depth),
            &run.counters,
            stats::Times {
                preprocess_s,
                trace_s,
                gpu_s: run.gpu_s,
                gpu_kernel_s: stats::KernelTimes { render: run.gpu_s, aov: None },
            },
        );
        Ok(Rendered { image, stats })
    }

    /// Renders an auxiliary output from the eye ray through each pixel centre, as
    /// the CPU reference's `render_aov` does.
    pub fn render_aov(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        aov: Aov,
        progress: &ProgressBar,
    ) -> Result<Rendered> {
        let (w, h) = (opts.width, opts.height);
        let Prepared { variant, kernels, mut packed, tables, start } = self.prepare(scene, opts, true)?;
        packed.params = Params {
            grid_w: w,
            grid_h: h,
            spp: 1,
            lattice_g: 1,
            max_depth: 1,
            aov: match aov {
                Aov::Depth => 0,
                Aov::Normal => 1,
                Aov::Id => 2,
            },
            ..packed.params
        };
        let preprocess_s = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let run = self.run(&kernels.aov, None, scene, &packed, tables.as_ref(), w, h, progress)?;
        let trace_s = start.elapsed().as_secs_f64();
        let mut image = Image::new(w, h, true);
        image.pixels = run.values;
        let set = opts.aov_settings("gpu", accel_name(variant));
        let stats = Stats::new(
            set,
            Vec::new(),
            &run.counters,
            stats::Times {
                preprocess_s,
                trace_s,
                gpu_s: run.gpu_s,
                gpu_kernel_s: stats::KernelTimes { render: None, aov: run.gpu_s },
            },
        );
        Ok(Rendered { image, stats })
    }

    /// Builds the candidate tables when `variant` traces them, and points `params` at the
    /// eye and fallback origins.
    pub fn tables(
        &self,
        scene: &Scene,
        w: u32,
        h: u32,
        variant: Variant,
        params: &mut Params,
    ) -> Result<Option<GpuTables>> {
        if !variant.cube {
            return Ok(None);
        }
        let t = tables::build(scene, w, h, variant)?;
        log::info!(
            "tables: {} origins, {} entries, longest lists {} (nearest) {} (shadow), fallback reachable: {}",
            t.flat.origins.len(),
            t.flat.entries.len(),
            t.worst_closest,
            t.worst_shadow,
            t.fallback_reachable
        );
        params.eye_origin = t.flat.eye_origin;
        params.fallback_origin = t.fallback;
        Ok(Some(t))
    }

    /// Uploads `packed` (and the candidate tables, when traced) and creates the kernels'
    /// buffers for tiles of up to `tile` grid points (`stepped`: with a point state each, for
    /// the `render` kernel).
    pub fn upload(
        &self,
        packed: &Packed,
        tables: Option<&GpuTables>,
        tile: u64,
        stepped: bool,
    ) -> SceneBuffers {
        let device = &self.ctx.device;
        let storage = |label: &str, bytes: &[u8], extra: wgpu::BufferUsages| {
            // Storage bindings may not be empty.
            let contents = if bytes.is_empty() { &[0u8; 256][..] } else { bytes };
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE | extra,
            })
        };
        let none = wgpu::BufferUsages::empty();
        let prims = storage("prims", bytemuck::cast_slice(&packed.prims), wgpu::BufferUsages::COPY_DST);
        let materials = storage("materials", bytemuck::cast_slice(&packed.materials), none);
        let lights = storage("lights", bytemuck::cast_slice(&packed.lights), wgpu::BufferUsages::COPY_DST);
        let attrs = storage("tri_attrs", bytemuck::cast_slice(&packed.tri_attrs), none);
        let infos = storage("texture_infos", bytemuck::cast_slice(&packed.texture_infos), none);
        let texels = storage("texels", bytemuck::cast_slice(&packed.texels), none);
        let flat = tables.map(|t| &t.flat);
        let table = |label: &str, bytes: Option<&[u8]>| storage(label, bytes.unwrap_or(&[]), none);
        let origins = table("origins", flat.map(|f| bytemuck::cast_slice(&f.origins)));
        let faces = table("faces", flat.map(|f| bytemuck::cast_slice(&f.faces)));
        let cell_start = table("cell_start", flat.map(|f| bytemuck::cast_slice(&f.cell_start)));
        let entries = table("entries", flat.map(|f| bytemuck::cast_slice(&f.entries)));
        let prim_origin = table("prim_origin", flat.map(|f| bytemuck::cast_slice(&f.prim_origin)));
        let light_origin = table("light_origin", flat.map(|f| bytemuck::cast_slice(&f.light_origin)));
        let prim_patches = table("prim_patches", flat.map(|f| bytemuck::cast_slice(&f.prim_patches)));
        let groups = table("groups", flat.map(|f| bytemuck::cast_slice(&f.groups)));
        let group_prims = table("group_prims", flat.map(|f| bytemuck::cast_slice(&f.group_prims)));
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("out"),
            size: tile * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let counters = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("counters"),
            contents: &[0u8; COUNTER_SLOTS * 8],
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
        let state_bytes = std::mem::size_of::<PointState>() as u64;
        let states = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("point states"),
            size: if stepped { tile * state_bytes } else { state_bytes },
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let active = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("active"),
            size: 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene"),
            layout: &self.bind_layout,
            entries: &[
                (0, &params),
                (1, &prims),
                (2, &materials),
                (3, &lights),
                (4, &attrs),
                (5, &infos),
                (6, &texels),
                (7, &out),
                (8, &counters),
                (9, &states),
                (10, &active),
                (11, &origins),
                (12, &faces),
                (13, &cell_start),
                (14, &entries),
                (15, &prim_origin),
                (16, &light_origin),
                (17, &prim_patches),
                (18, &groups),
                (19, &group_prims),
            ]
            .map(|(binding, b)| wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }),
        });
        SceneBuffers { params, prims, lights, out, counters, states, active, bind, tile }
    }

    /// Runs `pipeline` over a `gw`×`gh` grid of points in tiles. A `stepped` kernel
    /// (`render`) advances each point by one ray per dispatch and is repeated until no
    /// point has work left; the `aov` kernel runs once per tile.
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        pipeline: &wgpu::ComputePipeline,
        max_depth: Option<u32>,
        scene: &Scene,
        packed: &Packed,
        tables: Option<&GpuTables>,
        gw: u32,
        gh: u32,
        progress: &ProgressBar,
    ) -> Result<RunOutput> {
        self.check_loop_budget(scene, tables, max_depth)?;
        let stepped = max_depth.is_some();
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let total = gw as u64 * gh as u64;
        let tile = tile_points(scene, tables, TESTS_PER_DISPATCH);
        let tiles = total.div_ceil(tile);

        // The bind group keeps the scene buffers that are not named here alive.
        let SceneBuffers { params, out, counters, states, active, bind, .. } =
            self.upload(packed, tables, tile, stepped);
        let active_read = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("active readback"),
            size: 4,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let out_bytes = tile * 16;
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: out_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let state_bytes = std::mem::size_of::<PointState>() as u64;
        let timing = self.ctx.timestamps.then(|| {
            let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("kernel times"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let read = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps readback"),
                size: 16,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            (set, resolve, read)
        });
        progress.set_length(tiles);
        let period_s = queue.get_timestamp_period() as f64 * 1e-9;
        let mut gpu_s = 0.0;
        let mut values = Vec::with_capacity(total as usize);
        for t in 0..tiles {
            let first = t * tile;
            let count = tile.min(total - first) as u32;
            let p = Params { first_point: first as u32, point_count: count, ..packed.params };
            queue.write_buffer(&params, 0, bytemuck::bytes_of(&p));
            let bytes = count as u64 * 16;
            let mut first_step = true;
            loop {
                let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
                if stepped && first_step {
                    enc.clear_buffer(&states, 0, Some(count as u64 * state_bytes));
                }
                first_step = false;
                enc.clear_buffer(&active, 0, None);
                {
                    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("trace"),
                        timestamp_writes: timing.as_ref().map(|(set, _, _)| {
                            wgpu::ComputePassTimestampWrites {
                                query_set: set,
                                beginning_of_pass_write_index: Some(0),
                                end_of_pass_write_index: Some(1),
                            }
                        }),
                    });
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                    pass.dispatch_workgroups(count.div_ceil(WORKGROUP), 1, 1);
                }
                enc.copy_buffer_to_buffer(&active, 0, &active_read, 0, 4);
                if let Some((set, resolve, read)) = &timing {
                    enc.resolve_query_set(set, 0..2, resolve, 0);
                    enc.copy_buffer_to_buffer(resolve, 0, read, 0, 16);
                }
                queue.submit([enc.finish()]);
                let left = u32::from_le_bytes(self.read(&active_read, 4)?.try_into().expect("4 bytes"));
                if let Some((_, _, read)) = &timing {
                    let ts = self.read(read, 16)?;
                    let ts: &[u64] = bytemuck::cast_slice(&ts);
                    gpu_s += ts[1].saturating_sub(ts[0]) as f64 * period_s;
                }
                if !stepped || left == 0 {
                    break;
                }
            }
            let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            enc.copy_buffer_to_buffer(&out, 0, &readback, 0, bytes);
            queue.submit([enc.finish()]);
            let data = self.read(&readback, bytes)?;
            values.extend(bytemuck::cast_slice::<u8, [f32; 4]>(&data).iter().copied());
            progress.inc(1);
        }

        let counter_read = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("counters readback"),
            size: (COUNTER_SLOTS * 8) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        enc.copy_buffer_to_buffer(&counters, 0, &counter_read, 0, (COUNTER_SLOTS * 8) as u64);
        queue.submit([enc.finish()]);
        let raw = self.read(&counter_read, (COUNTER_SLOTS * 8) as u64)?;
        let c = decode_counters(&raw);
        Ok(RunOutput { values, counters: c, gpu_s: timing.is_some().then_some(gpu_s) })
    }

    /// lavapipe (Mesa's llvmpipe) ends every loop of an invocation once all of its loops
    /// have run 65535 iterations in total; were a step to need more, the result would be
    /// silently wrong, so it is an error instead.
    ///
    /// `max_depth`: `Some(d)` for the stepped `render` kernel with ray trees up to depth `d`.
    /// Each of its steps walks one list (a ray's, or a shadow job's) for at most
    /// [`WALK_CHUNK`] iterations, brute force included, leaving the rest to later steps,
    /// plus the shadow walks of at most [`shadow_inline`] entries that a hit traces at once;
    /// only when the ray stack can fill up (`d +` lights over `STACK_SIZE`) may a hit
    /// trace all its shadow rays at once, each walking its whole list. `None`: the `aov`
    /// kernel, which walks an eye ray's whole list in one go.
    pub fn check_loop_budget(
        &self,
        scene: &Scene,
        tables: Option<&GpuTables>,
        max_depth: Option<u32>,
    ) -> Result<()> {
        if !self.ctx.info.name.to_lowercase().contains("llvmpipe") {
            return Ok(());
        }
        let c = scene.counts();
        let lights = scene.lights.len() as u64;
        // A cylinder test loops over its two roots.
        let per_test = if c.cylinders > 0 { 3 } else { 1 };
        let brute = (c.spheres + c.triangles + 3 * c.cylinders) as u64;
        let (closest, shadow, eye) = match tables {
            Some(t) => (per_test * t.worst_closest, per_test * t.worst_shadow, per_test * t.worst_eye),
            None => (brute, brute, brute),
        };
        let what = if tables.is_some() { "the longest candidate lists" } else { "brute force" };
        let walks = match max_depth {
            Some(d) => {
                let group = crate::coherence::groups::GROUP_SIZE as u64;
                let chunk = per_test * (WALK_CHUNK + group);
                // The eye ray is depth 1, so secondary rays take at most `d` slots.
                let inline = if d as u64 + lights > STACK_SIZE as u64 {
                    lights * shadow
                } else {
                    lights * shadow.min(per_test * shadow_inline(scene) as u64 * (1 + group))
                };
                closest.max(shadow).min(chunk) + inline
            }
            None => eye,
        };
        let worst = walks + lights + COUNTER_SLOTS as u64 + 16;
        if worst > LAVAPIPE_LOOP_LIMIT {
            return Err(Error::Options(format!(
                "{what} over {} primitives and {lights} lights need up to {worst} loop iterations per \
                 ray on lavapipe, which stops at {LAVAPIPE_LOOP_LIMIT}; render this scene with --backend cpu",
                scene.primitives.len()
            )));
        }
        Ok(())
    }

    /// Waits for the queue and copies the first `bytes` of mappable `buffer`.
    pub fn read(&self, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>> {
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
            let _ = tx.send(r);
        });
        self.ctx
            .device
            .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
            .map_err(|e| Error::Gpu(e.to_string()))?;
        rx.recv().map_err(|e| Error::Gpu(e.to_string()))?.map_err(|e| Error::Gpu(e.to_string()))?;
        let data = buffer.get_mapped_range(0..bytes).map_err(|e| Error::Gpu(format!("{e:?}")))?.to_vec();
        buffer.unmap();
        Ok(data)
    }
}

/// Grid points per tile for about `tests` primitive tests per dispatch: one step of a
/// point tests the candidates of its ray and of a shadow ray per light (brute force: every
/// primitive; with the tables, a rough mean).
pub fn tile_points(scene: &Scene, tables: Option<&GpuTables>, tests: u64) -> u64 {
    let per_ray = match tables {
        Some(t) => t.mean_list.ceil() as u64 + 1,
        None => scene.primitives.len() as u64,
    };
    let work = per_ray * (1 + scene.lights.len() as u64);
    let tile = (tests / work.max(1)).clamp(256, MAX_TILE);
    tile.div_ceil(WORKGROUP as u64) * WORKGROUP as u64
}

/// The counters from the bytes of the kernels' `counters` buffer.
pub fn decode_counters(raw: &[u8]) -> Counters {
    let words: &[u32] = bytemuck::cast_slice(raw);
    let slot = |i: usize| words[2 * i] as u64 | (words[2 * i + 1] as u64) << 32;
    let mut c = Counters::default();
    for k in 0..4 {
        c.rays[k] = slot(k);
        c.tests[k].sphere = slot(4 + 3 * k);
        c.tests[k].triangle = slot(5 + 3 * k);
        c.tests[k].cylinder = slot(6 + 3 * k);
    }
    c.eye_hit = slot(16);
    c.shadow_blocked = slot(17);
    for k in 0..4 {
        c.tests[k].bound = slot(18 + k);
    }
    c
}

/// Whether the GPU traces the candidate tables for `accel`: `cube` and `auto` do, `brute`
/// does not (`bvh` is refused).
pub fn uses_tables(accel: AccelKind) -> bool {
    matches!(accel, AccelKind::Auto | AccelKind::Cube)
}

fn accel_name(variant: Variant) -> &'static str {
    if variant.cube {
        "cube"
    } else {
        "brute"
    }
}

/// The set-up shared by [`GpuRenderer::render`] and [`GpuRenderer::render_aov`]; `start` is
/// when preprocessing began.
struct Prepared {
    variant: Variant,
    kernels: Arc<Kernels>,
    packed: Packed,
    tables: Option<GpuTables>,
    start: Instant,
}

struct RunOutput {
    values: Vec<[f32; 4]>,
    counters: Counters,
    gpu_s: Option<f64>,
}

/// Checks that the GPU backend can render `scene` with `opts`.
pub fn check(scene: &Scene, opts: &RenderOptions) -> Result<()> {
    opts.validate()?;
    scene.validate()?;
    if opts.max_depth > MAX_DEPTH {
        return Err(Error::Options(format!(
            "--max-depth {} is deeper than the GPU backend's ray stack allows ({MAX_DEPTH}); use --backend cpu",
            opts.max_depth
        )));
    }
    if opts.accel == AccelKind::Bvh {
        return Err(Error::Options(
            "the GPU backend has no BVH: use --accel cube (the default) or brute with --backend gpu".into(),
        ));
    }
    if scene.primitives.len() >= u32::MAX as usize {
        return Err(Error::Scene("too many primitives for the GPU backend".into()));
    }
    Ok(())
}
