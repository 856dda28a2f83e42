//! Fuzz target: glTF as the optimizers write it (quantized attributes, meshopt and Draco
//! compression, instancing, WebP), through the harness the regression test replays. Its
//! seeds (fuzz/seeds/compressed/, from fuzz/make_compressed_seeds.sh) reach each decoder.
#![no_main]

#[path = "../harness.rs"]
#[allow(dead_code)]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = harness::run(harness::Reader::Compressed, data);
});
