//! Compiled kernels: one pipeline per kernel and [`Variant`], compiled on first use and
//! cached, over the one bind group layout of the scene buffers (`shaders/shared/layout.wgsl`
//! and `shaders/shared/tables.wgsl`: bindings 0 to 19).

use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use super::shaders::{self, Kernel, Variant};
use super::GpuContext;
use crate::error::Result;

/// The scene buffers' bindings: 0 `params`, 1–6 the read-only scene, 7–10 the kernels'
/// outputs and state, 11–19 the candidate tables (brute-force kernels leave them unused).
/// `params` is a read-only storage buffer, not a uniform: lavapipe would compile a variant
/// of the kernel for every tile's values (see `shaders/shared/layout.wgsl`).
fn bind_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    };
    let storage = |read_only| wgpu::BufferBindingType::Storage { read_only };
    let mut entries = vec![entry(0, storage(true))];
    entries.extend((1..=6).map(|b| entry(b, storage(true))));
    entries.extend((7..=10).map(|b| entry(b, storage(false))));
    entries.extend((11..=19).map(|b| entry(b, storage(true))));
    entries
}

/// The compute pipelines of the trace kernels (`render`, `aov`) by variant.
pub struct Kernels {
    bind_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    cache: Mutex<HashMap<(Kernel, Variant), Arc<wgpu::ComputePipeline>>>,
    compiles: AtomicUsize,
}

impl Kernels {
    pub fn new(ctx: &GpuContext) -> Kernels {
        let bind_layout = ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scene"),
            entries: &bind_layout_entries(),
        });
        let pipeline_layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("scene"),
            bind_group_layouts: &[Some(&bind_layout)],
            immediate_size: 0,
        });
        Kernels {
            bind_layout,
            pipeline_layout,
            cache: Mutex::new(HashMap::new()),
            compiles: AtomicUsize::new(0),
        }
    }

    /// The layout of the scene buffers' bind group.
    pub fn bind_layout(&self) -> &wgpu::BindGroupLayout {
        &self.bind_layout
    }

    /// How many pipelines have been compiled so far (each kernel and variant once).
    pub fn compiled(&self) -> usize {
        self.compiles.load(Ordering::Relaxed)
    }

    /// The pipeline of `kernel` (`render` or `aov`) for `variant`, compiled on first use.
    pub fn get(
        &self,
        ctx: &GpuContext,
        kernel: Kernel,
        variant: Variant,
    ) -> Result<Arc<wgpu::ComputePipeline>> {
        let mut cache = self.cache.lock().expect("kernel cache lock");
        if let Some(k) = cache.get(&(kernel, variant)) {
            return Ok(k.clone());
        }
        let pipeline = Arc::new(compute_pipeline(ctx, kernel, variant, Some(&self.pipeline_layout))?);
        self.compiles.fetch_add(1, Ordering::Relaxed);
        cache.insert((kernel, variant), pipeline.clone());
        Ok(pipeline)
    }
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
    Ok(ctx.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(kernel.name()),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    }))
}
