//! The flat GPU layout, without wgpu: the `#[repr(C)]` twins of the structs and constants of
//! `shaders/shared/layout.wgsl`, `wavefront.wgsl` and `counters.wgsl` ([`structs`],
//! [`counters`]; the tables' are in [`crate::coherence::flat`]), the scene packed into them
//! ([`pack`](mod@pack)), the kernels' parameters written in one place ([`params`]), the BVH flattened for the kernels' walk ([`bvh`]), the boxes the
//! platform's ray queries are built over ([`rayquery`]), and the limits one kernel pass
//! keeps to ([`budget`]).

pub mod budget;
pub mod bvh;
pub mod counters;
pub mod pack;
pub mod params;
pub mod rayquery;
pub mod structs;

pub use pack::{pack, pack_moved, Packed};
pub use structs::*;
