//! The GPU renderer: checks a job, compiles the kernels it needs, packs the scene (and, with
//! `--accel cube`, builds the candidate tables, with `--accel bvh` the BVH), runs the kernels
//! over the grid with the one dispatch schedule ([`super::schedule`]) and reads back the
//! image, the ray and test counters and the kernel time.
//!
//! `--accel auto` and `cube` trace the tables (and the BVH for rays leaving surfaces), `bvh`
//! the BVH, `brute` tests every primitive.
//! The three query sets answer the same WGSL calls, and a module contains only one of them
//! ([`Variant::queries`]).

use std::time::Instant;

use indicatif::ProgressBar;

use super::buffers::{upload, QueueSizes, SceneBuffers};
use super::kernels::{first_compile_marker, mark_compiled, Kernels};
use super::schedule::{self, Pacing, Pipelines, Progress, Schedule, WavePlan};
use super::setup::{add_surface_walk, check, check_f64, point_at, queue_sizes, resolve_surface, walk_bounds};
use super::shaders::{Depths, Kernel, Queries, Stage, Variant};
use super::GpuContext;
use crate::coherence::reach::WalkBounds;
use crate::coherence::{self, FlatTables, Tables};
use crate::error::{Error, Result};
use crate::job::{grid_image, simulated_effects, RenderOptions, Rendered};
use crate::layout::budget::{self, check_loop_budget, TESTS_PER_DISPATCH};
use crate::layout::counters::{decode_counters, decode_lanes, COUNTER_BYTES};
use crate::layout::{job_params, pack, Packed, AOV_DEPTH, AOV_ID, AOV_NORMAL};
use crate::output::{Aov, Image};
use crate::sampling::Sampling;
use crate::scene::Scene;
use crate::stats::{self, Counters, Stats};
use crate::tablefile::StoredTables;

/// An open device with its kernels, compiled once per kernel and [`Variant`] and cached.
pub struct GpuRenderer {
    pub ctx: GpuContext,
    kernels: Kernels,
}

/// What a run over the grid returns: one `vec4<f32>` per grid point, the counters, the
/// kernel time (in all and by kernel: nearest, shade, shadow, resolve or the single kernel),
/// the warm-up (compilation) time and the longest submission.
struct RunOutput {
    values: Vec<[f32; 4]>,
    counters: Counters,
    gpu_s: Option<f64>,
    kernel_s: Option<[f64; 4]>,
    /// The wavefront kernels' time by depth (nearest, shade, shadow), when timed.
    depth_s: Option<[[f64; 3]; crate::layout::MAX_DEPTH as usize]>,
    /// Lane coherence, when the kernels counted.
    lanes: Option<stats::LaneStats>,
    compile_s: f64,
    /// The driver's build of the ray queries' structure (0 without one).
    accel_build_s: f64,
    longest_submit_s: f64,
    longest_dispatch_s: Option<f64>,
    tiles_run_again: u32,
}

impl RunOutput {
    /// The times of a render whose preprocessing took `preprocess_s` and whose run took
    /// `trace_s`; `aov`: the kernel was the AOV pass, `shadows`: the shadow kernel ran.
    fn times(&self, preprocess_s: f64, trace_s: f64, aov: bool, shadows: bool) -> stats::Times {
        let k = self.kernel_s;
        let kernel = if aov {
            stats::KernelTimes { aov: k.map(|k| k[3]), ..Default::default() }
        } else {
            stats::KernelTimes {
                nearest: k.map(|k| k[0]),
                shade: k.map(|k| k[1]),
                shadow: k.filter(|_| shadows).map(|k| k[2]),
                resolve: k.map(|k| k[3]),
                aov: None,
            }
        };
        let depths = self.depth_s.filter(|_| !aov).map(|d| {
            d.iter()
                .enumerate()
                .filter(|(_, k)| k.iter().any(|&t| t > 0.0))
                .map(|(i, k)| stats::DepthTimes {
                    depth: i as u32 + 1,
                    nearest: k[0],
                    shade: k[1],
                    shadow: k[2],
                    all: k.iter().sum(),
                })
                .collect()
        });
        stats::Times {
            preprocess_s,
            trace_s,
            gpu_s: self.gpu_s,
            gpu_kernel_s: kernel,
            gpu_depth_s: depths,
            compile_s: Some(self.compile_s),
            longest_submit_s: Some(self.longest_submit_s),
            longest_dispatch_s: self.longest_dispatch_s,
            tiles_run_again: Some(self.tiles_run_again),
        }
    }
}

/// The set-up shared by [`GpuRenderer::render`] and [`GpuRenderer::render_aov`]; `start` is
/// when preprocessing began.
struct Prepared {
    variant: Variant,
    /// The kernels the render runs, compiled.
    pipelines: Vec<(Stage, std::sync::Arc<wgpu::ComputePipeline>)>,
    packed: Packed,
    tables: Option<TableSet>,
    start: Instant,
}

/// The tables a render traces: built for it, or read from a file (`render --tables`), with
/// the bounds on their walks computed here.
// One per render: the size of its variants does not matter.
#[allow(clippy::large_enum_variant)]
pub enum TableSet {
    Built(Tables),
    Stored(StoredTables, WalkBounds),
}

impl TableSet {
    pub fn flat(&self) -> &FlatTables {
        match self {
            TableSet::Built(t) => &t.flat,
            TableSet::Stored(t, _) => &t.flat,
        }
    }

    pub fn walks(&self) -> &WalkBounds {
        match self {
            TableSet::Built(t) => &t.walks,
            TableSet::Stored(_, w) => w,
        }
    }
}

impl GpuRenderer {
    /// Opens the GPU (see [`GpuContext::new`]).
    pub fn new() -> Result<GpuRenderer> {
        Ok(Self::with_context(GpuContext::new()?))
    }

    pub fn with_context(ctx: GpuContext) -> GpuRenderer {
        let kernels = Kernels::new(&ctx);
        GpuRenderer { ctx, kernels }
    }

    /// How many kernel pipelines have been compiled so far (each kernel and variant once).
    pub fn compiled_kernels(&self) -> usize {
        self.kernels.compiled()
    }

    /// The pipelines of `stages` for a render of `variant`, each compiled in its own
    /// variant ([`Stage::variant`]) on first use, all over the bind group layout of the
    /// render's buffers (with the ray queries' structure where `variant` uses them).
    pub fn pipelines(
        &self,
        stages: &[Stage],
        variant: Variant,
    ) -> Result<Vec<(Stage, std::sync::Arc<wgpu::ComputePipeline>)>> {
        let rq = variant.ray_queries();
        stages
            .iter()
            .map(|&s| Ok((s, self.kernels.get(&self.ctx, s.kernel, s.variant(variant), rq)?)))
            .collect()
    }

    /// What both renders do first: check the options, pick and compile the kernels, then
    /// (timed as preprocessing) pack the scene and build the tables it traces, or take
    /// `stored` ones (built with [`GpuRenderer::build_params`], checked here).
    fn prepare(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        aov: bool,
        stored: Option<StoredTables>,
    ) -> Result<Prepared> {
        check(scene, opts)?;
        check_f64(&self.ctx, opts)?;
        let variant = Self::job_variant(scene, opts, aov);
        debug_assert!(
            variant.shapes.contains(scene.shapes()),
            "the kernels lack the intersection code of a kind of primitive the scene holds"
        );
        let stages = if aov {
            vec![Stage { kernel: Kernel::Aov, depths: Depths::All }]
        } else {
            Kernel::wavefront(variant)
        };
        let pipelines = self.pipelines(&stages, variant)?;
        let start = Instant::now();
        let mut packed = pack(scene, opts.width, opts.height, opts.spawn);
        if variant.f64 {
            packed.use_f64(scene, opts.spawn);
        }
        match variant.queries {
            Queries::Bvh => packed.add_bvh(scene),
            Queries::RayQuery => packed.add_rq(scene),
            Queries::Tables | Queries::Brute => {}
        }
        let tables = match stored {
            None => self.tables(scene, opts, variant, &mut packed)?.map(TableSet::Built),
            Some(_) if !variant.tables() => {
                return Err(Error::Options(format!(
                    "stored tables are for --accel cube or auto; this render traces none (--accel {})",
                    variant.queries.name()
                )))
            }
            Some(t) => {
                let walks = Self::take_stored(scene, opts, variant, &mut packed, &t)?;
                Some(TableSet::Stored(t, walks))
            }
        };
        debug_assert!(
            variant.surface_rays || packed.params.surface_walk == 0,
            "the tables send rays leaving surfaces to kernels without their walk"
        );
        debug_assert_eq!(
            variant.ray_queries(),
            packed.rq.is_some(),
            "ray-query kernels without their structure"
        );
        Ok(Prepared { variant, pipelines, packed, tables, start })
    }

    /// What a render does with stored tables before it uploads them: checks every index
    /// they hold against the scene, bounds their walks, and points `packed`'s params at
    /// them (adding the BVH when rays leaving surfaces walk it).
    fn take_stored(
        scene: &Scene,
        opts: &RenderOptions,
        variant: Variant,
        packed: &mut Packed,
        t: &StoredTables,
    ) -> Result<WalkBounds> {
        t.flat.check_scene(scene.primitives.len(), scene.lights.len())?;
        let params = Self::variant_build_params(scene, opts, variant);
        let walks = WalkBounds::of(scene, &t.flat);
        point_at(&mut packed.params, &t.flat);
        add_surface_walk(packed, scene, &params, variant.surface_rq);
        Ok(walks)
    }

    /// The checks a render runs on stored tables before upload (`take_stored`),
    /// without a device: for tests and the tables file's fuzz target.
    pub fn check_stored(scene: &Scene, opts: &RenderOptions, t: &StoredTables) -> Result<()> {
        check(scene, opts)?;
        let variant = Self::job_variant(scene, opts, false);
        let mut packed = pack(scene, opts.width, opts.height, opts.spawn);
        Self::take_stored(scene, opts, variant, &mut packed, t).map(|_| ())
    }

    /// Builds the candidate tables when `variant` traces them (for all its effects) and
    /// points the params at the eye and fallback origins.
    pub fn tables(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        variant: Variant,
        packed: &mut Packed,
    ) -> Result<Option<Tables>> {
        if !variant.tables() {
            return Ok(None);
        }
        let params = Self::variant_build_params(scene, opts, variant);
        let t = coherence::build(scene, &params)?;
        log::info!(
            "tables: {} origins, {} entries, longest lists {} (nearest) {} (shadow), fallback reachable: {}",
            t.flat.origins.len(),
            t.flat.entries.len(),
            t.walks.worst_closest,
            t.walks.worst_shadow,
            t.walks.fallback_reachable
        );
        point_at(&mut packed.params, &t.flat);
        add_surface_walk(packed, scene, &params, variant.surface_rq);
        Ok(Some(t))
    }

    /// Dispatches each of `pipelines` (kernels of `variant`) once over no points, the first
    /// time in this process (see [`schedule::warm_up`]), so that compilation at first dispatch
    /// is neither counted in the kernel time nor mistaken for a hang: the first time on this
    /// machine one line on stderr says so. Returns the warm-ups' time (0 when warmed before).
    pub fn warm_up(
        &self,
        variant: Variant,
        pipelines: &[(Stage, std::sync::Arc<wgpu::ComputePipeline>)],
        buffers: &SceneBuffers,
        base: &crate::layout::Params,
    ) -> Result<f64> {
        let cold: Vec<&(Stage, std::sync::Arc<wgpu::ComputePipeline>)> = pipelines
            .iter()
            .filter(|(s, _)| self.kernels.first_warm_up(s.kernel, s.variant(variant)))
            .collect();
        let mut markers = Vec::new();
        for (s, _) in &cold {
            markers.extend(first_compile_marker(&self.ctx, s.kernel, s.variant(variant))?);
        }
        if !markers.is_empty() {
            // Said as a warning once per process (`accuracy` and `bench` compile one variant
            // per set of effects), then only in the log.
            static ANNOUNCED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
            let first = !ANNOUNCED.swap(true, std::sync::atomic::Ordering::Relaxed);
            let level = if first { log::Level::Warn } else { log::Level::Info };
            let mut names: Vec<&str> = cold.iter().map(|(s, _)| s.kernel.name()).collect();
            names.dedup();
            log::log!(
                level,
                "compiling the {} kernel{} for {}, {}: the first time on a machine this can take a minute",
                names.join(", "),
                if names.len() > 1 { "s" } else { "" },
                self.ctx.info.name,
                self.ctx.info.driver_info
            );
        }
        let mut took = 0.0;
        for (s, p) in cold {
            let t = schedule::warm_up(&self.ctx, p, buffers, base)?.as_secs_f64();
            log::info!("{} kernel ({:?} depths) warmed up in {t:.2} s", s.kernel.name(), s.depths);
            took += t;
        }
        for m in markers {
            mark_compiled(&m);
        }
        Ok(took)
    }

    /// Uploads `packed` (and the tables) into buffers for tiles of up to `tile` points, with
    /// the wavefront's queues of `queues` per point (`None`: the `aov` kernel's buffers).
    pub fn upload(
        &self,
        packed: &Packed,
        tables: Option<&FlatTables>,
        tile: u64,
        queues: Option<QueueSizes>,
    ) -> Result<SceneBuffers> {
        let layout = self.kernels.bind_layout(packed.rq.is_some()).ok_or_else(|| {
            Error::Options(format!("{} has no ray queries for the ray-query structure", self.ctx.info.name))
        })?;
        upload(&self.ctx, layout, packed, tables, tile, queues)
    }

    /// Checks that no step of a render with these tables can pass lavapipe's loop limit
    /// (see [`budget::check_loop_budget`]); other adapters have no such limit, and neither
    /// has a lavapipe with ray queries (Mesa 24.1 and later: `ray_queries`), on which Mesa
    /// 25.0 ran loops of 200,000 iterations whole (docs/drivers-and-faults.md).
    pub fn check_loop_budget(
        &self,
        scene: &Scene,
        walks: Option<&WalkBounds>,
        max_depth: Option<u32>,
        ray_queries: bool,
    ) -> Result<()> {
        if !self.ctx.is_lavapipe() || ray_queries {
            return Ok(());
        }
        check_loop_budget(scene, walks, max_depth)
    }

    /// Renders `scene` to linear radiance on the GPU.
    pub fn render(&self, scene: &Scene, opts: &RenderOptions, progress: &ProgressBar) -> Result<Rendered> {
        self.render_with(scene, opts, None, progress)
    }

    /// [`GpuRenderer::render`] with `stored` tables instead of building them (see
    /// [`crate::tablefile`]; the caller has checked that they were built for this render).
    pub fn render_with(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        stored: Option<StoredTables>,
        progress: &ProgressBar,
    ) -> Result<Rendered> {
        let opts = &resolve_surface(&self.ctx, &opts.resolved(scene))?;
        let Prepared { variant, pipelines, mut packed, tables, start } =
            self.prepare(scene, opts, false, stored)?;
        packed.params = job_params(opts, packed.params);
        let preprocess_s = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let run = self.run(
            variant,
            &pipelines,
            Some(opts.max_depth),
            scene,
            &packed,
            tables.as_ref(),
            opts.grid_region().size,
            progress,
        )?;
        // The driver's build of the ray queries' structure is preprocessing, as the BVH's is.
        let trace_s = start.elapsed().as_secs_f64() - run.accel_build_s;
        let preprocess_s = preprocess_s + run.accel_build_s;

        let image = grid_image(opts, scene, &run.values, opts.spp);
        let mut stats = Stats::new(
            opts.settings(scene, "gpu", variant.queries.name()),
            simulated_effects(scene, opts.max_depth),
            &run.counters,
            run.times(preprocess_s, trace_s, false, variant.shadows),
        );
        stats.settings.surface_walk = surface_walk_name(variant);
        stats.accel_bytes = accel_bytes(&packed, tables.as_ref());
        stats.texture_bytes = std::mem::size_of_val(packed.texels.as_slice()) as u64;
        stats.counted = variant.counters;
        stats.lanes = run.lanes.unwrap_or_default();
        Ok(Rendered { image, stats })
    }

    /// Renders an auxiliary output from the eye ray through each pixel centre, as the CPU
    /// reference's `render_aov` does.
    pub fn render_aov(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        aov: Aov,
        progress: &ProgressBar,
    ) -> Result<Rendered> {
        self.render_aov_with(scene, opts, aov, None, progress)
    }

    /// [`GpuRenderer::render_aov`] with `stored` tables (built for the AOV pass).
    pub fn render_aov_with(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        aov: Aov,
        stored: Option<StoredTables>,
        progress: &ProgressBar,
    ) -> Result<Rendered> {
        let opts = &resolve_surface(&self.ctx, &opts.resolved(scene))?;
        let (w, h) = (opts.region().width(), opts.region().height());
        let Prepared { variant, pipelines, mut packed, tables, start } =
            self.prepare(scene, opts, true, stored)?;
        let center = RenderOptions { spp: 1, sampling: Sampling::Pixels, max_depth: 1, ..opts.clone() };
        packed.params = job_params(&center, packed.params);
        packed.params.aov = match aov {
            Aov::Depth => AOV_DEPTH,
            Aov::Normal => AOV_NORMAL,
            Aov::Id => AOV_ID,
        };
        let preprocess_s = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let run = self.run(variant, &pipelines, None, scene, &packed, tables.as_ref(), (w, h), progress)?;
        let trace_s = start.elapsed().as_secs_f64() - run.accel_build_s;
        let times = run.times(preprocess_s + run.accel_build_s, trace_s, true, false);
        let mut image = Image::new(w, h, true);
        image.pixels = run.values;
        let mut stats = Stats::new(
            opts.aov_settings(scene, "gpu", variant.queries.name()),
            Vec::new(),
            &run.counters,
            times,
        );
        stats.accel_bytes = accel_bytes(&packed, tables.as_ref());
        stats.texture_bytes = std::mem::size_of_val(packed.texels.as_slice()) as u64;
        stats.counted = variant.counters;
        Ok(Rendered { image, stats })
    }

    /// Runs the kernels over the `grid` of points with the fixed schedule: the wavefront
    /// kernels (`max_depth` given) until every tile is done, or the `aov` kernel once per
    /// tile, after warming each pipeline up.
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        variant: Variant,
        pipelines: &[(Stage, std::sync::Arc<wgpu::ComputePipeline>)],
        max_depth: Option<u32>,
        scene: &Scene,
        packed: &Packed,
        tables: Option<&TableSet>,
        grid: (u32, u32),
        progress: &ProgressBar,
    ) -> Result<RunOutput> {
        let walks = walk_bounds(tables.map(TableSet::walks), packed);
        self.check_loop_budget(scene, walks.as_ref(), max_depth, variant.ray_queries())?;
        let total = grid.0 as u64 * grid.1 as u64;
        let tile = budget::tile_points(scene, walks.as_ref(), TESTS_PER_DISPATCH);
        let sizes = max_depth.map(|_| queue_sizes(scene, variant));
        let buffers = self.upload(packed, tables.map(TableSet::flat), tile, sizes)?;
        let mut params = packed.params;
        buffers.size_queues(&mut params);
        let compile_s = self.warm_up(variant, pipelines, &buffers, &params)?;
        let plan = max_depth.map(|d| WavePlan::new(variant, d, budget::retry_passes(scene, walks.as_ref())));
        let kernels = match pipelines.iter().find(|p| p.0.kernel == Kernel::Aov) {
            Some((_, aov)) => Pipelines::Single(aov),
            None => Pipelines::Wavefront(pipelines),
        };
        let readback = self.ctx.readback_buffer("readback", buffers.tile * 16);
        let mut schedule = Schedule::new(&self.ctx, total, buffers.tile, plan, Pacing::Fixed, true);
        progress.set_length(total);
        let mut values = Vec::with_capacity(total as usize);
        loop {
            // Between submissions a stop asked for ends the render.
            crate::interrupt::check()?;
            let Progress::TileDone { count, pass_done, .. } =
                schedule.step(&self.ctx, &kernels, &buffers, &params)?
            else {
                continue;
            };
            let bytes = count as u64 * 16;
            let mut enc =
                self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            enc.copy_buffer_to_buffer(&buffers.out, 0, &readback, 0, bytes);
            self.ctx.queue.submit([enc.finish()]);
            let data = self.ctx.read(&readback, bytes)?;
            values.extend(bytemuck::cast_slice::<u8, [f32; 4]>(&data).iter().copied());
            progress.inc(count as u64);
            if pass_done {
                break;
            }
        }
        let (counters, lanes) = self.counters(&buffers)?;
        Ok(RunOutput {
            values,
            counters,
            gpu_s: schedule.gpu_s(),
            kernel_s: schedule.kernel_s(),
            depth_s: schedule.depth_s(),
            lanes: (variant.counters && max_depth.is_some()).then_some(lanes),
            compile_s,
            accel_build_s: buffers.rq.as_ref().map_or(0.0, |r| r.build_s),
            longest_submit_s: schedule.longest_submit().as_secs_f64(),
            longest_dispatch_s: schedule.longest_pass(),
            tiles_run_again: schedule.tiles_run_again(),
        })
    }

    /// The counters and lane coherence the kernels have added up in `buffers` so far.
    pub fn counters(&self, buffers: &SceneBuffers) -> Result<(Counters, stats::LaneStats)> {
        let read = self.ctx.readback_buffer("counters readback", COUNTER_BYTES);
        let mut enc = self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        enc.copy_buffer_to_buffer(&buffers.counters, 0, &read, 0, COUNTER_BYTES);
        self.ctx.queue.submit([enc.finish()]);
        let raw = self.ctx.read(&read, COUNTER_BYTES)?;
        Ok((decode_counters(&raw), decode_lanes(&raw)))
    }
}

/// Bytes of the tables, the BVH or the ray queries' boxes a render traced (the driver's own
/// structure over the boxes is not counted: wgpu 30 does not say its size).
fn accel_bytes(packed: &Packed, tables: Option<&TableSet>) -> u64 {
    let bvh = packed.bvh.as_ref().map_or(0, |b| b.bytes());
    let rq = packed.rq.as_ref().map_or(0, |b| std::mem::size_of_val(b.as_slice()) as u64);
    bvh + rq + tables.map_or(0, |t| t.flat().bytes() as u64)
}

/// What the rays leaving surfaces took under the tables (`None`: no such ray, or another
/// accelerator, which takes them as it takes every ray).
fn surface_walk_name(variant: Variant) -> Option<String> {
    (variant.tables() && variant.surface_rays)
        .then(|| if variant.surface_rq { "rayquery" } else { "bvh" }.into())
}
