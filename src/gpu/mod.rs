//! The GPU side: device setup ([`GpuContext`]), the WGSL kernels composed per effect set
//! ([`shader`]), the Rust twins of their structs and the scene packing ([`layout`]), the
//! candidate tables as the kernels read them ([`tables`]), and the renderer that runs them
//! ([`GpuRenderer`]).

mod context;
pub mod layout;
mod render;
pub mod shader;
pub mod tables;

pub use context::GpuContext;
pub use render::{
    check, decode_counters, tile_points, uses_tables, GpuRenderer, Kernels, SceneBuffers, COUNTER_SLOTS,
    MAX_DEPTH, WORKGROUP,
};
pub use tables::GpuTables;
