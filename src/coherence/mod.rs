//! The coherence preprocessing (to be written): direction-cube candidate tables, flattened for the GPU.
