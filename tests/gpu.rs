//! GPU tests run on whatever adapter wgpu finds (lavapipe in CI). Without one they fail,
//! and the message says how to install lavapipe.

use cuberay::gpu::GpuContext;

fn gpu() -> GpuContext {
    GpuContext::new().unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn opens_a_device_with_large_storage_bindings() {
    let ctx = gpu();
    eprintln!("adapter: {} ({:?}) {}", ctx.info.name, ctx.info.backend, ctx.info.driver_info);
    // The candidate tables need big storage bindings; WebGPU's default is 128 MiB.
    assert!(ctx.device.limits().max_storage_buffer_binding_size >= 128 << 20);
}
