//! The GPU side: device setup now; the WGSL kernels that trace the candidate tables come
//! with the GPU renderer.

mod context;

pub use context::{GpuContext, GpuError};
