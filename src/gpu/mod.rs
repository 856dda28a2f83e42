//! The GPU side, the only part of cuberay that uses wgpu (with the preview's window): device
//! setup ([`GpuContext`]), the one preparation of a render without a device ([`prepare`]),
//! the WGSL kernels composed per effect set ([`shaders`]) and compiled
//! ([`kernels`]), the scene's buffers ([`buffers`]), the passes of a wave ([`plan`], plain
//! data), the one dispatch schedule that `render` and the preview share ([`schedule`]), and
//! the renderer ([`GpuRenderer`]). The structs and
//! constants it shares with the WGSL are in [`crate::layout`].

pub mod bindings;
pub mod buffers;
pub mod choose;
mod context;
pub mod kernels;
pub mod plan;
pub mod prepare;
mod render;
pub mod schedule;
pub mod shaders;
mod variant;

pub use buffers::SceneBuffers;
pub use choose::{check, choose, resolve, Capabilities, F32_REACH};
pub use context::GpuContext;
pub use prepare::{prepare, Prepared, Purpose};
pub use render::GpuRenderer;
