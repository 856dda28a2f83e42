//! Fuzz target: the part_exr reader, through the harness the regression test replays.
#![no_main]

#[path = "../harness.rs"]
#[allow(dead_code)]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = harness::run(harness::Reader::PartExr, data);
});
