//! The coherence preprocessing: Ohta and Maekawa's direction-cube candidate tables, built on
//! the CPU from a [`Scene`](crate::scene::Scene) and flattened for the GPU.
//!
//! This module owns the tables and nothing else: it does no file IO and knows nothing of
//! wgpu. It is organised as
//! - [`geom`]: cells, cones, the cell tests (Test A to build, exact Test B to validate), and
//!   the per-shape direction bounds and cover tests;
//! - [`origins`]: targets, origin clusters and the bounding-sphere hierarchy;
//! - [`build`]: the per-origin build (rayon-parallel), resolution and clustering under a
//!   memory budget, and flattening;
//! - [`groups`]: primitive groups, which long candidate lists name instead of their members;
//! - [`flat`]: the `#[repr(C)]` GPU buffers and their documented layout;
//! - [`walk`]: the CPU walker (the WGSL's algorithm, generic over the intersection routine);
//! - [`stats`]: what `cuberay info --tables` prints;
//! - [`bench`]: test counts per ray kind over a scene's primary rays and their ray trees.
//!
//! # The method
//! Each origin entity (the eye, each point light, each cluster of reflecting or transmitting
//! primitives) has a direction cube of `N×N` cells per face. A cell lists every primitive a ray
//! from the origin with a direction in the cell can hit, sorted by a lower bound `d_min` on the
//! hit distance, so a walker stops as soon as `d_min` exceeds the nearest hit so far.
//!
//! # Conservative in f32
//! Bounds are computed in f64 and widened by an angle `delta` (the GPU's f32 lookup may put a
//! direction in a neighbouring cell or face); origins are spheres inflated by the largest
//! spawn offset (plus f32 rounding of the geometry); `d_min` is lowered by the same amount and
//! rounded down to f32. Correctness never depends on how a lookup resolves a tie at a cell
//! boundary, cube edge or corner.
//!
//! # Usage
//! ```no_run
//! # use cuberay::coherence::{build, BuildParams, OriginKey};
//! # fn f(scene: &cuberay::scene::Scene) {
//! let tables = build(scene, &BuildParams::default()).unwrap();
//! let eye = tables.flat.origin(OriginKey::Eye).unwrap();
//! let dir = glam::Vec3::new(0.0, 0.0, -1.0);
//! // A primary ray starts at the eye: the origin of the walkers' camera-relative frame.
//! let at = glam::Vec3::ZERO;
//! let (hit, _count) = tables.flat.walk_nearest(eye, at, dir, f64::MAX, u32::MAX, |id, _t_best| {
//!     let _ = id; // intersect primitive `id` here
//!     None::<f64>
//! });
//! # let _ = hit; }
//! ```

pub mod bench;
pub mod build;
pub mod flat;
pub mod geom;
pub mod groups;
pub mod origins;
pub mod stats;
pub mod walk;

pub use build::{build, default_spawn_offset, BuildParams, ShadowMode, Tables};
pub use flat::{FlatTables, GpuEntry, GpuFace, GpuGroup, GpuOrigin, OriginKind};
pub use stats::TableStats;
pub use walk::{Dist, OriginKey, WalkCount};
