//! The fuzz campaigns' findings replayed on stable: every input under `fuzz/regressions/`
//! (one folder per reader) once crashed, hung or panicked a reader and must now be read or
//! refused cleanly, through the harness the fuzz targets use (`fuzz/harness.rs`). The
//! seeds of `fuzz/seeds/` must be accepted, so that the targets start from inputs that reach
//! past the first checks. docs/fuzzing.md says how to run a campaign.

#[path = "../../fuzz/harness.rs"]
#[allow(dead_code)]
mod harness;

use std::path::{Path, PathBuf};

use harness::Reader;

fn files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut v: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    v.sort();
    v
}

fn fuzz_dir(part: &str, reader: Reader) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz").join(part).join(reader.name())
}

#[test]
fn the_seeds_are_accepted() {
    let mut n = 0;
    for reader in Reader::ALL.into_iter().filter(|&r| r != Reader::Nff) {
        let seeds = files(&fuzz_dir("seeds", reader));
        assert!(!seeds.is_empty(), "no seeds for the {} target", reader.name());
        for seed in seeds {
            let bytes = std::fs::read(&seed).unwrap();
            if let Err(e) = harness::run(reader, &bytes) {
                panic!("the seed {} is refused: {e}", seed.display());
            }
            n += 1;
        }
    }
    // The NFF target's seeds are the repository's own scenes.
    for scene in files(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")) {
        if scene.extension().is_some_and(|e| e == "nff") {
            let bytes = std::fs::read(&scene).unwrap();
            harness::run(Reader::Nff, &bytes).unwrap_or_else(|e| panic!("{}: {e}", scene.display()));
            n += 1;
        }
    }
    eprintln!("{n} seeds accepted");
}

#[test]
fn what_the_campaigns_found_is_refused_without_a_panic() {
    let mut n = 0;
    for reader in Reader::ALL {
        for input in files(&fuzz_dir("regressions", reader)) {
            let bytes = std::fs::read(&input).unwrap();
            let answer = harness::run(reader, &bytes);
            eprintln!("{}: {}", input.display(), answer.err().unwrap_or_else(|| "read".into()));
            n += 1;
        }
    }
    assert!(n > 0, "fuzz/regressions/ holds no inputs");
}
