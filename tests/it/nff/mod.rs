//! Tests of the NFF loader: every entity, every kind of bad input (each error must name the
//! line and say what is wrong), ear clipping of concave polygons, and every SPD file of the
//! shared scenes (counts checked against an independent scan of the file).
//!
//! This module holds the helpers the areas share (parsing, the error checks, triangles, the
//! dropped count, vector areas); the tests are in one sub-module per area:
//!
//! - `entities`: every entity and how it maps onto the scene model;
//! - `triangulation`: ear clipping of concave, tilted and degenerate polygons, tiled exactly;
//! - `bad_input`: each kind of bad input, the error naming the line and saying what is
//!   wrong, and token soup that never panics;
//! - `spd`: every SPD file of the shared scenes, against an independent scan;
//! - `chunked`: the chunked parallel parse gives what the serial one gives.
//!
//! Every helper below also checks that the chunked parse agrees with the serial one on its
//! text ([`same_as_serial`]), so every case of every area checks that too.

use std::path::Path;

use cuberay::load::nff::parse_in_chunks;
use cuberay::load::Loaded;
use cuberay::scene::{Primitive, Triangle};
use cuberay::Error;
use glam::DVec3;

mod bad_input;
mod chunked;
mod entities;
mod spd;
mod triangulation;

// ---------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------

/// A view that every small test scene starts with (3 lines).
const VIEW: &str = "v\nfrom 0 0 10 at 0 0 0 up 0 1 0\nangle 45\n";

/// How a parse ended, in full: the scene and warnings, or the error's message and fields.
fn outcome(result: &Result<Loaded, Error>) -> String {
    match result {
        Ok(loaded) => format!("{loaded:?}"),
        Err(e) => format!("{e} | {e:?}"),
    }
}

/// Parses `text` serially, and checks that the chunked parse gives exactly the same
/// outcome, with chunks of every entity (1 byte) up to about a kilobyte.
#[track_caller]
fn same_as_serial(text: &str, path: &Path) -> Result<Loaded, Error> {
    let serial = parse_in_chunks(text, path, usize::MAX);
    let expected = outcome(&serial);
    for chunk_bytes in [1, 50, 1000] {
        let chunked = parse_in_chunks(text, path, chunk_bytes);
        assert!(
            outcome(&chunked) == expected,
            "{}: chunks of {chunk_bytes} bytes give\n{}\nthe serial parse\n{}",
            path.display(),
            outcome(&chunked).chars().take(2000).collect::<String>(),
            expected.chars().take(2000).collect::<String>()
        );
    }
    serial
}

fn parse_ok(text: &str) -> Loaded {
    match same_as_serial(text, Path::new("test.nff")) {
        Ok(loaded) => loaded,
        Err(e) => panic!("expected the scene to load, got: {e}\n--- input ---\n{text}"),
    }
}

/// Parses `text`, expects an NFF error on `line` whose message contains every one of
/// `words`, and returns the offending token.
#[track_caller]
fn nff_error(text: &str, line: usize, words: &[&str]) -> Option<String> {
    match same_as_serial(text, Path::new("bad.nff")) {
        Err(e @ Error::Nff { .. }) => {
            let shown = e.to_string();
            let Error::Nff { line: got, token, message, path } = e else { unreachable!() };
            assert_eq!(got, line, "wrong line in: {shown}");
            assert_eq!(path, Path::new("bad.nff"));
            assert!(
                shown.starts_with(&format!("bad.nff:{line}: ")),
                "display does not name file and line: {shown}"
            );
            for w in words {
                assert!(message.contains(w), "message lacks '{w}': {shown}");
            }
            token
        }
        Err(e) => panic!("expected an NFF syntax error, got: {e}"),
        Ok(_) => panic!("expected an error on line {line}, the scene loaded\n--- input ---\n{text}"),
    }
}

#[track_caller]
fn invalid_error(text: &str, words: &[&str]) {
    match same_as_serial(text, Path::new("bad.nff")) {
        Err(e @ Error::Invalid { .. }) => {
            let shown = e.to_string();
            assert!(shown.starts_with("bad.nff: "), "{shown}");
            for w in words {
                assert!(shown.contains(w), "message lacks '{w}': {shown}");
            }
        }
        Err(e) => panic!("expected an invalid-scene error, got: {e}"),
        Ok(_) => panic!("expected an error, the scene loaded"),
    }
}

fn triangles(loaded: &Loaded) -> Vec<&Triangle> {
    loaded
        .scene
        .primitives
        .iter()
        .filter_map(|p| if let Primitive::Triangle(t) = p { Some(t) } else { None })
        .collect()
}

/// The number in the "dropped N degenerate triangle(s)" warning, or 0.
fn dropped(loaded: &Loaded) -> usize {
    loaded
        .warnings
        .iter()
        .find_map(|w| w.strip_prefix("dropped "))
        .map(|rest| rest.split_whitespace().next().unwrap().parse().unwrap())
        .unwrap_or(0)
}

/// Newell's vector area (half the sum of the edge cross products) of a polygon.
fn vector_area(points: &[DVec3]) -> DVec3 {
    let o = points[0];
    let mut n = DVec3::ZERO;
    for i in 1..points.len() - 1 {
        n += (points[i] - o).cross(points[i + 1] - o);
    }
    n * 0.5
}
