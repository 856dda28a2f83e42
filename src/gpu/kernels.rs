//! Compiled kernels: one pipeline per kernel and [`Variant`], compiled on first use and
//! cached, over the bind group layout of the scene buffers ([`SceneBinding`]), and for the
//! kernels that use ray queries the same with the acceleration structure.
//!
//! Lavapipe compiles a kernel at its first dispatch, not at pipeline creation (seconds over
//! the wavefront kernels; docs/drivers-and-faults.md has the figures); Mesa's disk cache
//! then keeps the machine code for later runs. So the renderer dispatches each pipeline once over no points before timing
//! anything (see [`super::schedule::warm_up`]), and says on stderr, once per machine,
//! adapter, driver and kernel source, that a kernel is being compiled:
//! [`first_compile_marker`].

use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use super::bindings::{self, SceneBinding};
use super::shaders::{self, Kernel, Variant};
use super::GpuContext;
use crate::error::Result;

/// A bind group layout of the scene buffers and its pipeline layout.
struct Layouts {
    bind: wgpu::BindGroupLayout,
    pipeline: wgpu::PipelineLayout,
}

impl Layouts {
    fn new(ctx: &GpuContext, rq: bool) -> Layouts {
        let label = if rq { "scene with ray queries" } else { "scene" };
        let family = SceneBinding::family(rq).map(SceneBinding::binding);
        let bind = bindings::layout(&ctx.device, label, family, wgpu::ShaderStages::COMPUTE);
        let pipeline = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&bind)],
            immediate_size: 0,
        });
        Layouts { bind, pipeline }
    }
}

/// A wavefront stage's pipeline: the kernel, the depths it serves, and its compiled pipeline.
pub type StagePipeline = (super::shaders::Stage, Arc<wgpu::ComputePipeline>);

/// The compute pipelines of the trace kernels (the wavefront's, `aov`) by variant.
pub struct Kernels {
    plain: Layouts,
    /// With the acceleration structure, where the adapter has ray queries.
    rq: Option<Layouts>,
    cache: Mutex<HashMap<(Kernel, Variant, bool), Arc<wgpu::ComputePipeline>>>,
    compiles: AtomicUsize,
    /// The pipelines already dispatched once (warmed up) in this process.
    warmed: Mutex<HashSet<(Kernel, Variant)>>,
}

impl Kernels {
    pub fn new(ctx: &GpuContext) -> Kernels {
        Kernels {
            plain: Layouts::new(ctx, false),
            rq: ctx.ray_queries.then(|| Layouts::new(ctx, true)),
            cache: Mutex::new(HashMap::new()),
            compiles: AtomicUsize::new(0),
            warmed: Mutex::new(HashSet::new()),
        }
    }

    /// The layout of the scene buffers' bind group, with the acceleration structure (`rq`)
    /// or without; `None` where ray queries are asked of an adapter without them.
    pub fn bind_layout(&self, rq: bool) -> Option<&wgpu::BindGroupLayout> {
        self.layouts(rq).map(|l| &l.bind)
    }

    fn layouts(&self, rq: bool) -> Option<&Layouts> {
        if rq {
            self.rq.as_ref()
        } else {
            Some(&self.plain)
        }
    }

    /// How many pipelines have been compiled so far (each kernel and variant once).
    pub fn compiled(&self) -> usize {
        self.compiles.load(Ordering::Relaxed)
    }

    /// The pipeline of `kernel` (a wavefront kernel or `aov`) for `variant`, compiled on
    /// first use, over the layout with the ray queries' structure (`rq`: the render's
    /// kernels use ray queries, if not this one) or without; and whether this call made it.
    pub fn get(
        &self,
        ctx: &GpuContext,
        kernel: Kernel,
        variant: Variant,
        rq: bool,
    ) -> Result<(Arc<wgpu::ComputePipeline>, bool)> {
        let variant = kernel.variant_of(variant);
        let rq = rq || variant.ray_queries();
        if let Some(k) = self.cache.lock().expect("kernel cache lock").get(&(kernel, variant, rq)) {
            return Ok((k.clone(), false));
        }
        // Made outside the lock, so that several kernels are made at once (lavapipe turns
        // each into its own IR at this call: tens of milliseconds a kernel).
        let layouts = self.layouts(rq).ok_or_else(|| {
            crate::error::Error::Options(format!(
                "{} has no ray queries for the {} kernel",
                ctx.info.name,
                kernel.name()
            ))
        })?;
        let pipeline = Arc::new(compute_pipeline(ctx, kernel, variant, Some(&layouts.pipeline))?);
        self.compiles.fetch_add(1, Ordering::Relaxed);
        let mut cache = self.cache.lock().expect("kernel cache lock");
        Ok((cache.entry((kernel, variant, rq)).or_insert(pipeline).clone(), true))
    }

    /// Records that the pipeline of `kernel` for `variant` has been dispatched; `true` the
    /// first time in this process.
    pub fn first_warm_up(&self, kernel: Kernel, variant: Variant) -> bool {
        self.warmed.lock().expect("warm-up lock").insert((kernel, kernel.variant_of(variant)))
    }
}

/// The marker file saying that `kernel` for `variant` has been compiled on this machine by
/// this adapter and driver, when there is none yet (`None`: compiled before, or no cache
/// folder). It lives in `$XDG_CACHE_HOME/cuberay/kernels` (else `~/.cache/cuberay/kernels`)
/// and is named by a hash of the adapter, the driver and the kernel's WGSL. It only decides
/// whether to print the notice: a missing or stale marker costs one line on stderr.
pub fn first_compile_marker(ctx: &GpuContext, kernel: Kernel, variant: Variant) -> Result<Option<PathBuf>> {
    let Some(dir) = kernel_cache_dir() else { return Ok(None) };
    let variant = kernel.variant_of(variant);
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let info = &ctx.info;
    (&info.name, &info.driver, &info.driver_info, info.vendor, info.device).hash(&mut h);
    (kernel.name(), shaders::compose(kernel, variant)?).hash(&mut h);
    let marker = dir.join(format!("{}-{:016x}", kernel.name(), h.finish()));
    Ok((!marker.exists()).then_some(marker))
}

/// Writes a marker from [`first_compile_marker`]; a failure only means the notice comes again.
pub fn mark_compiled(marker: &std::path::Path) {
    let made =
        marker.parent().map(std::fs::create_dir_all).transpose().and_then(|_| std::fs::write(marker, b""));
    if let Err(e) = made {
        log::debug!("cannot write the kernel marker {}: {e}", marker.display());
    }
}

/// `$XDG_CACHE_HOME/cuberay/kernels`, else `$HOME/.cache/cuberay/kernels`.
fn kernel_cache_dir() -> Option<PathBuf> {
    let non_empty = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    let base = non_empty("XDG_CACHE_HOME").or_else(|| non_empty("HOME").map(|h| h.join(".cache")))?;
    Some(base.join("cuberay").join("kernels"))
}

/// The compute pipeline of `kernel` for `variant` (`layout`: `None` takes the layout the
/// shader implies).
pub fn compute_pipeline(
    ctx: &GpuContext,
    kernel: Kernel,
    variant: Variant,
    layout: Option<&wgpu::PipelineLayout>,
) -> Result<wgpu::ComputePipeline> {
    let module = shader_module(ctx, kernel, variant)?;
    Ok(ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(kernel.name()),
        layout,
        module: &module,
        entry_point: Some(kernel.name()),
        compilation_options: Default::default(),
        cache: None,
    }))
}

/// The shader module of `kernel` for `variant`, labelled with the kernel's name.
pub fn shader_module(ctx: &GpuContext, kernel: Kernel, variant: Variant) -> Result<wgpu::ShaderModule> {
    let source = shaders::compose(kernel, variant)?;
    // Ray-query kernels keep naga's checks around each query: without them (a trusted
    // module) the kernels took 1.05–1.08× the time on Mesa 25.0, no faster
    // (docs/performance.md, "Ray queries").
    Ok(ctx.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(kernel.name()),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    }))
}

/// The pipelines a schedule dispatches: the wavefront kernels of a render's variant, each
/// with the depths it serves ([`Kernel::wavefront`]), or one kernel run once over each tile
/// (the `aov` kernel).
pub enum Pipelines<'a> {
    Wavefront(&'a [StagePipeline]),
    Single(&'a wgpu::ComputePipeline),
}

impl Pipelines<'_> {
    /// The pipeline of `kernel` for the passes of depth `depth`.
    pub fn of(&self, k: Kernel, depth: u32) -> &wgpu::ComputePipeline {
        match self {
            Pipelines::Single(p) => p,
            Pipelines::Wavefront(all) => all
                .iter()
                .find(|p| p.0.kernel == k && p.0.serves(depth))
                .map(|p| p.1.as_ref())
                .unwrap_or_else(|| panic!("a pass of the {} kernel, which this variant lacks", k.name())),
        }
    }
}
