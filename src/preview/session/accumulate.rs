//! The accumulation pass: the `accumulate` kernel adds each finished tile of the wavefront
//! kernels' output to an accumulation; and the order of the passes, each of which renders
//! one sample of the lattice.

use crate::error::Result;
use crate::gpu::bindings::{self, SceneBinding, ACCUMULATE};
use crate::gpu::buffers::check_limits;
use crate::gpu::kernels::compute_pipeline;
use crate::gpu::kernels::Pipelines;
use crate::gpu::kernels::StagePipeline;
use crate::gpu::schedule::{Progress, Schedule};
use crate::gpu::shaders::{Kernel, Variant};
use crate::gpu::{self, SceneBuffers};
use crate::layout::Params;

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

/// The accumulation pass: the `accumulate` kernel and the buffer that tells it which points a
/// finished tile holds.
pub(super) struct Accumulator {
    tile: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl Accumulator {
    pub(super) fn new(ctx: &gpu::GpuContext) -> Result<Accumulator> {
        let tile = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("accumulate tile"),
            size: std::mem::size_of::<Tile>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = bindings::layout(&ctx.device, "accumulate", ACCUMULATE, wgpu::ShaderStages::COMPUTE);
        let pipeline_layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("accumulate"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = compute_pipeline(ctx, Kernel::Accumulate, Variant::default(), Some(&pipeline_layout))?;
        Ok(Accumulator { tile, layout, pipeline })
    }

    /// The bind group that adds the tiles in `buffers`' output to `accum`.
    pub(super) fn bind(
        &self,
        ctx: &gpu::GpuContext,
        buffers: &SceneBuffers,
        accum: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        bindings::buffers_group(
            &ctx.device,
            "accumulate",
            &self.layout,
            &ACCUMULATE,
            [&self.tile, &buffers[SceneBinding::OutColor], accum],
        )
    }
}

/// An accumulation of `points` grid points (one `vec4<f32>` each), zeroed, within the
/// adapter's limits.
pub(super) fn accumulation(ctx: &gpu::GpuContext, label: &str, points: u64) -> Result<wgpu::Buffer> {
    check_limits(&[(label, points * 16)], &ctx.device.limits())?;
    Ok(ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: points * 16,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    }))
}

/// One submission of `schedule` over the kernels `pipelines`; a finished tile is added by
/// `accumulator` to the accumulation that `bind` names, and its points to `points_traced`.
/// Returns whether the tile ended a pass.
#[allow(clippy::too_many_arguments)]
pub(super) fn step_tile(
    ctx: &gpu::GpuContext,
    schedule: &mut Schedule,
    pipelines: &[StagePipeline],
    buffers: &SceneBuffers,
    base: &Params,
    accumulator: &Accumulator,
    bind: &wgpu::BindGroup,
    points_traced: &mut u64,
) -> Result<bool> {
    let kernels = Pipelines::Wavefront(pipelines);
    let Progress::TileDone { first, count, pass_done } = schedule.step(ctx, &kernels, buffers, base)? else {
        return Ok(false);
    };
    let tile = Tile { first_point: first as u32, point_count: count, ..Tile::default() };
    ctx.queue.write_buffer(&accumulator.tile, 0, bytemuck::bytes_of(&tile));
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&accumulator.pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(count.div_ceil(ACCUMULATE_WORKGROUP), 1, 1);
    }
    ctx.queue.submit([enc.finish()]);
    *points_traced += count as u64;
    Ok(pass_done)
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
}
