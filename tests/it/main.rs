//! cuberay's integration tests: one test crate (so that `cargo test` links wgpu and naga
//! once, not once per area), a module per area. docs/architecture.md's test map says what
//! each proves. Run one area with `cargo test --release --test it hard::`.

#[macro_use]
mod common;

mod accuracy;
mod arith;
mod bindings;
mod cli;
mod coherence;
mod environment;
mod fuzz;
mod gltf;
mod gltf_compressed;
mod gpu;
mod hard;
mod matrix;
mod nff;
mod parts;
mod precision;
mod preview;
mod rayquery;
mod reference;
mod shaders;
mod slurm;
mod twins;
