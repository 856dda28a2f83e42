//! The tone mapping of `shaders/shared/tonemap.wgsl` (the preview's) against its Rust twin,
//! `Tonemap::apply` (the PNG output's), on the GPU.

use cuberay::gpu::shaders::{compose_root, Variant};
use cuberay::gpu::GpuContext;

use super::Rng;

/// The preview's tone mapping (`shaders/shared/tonemap.wgsl`) against its twin
/// (`Tonemap::apply`, which the PNG output uses) on the GPU, for every mode over colours from
/// black to 64 times white: within a few ulps of 1 (Vulkan lets a driver's division be off
/// by 2.5 ulps), so the window and the PNG show the same 8-bit values but at a rounding edge.
#[test]
fn the_tone_mapping_matches_its_rust_twin_on_the_gpu() {
    use cuberay::scene::Tonemap;
    const KERNEL: &str = r#"
#include "shared/tonemap.wgsl"

@group(0) @binding(0) var<storage, read> inputs: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> outputs: array<vec4<f32>>;

@compute @workgroup_size(64)
fn tone(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&inputs) {
        return;
    }
    let c = inputs[i];
    outputs[i] = vec4<f32>(tonemap(c.xyz, bitcast<u32>(c.w)), 0.0);
}
"#;
    let modes = [(Tonemap::None, 0u32), (Tonemap::PbrNeutral, 1), (Tonemap::Aces, 2)];
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let mut inputs = Vec::new();
    for &(_, code) in &modes {
        for _ in 0..2000 {
            let scale = (2.0f32).powf(rng.range(-10.0, 6.0));
            let c = [rng.unit() * scale, rng.unit() * scale, rng.unit() * scale];
            inputs.push([c[0], c[1], c[2], f32::from_bits(code)]);
        }
        inputs.push([0.0, 0.0, 0.0, f32::from_bits(code)]);
        inputs.push([0.76, 0.5, 0.1, f32::from_bits(code)]);
    }
    let ctx = GpuContext::new().unwrap_or_else(|e| panic!("{e}"));
    let source = compose_root(KERNEL, Variant::default()).expect("the test kernel composes");
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("tone"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("tone"),
        layout: None,
        module: &module,
        entry_point: Some("tone"),
        compilation_options: Default::default(),
        cache: None,
    });
    use wgpu::util::DeviceExt;
    let bytes = (inputs.len() * 16) as u64;
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("inputs"),
        contents: bytemuck::cast_slice(&inputs),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("outputs"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("tone"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: input.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: output.as_entire_binding() },
        ],
    });
    let readback = ctx.readback_buffer("tone readback", bytes);
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((inputs.len() as u32).div_ceil(64), 1, 1);
    }
    enc.copy_buffer_to_buffer(&output, 0, &readback, 0, bytes);
    ctx.queue.submit([enc.finish()]);
    let out = ctx.read(&readback, bytes).unwrap();
    let out: &[[f32; 4]] = bytemuck::cast_slice(&out);
    let mut worst = 0.0f32;
    for (i, c) in inputs.iter().enumerate() {
        let mode = modes.iter().find(|m| m.1 == c[3].to_bits()).unwrap().0;
        let want = mode.apply([c[0], c[1], c[2]]);
        for k in 0..3 {
            let d = (out[i][k] - want[k]).abs();
            worst = worst.max(d);
            assert!(d <= 4e-6, "{mode:?} of {:?}: GPU {:?}, CPU {want:?}", &c[..3], &out[i][..3]);
        }
        if mode != Tonemap::None {
            assert!(want.iter().all(|v| (0.0..=1.0).contains(v)));
        }
    }
    eprintln!("tone mapping: {} colours, GPU and CPU within {worst:e}", inputs.len());
}
