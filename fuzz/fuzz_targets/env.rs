//! Fuzz target: the environment map reader (`--env`), through the harness the regression test
//! replays.
#![no_main]

#[path = "../harness.rs"]
#[allow(dead_code)]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = harness::run(harness::Reader::Env, data);
});
