//! cuberay: a GPU Whitted ray tracer that traces Ohta and Maekawa's direction-cube
//! candidate tables ("ray coherence", 1987) in WGSL compute shaders.
//!
//! Data flows one way:
//!
//! ```text
//! scene file ──load──▶ Scene ──coherence──▶ candidate tables ──flatten──▶ GPU buffers ──WGSL──▶ image
//!                        └──────────────reference (CPU, f64)──────────────────────────────────▶ image
//! ```
//!
//! Layers, each using only those before it: [`scene`] ← [`load`]; [`scene`] ← [`arith`] ←
//! [`coherence`] ← [`layout`] ← [`gpu`] ← [`preview`], [`accuracy`]; the CPU
//! [`reference`](mod@reference) beside them.
//! [`job`], [`sampling`], [`bvh`], [`stats`], [`phases`], [`output`], [`region`], [`part`],
//! [`interrupt`] and [`error`] are shared by both backends.
//!
//! - [`scene`]: the plain-data scene model both renderers read;
//! - [`load`]: NFF and glTF loaders that produce a validated [`scene::Scene`];
//! - [`job`]: what to render ([`job::RenderOptions`]) and what a render returns;
//! - [`sampling`]: where eye rays go through the image;
//! - [`bvh`]: the bounding volume hierarchy both backends can trace (`--accel bvh`), the
//!   baseline the candidate tables are measured against;
//! - [`arith`]: the kernels' f32 arithmetic on the CPU (twins of the WGSL geometry);
//! - [`coherence`]: the direction-cube candidate tables, flattened, and their one walker;
//! - [`cost`]: what `--accel auto` weighs: each origin's table build against what it saves;
//! - [`layout`]: the `#[repr(C)]` twins of the WGSL structs and constants, the packed scene;
//! - [`gpu`]: the WGSL kernels through wgpu;
//! - [`preview`]: the interactive window that refines a render progressively;
//! - [`reference`](mod@reference): the independent CPU renderer in f64;
//! - [`stats`], [`phases`], [`output`], [`compare`], [`info`]: statistics, where a command's
//!   time goes, image files, image comparison, scene summaries;
//! - [`region`], [`part`]: the part of an image a render covers (`--tile`, `--crop`), and
//!   the partial EXRs that `cuberay merge` assembles;
//! - [`tablefile`]: candidate tables stored on disk, so that the tasks of a split render
//!   share one build;
//! - [`accuracy`]: what accuracy costs in time: settings swept on the GPU against a
//!   converged CPU reference, with error metrics and a plot;
//! - [`interrupt`]: how a render in progress is asked to stop (Ctrl-C, a closed window);
//! - [`error`]: the library's one error type.

pub mod accuracy;
pub mod arith;
pub mod bvh;
pub mod coherence;
pub mod compare;
pub mod cost;
pub mod error;
pub mod gpu;
pub mod info;
pub mod interrupt;
pub mod job;
pub mod layout;
pub mod load;
pub mod output;
pub mod part;
pub mod phases;
pub mod preview;
pub mod reference;
pub mod region;
pub mod sampling;
pub mod scene;
pub mod stats;
pub mod tablefile;

pub use error::{Error, Result};
