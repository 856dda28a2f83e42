//! glTF loader (to be written).
use std::path::Path;

use super::{LoadError, LoadOptions, Loaded};

pub fn load(path: &Path, _options: &LoadOptions) -> Result<Loaded, LoadError> {
    Err(LoadError::Invalid { path: path.to_owned(), message: "glTF loader not written yet".into() })
}
