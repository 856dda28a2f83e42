//! The GPU renderer: prepares a job ([`super::prepare`]: the options resolved, the scene
//! packed, the tables or the BVH built), compiles the kernels it needs, uploads the buffers,
//! runs the kernels over the grid with the one dispatch schedule ([`super::schedule`]) and
//! reads back the image, the ray and test counters and the kernel time.

use std::time::Instant;

use indicatif::ProgressBar;

use super::bindings::SceneBinding;
use super::buffers::{upload, BufferSizes, SceneBuffers};
use super::choose::Capabilities;
use super::kernels::{first_compile_marker, mark_compiled, Kernels, Pipelines, StagePipeline};
use super::prepare::{self, Prepared, Purpose, TableSet};

use super::schedule::{self, Pacing, Progress, Schedule, WavePlan};
use super::shaders::{Kernel, Stage, Variant};
use super::GpuContext;
use crate::coherence::FlatTables;
use crate::error::{Error, Result};
use crate::job::{grid_image, simulated_effects, KernelForm, RenderOptions, Rendered};
use crate::layout::counters::{decode_counters, decode_lanes, COUNTER_BYTES};
use crate::layout::Packed;
use crate::output::{Aov, Image};
use crate::phases::Phases;
use crate::scene::Scene;
use crate::stats::{self, Counters, Stats};
use crate::tablefile::StoredTables;

/// An open device with its kernels, compiled once per kernel and [`Variant`] and cached.
pub struct GpuRenderer {
    pub ctx: GpuContext,
    /// What the adapter offers that a render's choices depend on.
    pub caps: Capabilities,
    kernels: Kernels,
}

/// What a run over the grid returns: one `vec4<f32>` per grid point, the counters, the
/// kernel time (in all and by kernel: nearest, shade, shadow, resolve or the single kernel,
/// tree), the warm-up (compilation) time and the longest submission.
struct RunOutput {
    values: Vec<[f32; 4]>,
    counters: Counters,
    /// The form the kernels traced in.
    form: KernelForm,
    gpu_s: Option<f64>,
    kernel_s: Option<[f64; 5]>,
    /// The wavefront kernels' time by depth (nearest, shade, shadow), when timed.
    depth_s: Option<[[f64; 3]; crate::layout::MAX_DEPTH as usize]>,
    /// Lane coherence, when the kernels counted.
    lanes: Option<stats::LaneStats>,
    compile_s: f64,
    /// Creating and filling the buffers.
    upload_s: f64,
    /// The schedule's loop over the grid: the kernels and the readbacks.
    loop_s: f64,
    /// The driver's build of the ray queries' structure (0 without one).
    accel_build_s: f64,
    longest_submit_s: f64,
    longest_dispatch_s: Option<f64>,
    tiles_run_again: u32,
}

impl RunOutput {
    /// The phases of a render of `p` whose kernels took `trace_s` (the command adds its
    /// start-up, load and output): the upload includes the driver's build of the ray
    /// queries' structure.
    fn phases(&self, p: &Prepared) -> Phases {
        Phases {
            build_s: p.preprocess_s,
            tables_s: p.tables_s,
            bvh_s: p.bvh_s,
            upload_s: self.upload_s,
            compile_s: self.compile_s,
            trace_s: self.loop_s,
            ..Phases::default()
        }
    }

    /// The times of a render whose preprocessing took `preprocess_s` and whose run took
    /// `trace_s`; `aov`: the kernel was the AOV pass, `shadows`: the shadow kernel ran.
    fn times(&self, preprocess_s: f64, trace_s: f64, aov: bool, shadows: bool) -> stats::Times {
        let k = self.kernel_s;
        let kernel = if aov {
            stats::KernelTimes { aov: k.map(|k| k[3]), ..Default::default() }
        } else if self.form == KernelForm::Tree {
            stats::KernelTimes { tree: k.map(|k| k[4]), resolve: k.map(|k| k[3]), ..Default::default() }
        } else {
            stats::KernelTimes {
                nearest: k.map(|k| k[0]),
                shade: k.map(|k| k[1]),
                shadow: k.filter(|_| shadows).map(|k| k[2]),
                resolve: k.map(|k| k[3]),
                aov: None,
                tree: None,
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
            phases: Phases::default(),
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
        GpuRenderer { caps: ctx.capabilities(), ctx, kernels }
    }

    /// How many kernel pipelines have been compiled so far (each kernel and variant once).
    pub fn compiled_kernels(&self) -> usize {
        self.kernels.compiled()
    }

    /// The pipelines of `stages` for a render of `variant`, each compiled in its own
    /// variant ([`Stage::variant`]) on first use, all over the bind group layout of the
    /// render's buffers (with the ray queries' structure where `variant` uses them).
    pub fn pipelines(&self, stages: &[Stage], variant: Variant) -> Result<Vec<StagePipeline>> {
        Ok(self.make_pipelines(stages, variant)?.0)
    }

    /// [`GpuRenderer::pipelines`], and whether any of them was made by this call.
    fn make_pipelines(&self, stages: &[Stage], variant: Variant) -> Result<(Vec<StagePipeline>, bool)> {
        let rq = variant.ray_queries();
        // Each on a thread of its own: making a pipeline is the driver's work on one core.
        std::thread::scope(|scope| {
            let made: Vec<_> = stages
                .iter()
                .map(|&s| scope.spawn(move || self.kernels.get(&self.ctx, s.kernel, s.variant(variant), rq)))
                .collect();
            let (mut pipelines, mut any) = (Vec::with_capacity(stages.len()), false);
            for (&s, m) in stages.iter().zip(made) {
                let (p, new) = m.join().expect("a kernel's thread does not panic")?;
                pipelines.push((s, p));
                any |= new;
            }
            Ok((pipelines, any))
        })
    }

    /// Plans a render of `scene` for `purpose` ([`prepare::plan`]), then makes its kernels
    /// while [`prepare::build`] builds what they trace, on another thread; returns both, and
    /// the seconds the kernels took.
    fn prepare(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        purpose: Purpose,
        stored: Option<StoredTables>,
    ) -> Result<(Prepared, Vec<StagePipeline>, f64)> {
        let plan = prepare::plan(scene, opts, &self.caps, purpose, stored.is_some())?;
        let (variant, stages) = (plan.variant, plan.stages.clone());
        std::thread::scope(|scope| {
            let made = scope.spawn(|| {
                let start = Instant::now();
                // Only making a kernel counts: finding every one made before is no compile.
                self.make_pipelines(&stages, variant)
                    .map(|(p, new)| (p, if new { start.elapsed().as_secs_f64() } else { 0.0 }))
            });
            let prepared = prepare::build(scene, plan, &self.caps, stored);
            let (pipelines, made_s) = made.join().expect("the kernels' thread does not panic")?;
            Ok((prepared?, pipelines, made_s))
        })
    }

    /// Dispatches each of `pipelines` (kernels of `variant`) once over no points, the first
    /// time in this process (see [`schedule::warm_up`]), so that compilation at first dispatch
    /// is neither counted in the kernel time nor mistaken for a hang: the first time on this
    /// machine one line on stderr says so. Returns the warm-ups' time (0 when warmed before).
    pub fn warm_up(
        &self,
        variant: Variant,
        pipelines: &[StagePipeline],
        buffers: &SceneBuffers,
        base: &crate::layout::Params,
    ) -> Result<f64> {
        let cold: Vec<&StagePipeline> = pipelines
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

    /// Uploads `packed` (and the tables) into buffers of `sizes`.
    pub fn upload(
        &self,
        packed: &Packed,
        tables: Option<&FlatTables>,
        sizes: BufferSizes,
    ) -> Result<SceneBuffers> {
        let layout = self.kernels.bind_layout(packed.rq.is_some()).ok_or_else(|| {
            Error::Options(format!("{} has no ray queries for the ray-query structure", self.ctx.info.name))
        })?;
        upload(&self.ctx, layout, packed, tables, sizes)
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
        let (p, pipelines, made_s) = self.prepare(scene, opts, Purpose::Render, stored)?;
        let opts = &p.opts;
        let start = Instant::now();
        let run = self.run(&p, &pipelines, made_s, opts.grid_region().size, progress)?;
        // The driver's build of the ray queries' structure is preprocessing, as the BVH's is.
        let trace_s = start.elapsed().as_secs_f64() - run.accel_build_s;
        let preprocess_s = p.preprocess_s + run.accel_build_s;
        let image = grid_image(opts, scene, &run.values, opts.spp);
        let variant = p.variant;
        let mut stats = Stats::new(
            opts.settings(scene, "gpu", variant.accel.name()),
            simulated_effects(scene, opts.max_depth),
            &run.counters,
            run.times(preprocess_s, trace_s, false, variant.effects.shadows),
        );
        stats.settings.surface_walk = surface_walk_name(variant);
        stats.settings.kernel_form = Some(opts.form.name().into());
        stats.time.phases = run.phases(&p);
        stats.accel_bytes = accel_bytes(&p.packed, p.tables.as_ref());
        stats.texture_bytes = std::mem::size_of_val(p.packed.texels.as_slice()) as u64;
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
        let (p, pipelines, made_s) = self.prepare(scene, opts, Purpose::Aov(aov), stored)?;
        let opts = &p.opts;
        let (w, h) = (opts.region().width(), opts.region().height());
        let start = Instant::now();
        let run = self.run(&p, &pipelines, made_s, (w, h), progress)?;
        let trace_s = start.elapsed().as_secs_f64() - run.accel_build_s;
        let times = run.times(p.preprocess_s + run.accel_build_s, trace_s, true, false);
        let phases = run.phases(&p);
        let mut image = Image::new(w, h, true);
        image.pixels = run.values;
        let mut stats = Stats::new(
            opts.aov_settings(scene, "gpu", p.variant.accel.name()),
            Vec::new(),
            &run.counters,
            times,
        );
        stats.time.phases = phases;
        stats.accel_bytes = accel_bytes(&p.packed, p.tables.as_ref());
        stats.texture_bytes = std::mem::size_of_val(p.packed.texels.as_slice()) as u64;
        stats.counted = p.variant.counters;
        Ok(Rendered { image, stats })
    }

    /// Runs `pipelines`, the kernels of `p` (made in `made_s`), over the `grid` of points
    /// with the fixed schedule: the wavefront kernels until every tile is done, or the `aov`
    /// kernel once per tile, after warming each pipeline up.
    fn run(
        &self,
        p: &Prepared,
        pipelines: &[StagePipeline],
        made_s: f64,
        grid: (u32, u32),
        progress: &ProgressBar,
    ) -> Result<RunOutput> {
        let variant = p.variant;
        let total = grid.0 as u64 * grid.1 as u64;
        let start = Instant::now();
        let buffers = self.upload(&p.packed, p.tables.as_ref().map(TableSet::flat), p.sizes)?;
        let upload_s = start.elapsed().as_secs_f64();
        let params = p.packed.params;
        let compile_s = made_s + self.warm_up(variant, pipelines, &buffers, &params)?;
        // Every render but an AOV's runs waves, of either form.
        let waves = p.sizes.sums;
        let plan = waves.then(|| WavePlan::new(variant, p.opts.max_depth, p.retries, p.opts.form));
        let kernels = match pipelines.iter().find(|p| p.0.kernel == Kernel::Aov) {
            Some((_, aov)) => Pipelines::Single(aov),
            None => Pipelines::Wavefront(pipelines),
        };
        let readback = self.ctx.readback_buffer("readback", buffers.tile * 16);
        let mut schedule = Schedule::new(&self.ctx, total, buffers.tile, plan, Pacing::Fixed, true);
        progress.set_length(total);
        let start = Instant::now();
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
            enc.copy_buffer_to_buffer(&buffers[SceneBinding::OutColor], 0, &readback, 0, bytes);
            self.ctx.queue.submit([enc.finish()]);
            let data = self.ctx.read(&readback, bytes)?;
            values.extend(bytemuck::cast_slice::<u8, [f32; 4]>(&data).iter().copied());
            progress.inc(count as u64);
            if pass_done {
                break;
            }
        }
        let loop_s = start.elapsed().as_secs_f64();
        let (counters, lanes) = self.counters(&buffers)?;
        Ok(RunOutput {
            values,
            counters,
            form: p.opts.form,
            gpu_s: schedule.gpu_s(),
            kernel_s: schedule.kernel_s(),
            depth_s: schedule.depth_s(),
            // The lane coherence is the wavefront kernels' (by kernel and depth).
            lanes: (variant.counters && waves && p.opts.form != KernelForm::Tree).then_some(lanes),
            compile_s,
            upload_s,
            loop_s,
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
        enc.copy_buffer_to_buffer(&buffers[SceneBinding::Counters], 0, &read, 0, COUNTER_BYTES);
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
    (variant.cube() && variant.surface_rays)
        .then(|| if variant.surface_rq { "rayquery" } else { "bvh" }.into())
}
