//! Fuzz target: the nff reader, through the harness the regression test replays; and the
//! chunked parse, which large files get, against the serial one: the same scene, warnings
//! or error (inputs here are below the size that is parsed in chunks by default).
#![no_main]

use std::path::Path;

use cuberay::load::nff::parse_in_chunks;

#[path = "../harness.rs"]
#[allow(dead_code)]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = harness::run(harness::Reader::Nff, data);
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("scene.nff");
    let outcome = |chunk_bytes| match parse_in_chunks(text, path, chunk_bytes) {
        Ok(loaded) => format!("{loaded:?}"),
        Err(e) => format!("{e} | {e:?}"),
    };
    let serial = outcome(usize::MAX);
    for chunk_bytes in [1, 97] {
        assert!(outcome(chunk_bytes) == serial, "chunks of {chunk_bytes} bytes differ from the serial parse");
    }
});
