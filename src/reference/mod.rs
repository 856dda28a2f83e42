//! The CPU reference renderer (to be written): Whitted ray tracing in f64, independent of the coherence tables.
