//! NFF loader (to be written).
use std::path::Path;

use super::{LoadError, Loaded};

pub fn load(path: &Path) -> Result<Loaded, LoadError> {
    Err(LoadError::Invalid { path: path.to_owned(), message: "NFF loader not written yet".into() })
}
