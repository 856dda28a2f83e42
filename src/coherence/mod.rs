//! The coherence preprocessing: Ohta and Maekawa's direction-cube candidate tables, built on
//! the CPU from a [`Scene`](crate::scene::Scene), flattened into the buffers the GPU reads,
//! and walked by the one walker the CPU and (as its WGSL twin) the GPU share.
//!
//! This module owns the tables and nothing else: it does no file IO and knows nothing of
//! wgpu. Its files, in the order data flows through them:
//! - [`params`]: what a build may be told (resolutions, spawn-offset policy, effects);
//! - [`targets`]: every primitive as a target (bounding shape, self-listing, occluder);
//! - [`hierarchy`]: the bounding-sphere hierarchy over targets;
//! - [`defs`]: the direction cubes to build (eye frustum, lights);
//! - [`context`]: the shared inputs of the builds;
//! - [`cells`]: direction-cube cells and cones, and the cell tests;
//! - [`cuts`]: the cells' cut-off distances, shared by the threads building an origin;
//! - [`bounds`]: direction bounds from an origin sphere to spheres, triangles and capsules;
//! - [`pair`]: one origin–target bound, its `d_min` and cover test;
//! - [`raster`]: rasterising a bound into an origin's cells;
//! - [`origin`]: building one direction cube (rayon-parallel over origins);
//! - [`lists`]: finishing one cube's lists (sorting, window cropping);
//! - [`raytree`]: the kernels' ray trees in f32, which the audit traces;
//! - [`tables`]: the whole build ([`build`]) and the eye-only rebuild;
//! - [`flatten`]: cubes into flat buffers, with the fallback origin;
//! - [`flat`]: the `#[repr(C)]` buffers and their documented layout;
//! - [`reach`]: how long a walk of the flat tables can be (for the GPU's loop budget);
//! - [`cube`]: the direction-cube lookup (face, cell, candidate range);
//! - [`walk`]: the walker (twin of `shaders/shared/walk.wgsl`);
//! - [`stats`]: what `cuberay info --tables` prints;
//! - [`audit`]: a checking tracer for the tests and examples: test counts per ray kind over
//!   a scene's primary rays and their ray trees, checked against brute force.
//!
//! # The method
//! Each origin entity rays leave from (the eye, each point light) has a direction cube of
//! `N×N` cells per face (Ohta and Maekawa). A cell lists every primitive a ray from the origin
//! with a direction in the cell can hit, sorted by a lower bound `d_min` on the hit distance,
//! so a walker stops as soon as `d_min` exceeds the nearest hit so far. Rays leaving surfaces
//! have no one origin: the tables leave them to the BVH. (Arvo and Kirk's ray classification,
//! beams of origin × direction with lists built and walked the same way, was built here and
//! removed: its rays cost 2.0–3.5× the BVH's walk and took seconds to build;
//! docs/performance.md has the figures.)
//!
//! # Conservative in f32
//! Bounds are computed in f64 and widened by an angle `delta` (the GPU's f32 lookup may put a
//! direction in a neighbouring cell or face); origins are spheres inflated by the largest
//! spawn offset of the kernels' model ([`crate::arith::spawn`]) plus f32 rounding of the
//! geometry; `d_min` is lowered by the same amount and rounded down to f32. Correctness never
//! depends on how a lookup resolves a tie at a cell boundary, cube edge or corner.
//!
//! # Usage
//! ```no_run
//! # use cuberay::coherence::{build, walk, BuildParams, OriginKey, WalkCount};
//! # use cuberay::arith::{closest::Closest, FAR, NO_ID};
//! # fn f(scene: &cuberay::scene::Scene) {
//! let tables = build(scene, &BuildParams::default()).unwrap();
//! let dir = glam::Vec3::new(0.0, 0.0, -1.0);
//! // A primary ray from the eye; the walk reads the eye's cell of `dir`.
//! let mut count = WalkCount::default();
//! let hit: Closest<f32, ()> = walk::table_nearest(&tables.flat, OriginKey::Eye, dir, FAR, NO_ID, &mut count, |id| {
//!     let _ = id; // intersect primitive `id` here: Some((t, payload)) for a hit before FAR
//!     None
//! });
//! # let _ = hit; }
//! ```

pub mod audit;
pub mod bounds;
pub mod cells;
pub mod context;
pub mod cube;
pub mod cuts;
pub mod defs;
pub mod flat;
pub mod flatten;
pub mod hierarchy;
pub mod lists;
pub mod origin;
pub mod pair;
pub mod params;
pub mod raster;
pub mod raytree;
pub mod reach;
pub mod stats;
pub mod tables;
pub mod targets;
pub mod walk;

pub use flat::{FlatTables, GpuEntry, GpuFace, GpuOrigin, OriginKind};
pub use params::BuildParams;
pub use stats::TableStats;
pub use tables::{build, traces_surface_rays, untabled_lights, Tables};
pub use walk::{OriginKey, WalkCount};

/// Random numbers and directions for the module's own tests.
#[cfg(test)]
pub(crate) mod testutil {
    use glam::DVec3;

    pub fn rng(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn unit(seed: &mut u64) -> DVec3 {
        loop {
            let v = DVec3::new(rng(seed) * 2.0 - 1.0, rng(seed) * 2.0 - 1.0, rng(seed) * 2.0 - 1.0);
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}
