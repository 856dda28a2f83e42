//! The kernels' f32 arithmetic on the CPU: line-by-line Rust twins of the WGSL functions in
//! `shaders/shared/geometry.wgsl`, `intersect.wgsl`, `closest.wgsl` and `brute.wgsl`, with
//! the same names (the one exception: WGSL `intersect_prim` is
//! [`geometry::Prim32::intersect`]), so that tests, the table build and the measurements
//! compute exactly what the GPU computes.
//!
//! - [`geometry`]: rays, primitive hits, the intersection routines, [`geometry::Prim32`] (a
//!   primitive as the GPU stores it, re-centred on the eye);
//! - [`closest`]: the nearest-hit rule every query shares (ties to the lower id), generic over
//!   the distance type so that the f64 reference can use it too, and brute force;
//! - [`spawn`]: the one spawn-offset model: where a ray leaving a surface starts, under a
//!   [`spawn::SpawnPolicy`], and the largest offset a render can see (what the tables inflate
//!   their origins by);
//! - [`precision`]: whether f32 resolves a scene as its image shows it (`--precision auto`).
//!
//! Everything here is written so that the WGSL can follow it line by line: no recursion, no
//! allocation, no NaN or infinity as a sentinel (a miss is [`FAR`], `0x1.fffffep+127f`), only
//! operations WGSL has. The table walk's twin is [`crate::coherence::walk`], the sampling's is
//! [`crate::sampling`].

pub mod closest;
pub mod geometry;
pub mod precision;
pub mod spawn;

/// The largest finite f32: the open end of an unbounded ray, and "no hit" (WGSL `FAR`).
pub const FAR: f32 = f32::MAX;
/// "No primitive" (WGSL `NO_ID`).
pub const NO_ID: u32 = u32::MAX;
/// Shadow rays of a positional light, traced from the light towards the point they are cast
/// for, end this relative distance before that point (WGSL `SHADOW_END_REL`, `2⁻²⁰`).
pub const SHADOW_END_REL: f32 = 1.0 / 1048576.0;
