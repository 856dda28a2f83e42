//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The third-party scenes folder (`../shared/scenes` beside the repository, or
/// `$CUBERAY_SHARED_SCENES`). Panics with a plain message when it is missing: tests that
/// need these scenes must not pass silently without them.
pub fn shared_scenes() -> PathBuf {
    if let Ok(dir) = std::env::var("CUBERAY_SHARED_SCENES") {
        let p = PathBuf::from(dir);
        assert!(p.is_dir(), "CUBERAY_SHARED_SCENES={} is not a directory", p.display());
        return p;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for dir in root.ancestors() {
        let candidate = dir.join("shared").join("scenes");
        if candidate.is_dir() && dir != root {
            return candidate;
        }
    }
    panic!(
        "the shared scenes folder is missing: expected ../shared/scenes beside {} (or set \
         CUBERAY_SHARED_SCENES). These tests read the SPD databases and glTF sample models from it.",
        root.display()
    );
}

/// A file under the shared scenes folder, which must exist.
pub fn shared(rel: &str) -> PathBuf {
    let p = shared_scenes().join(rel);
    assert!(p.exists(), "missing shared scene file {}", p.display());
    p
}

/// The cuberay binary built for these tests.
pub fn cuberay() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_cuberay"))
}
