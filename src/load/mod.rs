//! Scene loaders: NFF (Haines' Standard Procedural Databases) and glTF 2.0 (.gltf, .glb).
//!
//! Every loader returns a validated [`Scene`] (see the invariants in [`crate::scene`]) or a
//! [`Error`] that names the file, the place in it (NFF: line and token; glTF: the JSON
//! path of the node, mesh, accessor...) and what was wrong. Loaders never panic on input.

use std::path::Path;

use crate::error::Error;
use crate::scene::Scene;

pub mod gltf;
pub mod nff;
mod polygon;
pub mod setup;

pub use setup::{apply as apply_setup, EnvChoice, Setup};

/// Options that select among what a file offers.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// glTF: which camera node to use, counted from 0 in traversal order (depth first,
    /// roots in scene order, children in file order). Default: the first; with none, a
    /// camera framing the scene's bounds.
    pub camera: Option<usize>,
    /// glTF: pose the animated nodes at this time in seconds (`--frames`); `None`: the
    /// nodes' own transforms. A file without animations is refused when it is given.
    pub time: Option<f64>,
}

/// A loaded scene and the warnings the loader gathered (dropped degenerate triangles,
/// ignored extensions, the default light...).
#[derive(Clone, Debug)]
pub struct Loaded {
    pub scene: Scene,
    pub warnings: Vec<String>,
    /// The file's format: a glTF scene without lights gets the studio environment by
    /// default ([`setup::apply`]).
    pub format: SceneFormat,
}

/// The format a scene was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    Nff,
    Gltf,
}

/// Loads a scene file, choosing the format by extension.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Loaded, Error> {
    if path.is_dir() {
        return Err(Error::Io {
            path: path.to_owned(),
            source: std::io::Error::new(std::io::ErrorKind::IsADirectory, "a folder, not a scene file"),
        });
    }
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("nff") => match options.camera {
            Some(n) => Err(Error::Options(format!(
                "--camera {n}: {} is an NFF file, whose one view is its `v` block; --camera picks a \
                 camera of a glTF scene",
                path.display()
            ))),
            None => nff::load(path),
        },
        Some("gltf") | Some("glb") => gltf::load(path, options),
        _ => Err(Error::UnknownSceneFormat { path: path.to_owned() }),
    }
}

/// Where the built-in showcase scene comes from (shown in messages).
pub const SHOWCASE_NAME: &str = "scenes/showcase.nff";

/// The text of the built-in showcase scene, compiled into the binary from
/// `scenes/showcase.nff`.
pub const SHOWCASE_SOURCE: &str = include_str!("../../scenes/showcase.nff");

/// The built-in showcase scene (`cuberay render` without a scene): mirrors, glass,
/// shadows and three lights.
pub fn showcase() -> Result<Loaded, Error> {
    nff::parse(SHOWCASE_SOURCE, Path::new(SHOWCASE_NAME))
}
