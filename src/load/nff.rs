//! NFF loader: Eric Haines' Neutral File Format (the Standard Procedural Databases) into a
//! [`Scene`]. The specification is `spd/doc/NFF.TXT` (v3.9) of the shared scenes.
//!
//! # Reading
//! The file is read as whitespace-separated tokens, each with its 1-based line; `#` starts
//! a comment that runs to the end of its line ([`cursor`] walks the text without building
//! a token list). Entities are read token by token, not line by line: the SPD generators
//! write a whole cylinder on one line where the specification shows three. Entities may
//! come in any order (`b` before `v`, lights after objects), but there must be exactly one
//! `v`.
//!
//! A large file is parsed in chunks on all cores ([`chunks`]): it is cut where a line
//! starts with an entity keyword, each chunk is read on its own, and the chunks' states are
//! joined in file order. The scene, the warnings and the first error are exactly those of
//! a serial parse.
//!
//! # Mapping onto the scene model
//! - `v`: [`Camera::look_at`] with a perspective projection whose `angle` is the full field
//!   of view between the centres of the edge pixels ([`FovSpan::EdgePixelCenters`]);
//!   `from`, `at`, `up` and `angle` are required, `hither` (default 0) becomes
//!   [`Camera::near`], `resolution` becomes [`Scene::resolution`].
//! - `b`: the background colour (black without one).
//! - `l X Y Z [R G B]`: a point light without distance falloff, white unless coloured. NFF
//!   leaves the intensity open; following the SPD suggestion every one of the L lights gets
//!   intensity `sqrt(L)/(2L)` and the ambient light is white with the same scalar. A file
//!   without lights gets [`Light::default_for`] the camera (with a warning) and the ambient
//!   of a single light, 0.5.
//! - `f`: one [`Material`] per entity, mapped as [`crate::scene`] documents. `ior <= 0` (the
//!   SPD files write 0 for opaque surfaces) is stored as 1 when T = 0 and is an error when the
//!   surface transmits. Primitives before the first `f` get [`Material::default`], which is
//!   added to the materials only when used.
//! - `s`: a sphere; a negative radius means only the inside is visible (`inside_only`).
//! - `c`: a cylinder or cone without caps. Both radii negative means inside only; one radius
//!   may be zero (a cone ending in a point).
//! - `p` and `pp`: polygons, triangulated by ear clipping in the polygon's plane (they may be
//!   concave: the gears have 144-vertex faces). A polygon of n vertices always accounts for
//!   n − 2 triangles: those without area (repeated or collinear vertices) are dropped and
//!   counted in one warning. `pp` keeps its vertex normals, normalised; a zero normal is
//!   replaced by the triangle's geometric normal, with a warning.
//!
//! # Errors
//! Unknown keywords, missing or non-numeric or non-finite numbers, bad vertex counts, zero
//! sphere radii, coincident cylinder ends and impossible views are [`Error::Nff`] naming
//! the line and the token. A file without `v` or without any primitive is
//! [`Error::Invalid`]. The loader never panics.

use std::path::Path;

use super::Loaded;
use crate::error::Error;

mod chunks;
mod cursor;
mod entities;
mod number;
mod state;

/// Loads an NFF file.
pub fn load(path: &Path) -> Result<Loaded, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
    match std::str::from_utf8(&bytes) {
        Ok(text) => parse(text, path),
        Err(e) => {
            let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
            Err(Error::Nff {
                path: path.to_owned(),
                line,
                token: None,
                message: "the file is not text: it holds a byte that is not UTF-8".into(),
            })
        }
    }
}

/// Parses NFF text; `path` is only used in error messages. Large texts are parsed in
/// parallel chunks.
pub fn parse(text: &str, path: &Path) -> Result<Loaded, Error> {
    chunks::parse(text, path, chunks::chunk_bytes(text.len()))
}

/// [`parse`] with chunks of about `chunk_bytes` bytes (at least one entity each); `usize::MAX`
/// parses serially. For tests that compare the chunked parse with the serial one.
#[doc(hidden)]
pub fn parse_in_chunks(text: &str, path: &Path, chunk_bytes: usize) -> Result<Loaded, Error> {
    chunks::parse(text, path, chunk_bytes.max(1))
}

const KEYWORDS: [&str; 8] = ["v", "b", "l", "f", "c", "s", "p", "pp"];
const VIEW_KEYWORDS: [&str; 6] = ["from", "at", "up", "angle", "hither", "resolution"];
const AXES: [&str; 3] = ["x", "y", "z"];
