//! The flat GPU layout, without wgpu: the `#[repr(C)]` twins of every WGSL struct and
//! constant shared with the host ([`structs`], [`counters`]), the scene packed into them
//! ([`pack`](mod@pack)), and the limits one kernel step keeps to ([`budget`]).

pub mod budget;
pub mod counters;
pub mod pack;
pub mod structs;

pub use pack::{job_params, pack, Packed};
pub use structs::*;
