//! The chunked parallel parse against the serial one: the same scene, the same warnings,
//! the same first error (message, file and line), for every NFF file of the repository and
//! of the shared SPD scenes, for large synthetic texts, and (through the helpers of this
//! module's parent) for every bad-input case.

use std::path::{Path, PathBuf};

use cuberay::load::nff::{parse, parse_in_chunks};

use super::{same_as_serial, VIEW};
use crate::common::shared_scenes;

/// The NFF files of a folder, sorted.
fn nff_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "nff"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_nff_file_parses_in_chunks_as_serially() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = nff_files(&shared_scenes().join("spd/nff"));
    assert!(!files.is_empty(), "no SPD files");
    files.extend(nff_files(&root.join("scenes")));
    files.extend(nff_files(&root.join("scenes/hard")));
    files.extend(nff_files(&root.join("fuzz/regressions/nff")));
    for path in &files {
        let text = std::fs::read_to_string(path).unwrap();
        // Each helper call compares several chunk sizes with the serial parse.
        let _ = same_as_serial(&text, path);
    }
}

/// A text of about `polygons` × 100 bytes: a view, lights, fills between the polygons,
/// patches, spheres, cylinders and degenerate triangles, in the order the SPD files use.
fn large_text(polygons: usize) -> String {
    let mut text = String::from("b 0.1 0.2 0.3\n");
    text += VIEW;
    text += "l 1 2 3\nl 4 5 6 0.5 0.5 0.5\n";
    for i in 0..polygons {
        let x = i as f64 * 0.001;
        if i % 5000 == 1 {
            text += &format!("f 1 {x} 0.5 0.5 0.5 {i} 0 0\n");
        }
        match i % 7 {
            0 => text += &format!("pp 3\n{x} 0 0 0 0 1\n{x} 1 0 0 0 0\n0 {x} 1 0 1 1\n"),
            1 => text += &format!("s {x} 1 2 0.{i}\n"),
            2 => text += &format!("c {x} 0 0 1 {x} 0 1 0.5\n"),
            3 => text += "p 3\n0 0 0\n1 1 1\n2 2 2\n",
            _ => text += &format!("p 4\n{x} 0 0\n1 0 0\n1 1 {x}\n0 1 0\n"),
        }
    }
    text
}

#[test]
fn large_texts_parse_in_parallel_as_serially() {
    let text = large_text(60_000);
    assert!(text.len() > 2 << 20, "large enough for the default parse to use chunks");
    let path = Path::new("large.nff");
    let serial = format!("{:?}", parse_in_chunks(&text, path, usize::MAX).unwrap());
    assert_eq!(format!("{:?}", parse(&text, path).unwrap()), serial);
    for chunk_bytes in [1, 1000, 100_000] {
        assert_eq!(format!("{:?}", parse_in_chunks(&text, path, chunk_bytes).unwrap()), serial);
    }
    // A file whose first entity is a primitive: the default material comes first.
    let text = format!("s 0 0 0 1\n{}", large_text(30_000));
    same_as_serial(&text, path).unwrap();
}

#[test]
fn large_texts_fail_in_parallel_as_serially() {
    let text = large_text(30_000);
    let line = |k: usize| text[..k].matches('\n').count() + 1;
    let path = Path::new("bad.nff");
    // A second 'v' late in the file, then an error after it: the 'v' is reported.
    let late = text.len() * 3 / 4;
    let late = late + text[late..].find("\np ").unwrap() + 1;
    let bad = format!("{}{VIEW}s 0 0 0 0\n{}", &text[..late], &text[late..]);
    let err = same_as_serial(&bad, path).unwrap_err().to_string();
    assert!(err.starts_with(&format!("bad.nff:{}: ", line(late))), "{err}");
    assert!(err.contains("second 'v'"), "{err}");
    // A truncated entity just before another chunk's error: the first error wins.
    let early = text.len() / 3;
    let early = early + text[early..].find("\ns ").unwrap() + 1;
    let bad = format!("{}s 1 2\n{}x\n", &text[..early], &text[early..]);
    let err = same_as_serial(&bad, path).unwrap_err().to_string();
    assert!(err.contains("z of the sphere centre is missing"), "{err}");
    // A file cut in the middle of a patch.
    let cut = &text[..text.len() / 2 + 7];
    same_as_serial(cut, path).unwrap_err();
}
