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
//! - [`scene`]: the plain-data scene model both renderers read;
//! - [`load`]: NFF and glTF loaders that produce a validated [`scene::Scene`];
//! - [`info`]: the summary `cuberay info` prints;
//! - [`coherence`]: the direction-cube candidate tables, flattened for the GPU, and their CPU walker;
//! - [`mirror`]: f32 Rust twins of the WGSL functions (cell lookup, intersections, table walk);
//! - [`preview`]: the interactive window that refines a render progressively.

pub mod coherence;
pub mod compare;
pub mod error;
pub mod gpu;
pub mod info;
pub mod job;
pub mod kernel;
pub mod layout;
pub mod load;
pub mod output;
pub mod preview;
pub mod reference;
pub mod sampling;
pub mod scene;
pub mod stats;

pub use error::{Error, Result};
