//! The preview's display pass (`shaders/display.wgsl`): a full-window triangle whose fragments
//! read the accumulation and encode its average as the headless PNG output does.

use super::session::Session;
use crate::error::Result;
use crate::gpu::bindings::{self, DISPLAY};
use crate::gpu::kernels::shader_module;
use crate::gpu::shaders::{Kernel, Variant};
use crate::gpu::GpuContext;
use crate::scene::{Tonemap, Transfer};

/// What the window shows, read by the display pass (WGSL `View` in
/// `shaders/display.wgsl`, keep them in sync).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct View {
    pub width: u32,
    pub height: u32,
    pub grid_w: u32,
    /// Samples accumulated per grid point (0: nothing to show yet).
    pub samples: u32,
    /// 1: the accumulation holds pixel corners (SPD sampling); a pixel averages four.
    pub corners: u32,
    /// What the shader does after clamping: one of the `ENCODE_*` codes.
    pub encode: u32,
    /// Pixels per grid point edge: 1, or a moving camera's coarse block.
    pub block: u32,
    /// The tone mapping before the clamp: one of the `TONEMAP_*` codes.
    pub tonemap: u32,
    /// What the values are multiplied by first: 2^`--exposure`.
    pub exposure: f32,
    pub pad1: u32,
}

/// [`View::tonemap`] codes (WGSL `TONEMAP_*`): [`Tonemap`]'s.
pub const TONEMAP_NONE: u32 = 0;
pub const TONEMAP_PBR_NEUTRAL: u32 = 1;
pub const TONEMAP_ACES: u32 = 2;

/// [`View::encode`] codes (WGSL `ENCODE_*`): store the clamped value as it is, sRGB-encode
/// it, or undo the sRGB encoding an sRGB target format applies.
pub const ENCODE_NONE: u32 = 0;
pub const ENCODE_SRGB: u32 = 1;
pub const ENCODE_LINEARIZE: u32 = 2;

/// The display pass: a full-window triangle whose fragments read the accumulation.
pub struct Display {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    view_buffer: wgpu::Buffer,
    /// The target format encodes sRGB in hardware.
    srgb_target: bool,
}

impl Display {
    pub fn new(ctx: &GpuContext, format: wgpu::TextureFormat) -> Result<Display> {
        let device = &ctx.device;
        let module = shader_module(ctx, Kernel::Display, Variant::default())?;
        let layout = bindings::layout(device, "display", DISPLAY, wgpu::ShaderStages::FRAGMENT);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("display"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("display"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(format.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let view_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("display view"),
            size: std::mem::size_of::<View>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(Display { layout, pipeline, view_buffer, srgb_target: format.is_srgb() })
    }

    /// Draws the session's accumulation into `target`.
    pub fn draw(&self, ctx: &GpuContext, session: &Session, target: &wgpu::TextureView) {
        let o = session.options();
        let shown = session.shown();
        let view = View {
            width: o.width,
            height: o.height,
            grid_w: shown.grid_w,
            samples: shown.samples,
            corners: shown.corners as u32,
            block: shown.block,
            encode: match (session.transfer(), self.srgb_target) {
                (Transfer::Srgb, false) => ENCODE_SRGB,
                (Transfer::Display, true) => ENCODE_LINEARIZE,
                _ => ENCODE_NONE,
            },
            tonemap: match o.tonemap_for(session.scene()) {
                Tonemap::None => TONEMAP_NONE,
                Tonemap::PbrNeutral => TONEMAP_PBR_NEUTRAL,
                Tonemap::Aces => TONEMAP_ACES,
            },
            exposure: crate::output::exposure_scale(o.exposure),
            ..View::default()
        };
        ctx.queue.write_buffer(&self.view_buffer, 0, bytemuck::bytes_of(&view));
        let bind = bindings::buffers_group(
            &ctx.device,
            "display",
            &self.layout,
            &DISPLAY,
            [&self.view_buffer, shown.buffer],
        );
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("display"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.draw(0..3, 0..1);
        }
        ctx.queue.submit([enc.finish()]);
    }
}
