//! NFF bad input: each error names the line (and token) and says what is wrong; token soup
//! never panics.

use std::path::Path;

use cuberay::Error;
use proptest::prelude::*;

use super::{invalid_error, nff_error, same_as_serial, VIEW};

#[test]
fn unknown_keyword() {
    let token = nff_error(&format!("{VIEW}s 0 0 0 1\nsphere 0 0 0 1\n"), 5, &["unknown keyword"]);
    assert_eq!(token.as_deref(), Some("sphere"));
    let token = nff_error(&format!("{VIEW}V\n"), 4, &["unknown keyword"]);
    assert_eq!(token.as_deref(), Some("V"), "keywords are lower case");
}

#[test]
fn truncated_entities() {
    nff_error(&format!("{VIEW}s 0 0 0"), 4, &["file ends inside", "sphere radius", "'s'"]);
    nff_error(
        &format!("{VIEW}s 0 0 0 1\nc 0 0 0 1\n0 0 1"),
        5,
        &["file ends inside", "cylinder apex radius"],
    );
    nff_error(&format!("{VIEW}p 4\n0 0 0\n1 0 0\n1 1 0\n"), 4, &["file ends inside", "x of vertex 4 of 4"]);
    nff_error(
        &format!("{VIEW}pp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0"),
        4,
        &["file ends inside", "z of normal 3 of 3"],
    );
    nff_error(&format!("{VIEW}f 1 1 1 1 0"), 4, &["file ends inside", "Phong exponent"]);
    nff_error(&format!("{VIEW}l 1 2"), 4, &["file ends inside", "z of the light position"]);
    nff_error(&format!("{VIEW}l 1 2 3 1 1"), 4, &["file ends inside", "blue of the light colour"]);
    nff_error("b 0 0", 1, &["file ends inside", "blue of the background colour"]);
    nff_error("v from 0 0 1 at 0 0 0 up 0 1 0 angle", 1, &["file ends inside", "field of view angle"]);
    nff_error(&format!("{VIEW}p"), 4, &["file ends inside", "vertex count"]);
    // Truncated in the middle of the file: the next entity's keyword shows up too early.
    let token = nff_error(
        &format!("{VIEW}c 0 0 0 1 0 0 2\ns 0 0 0 1\n"),
        5,
        &["cylinder apex radius is missing", "line 4"],
    );
    assert_eq!(token.as_deref(), Some("s"));
}

#[test]
fn non_numeric_tokens() {
    let token = nff_error(&format!("{VIEW}s 0 0 zero 1\n"), 4, &["z of the sphere centre must be a number"]);
    assert_eq!(token.as_deref(), Some("zero"));
    nff_error(
        &format!("{VIEW}s 0 0 0 1\nf 1 1 1 0.5 0.5 x3 0 1\n"),
        5,
        &["Phong exponent", "must be a number"],
    );
    nff_error(&format!("{VIEW}p 3\n0 0 0\n1 0,5 0\n0 1 0\n"), 6, &["y of vertex 2 of 3"]);
    nff_error(
        "b 0.1 0.2 0.3\nv\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 45deg\n",
        6,
        &["field of view angle", "number"],
    );
    nff_error(&format!("{VIEW}l 1 2 3 1 one 1\n"), 4, &["green of the light colour"]);
}

#[test]
fn nan_and_infinite_numbers() {
    for bad in ["nan", "NaN", "inf", "-inf", "infinity", "1e400", "-1e999"] {
        let token =
            nff_error(&format!("{VIEW}s 0 0 0 1\ns 0 {bad} 0 1\n"), 5, &["y of the sphere centre", "finite"]);
        assert_eq!(token.as_deref(), Some(bad));
    }
    nff_error(&format!("{VIEW}l 0 0 5 1 nan 1\n"), 4, &["green of the light colour", "finite"]);
    nff_error(&format!("{VIEW}f 1 1 1 inf 0 1 0 1\n"), 4, &["diffuse weight", "finite"]);
    nff_error("v from 0 0 1 at 0 0 0 up 0 1 0 angle nan", 1, &["angle", "finite"]);
}

#[test]
fn zero_sphere_radius() {
    nff_error(&format!("{VIEW}s 0 0 0 1\ns 1 1 1 0\n"), 5, &["sphere radius is zero"]);
    nff_error(&format!("{VIEW}s 1 1 1 -0.0\n"), 4, &["sphere radius is zero"]);
}

#[test]
fn bad_cylinders() {
    nff_error(&format!("{VIEW}c 1 2 3 1 1 2 3 1\n"), 4, &["base and apex coincide"]);
    nff_error(&format!("{VIEW}c\n1 2 3 1\n1 2 3 0.5\n"), 6, &["base and apex coincide"]);
    nff_error(&format!("{VIEW}c 0 0 0 0 0 0 1 0\n"), 4, &["both cylinder radii are zero"]);
    nff_error(&format!("{VIEW}c 0 0 0 -1 0 0 1 1\n"), 4, &["opposite signs"]);
}

#[test]
fn polygon_with_too_few_vertices() {
    for n in [0, 1, 2] {
        let mut text = format!("{VIEW}p {n}\n");
        for _ in 0..n {
            text += "0 0 0\n";
        }
        let token = nff_error(&text, 4, &["at least 3 vertices", &format!("has {n}")]);
        assert_eq!(token, Some(n.to_string()));
    }
    nff_error(&format!("{VIEW}pp 2\n0 0 0 0 0 1\n1 0 0 0 0 1\n"), 4, &["at least 3 vertices", "'pp'"]);
}

#[test]
fn bad_vertex_counts() {
    for bad in ["3.0", "-3", "three", "1e1", "99999999999999999999999"] {
        let token = nff_error(
            &format!("{VIEW}p {bad}\n0 0 0\n1 0 0\n0 1 0\n"),
            4,
            &["vertex count must be a whole number"],
        );
        assert_eq!(token.as_deref(), Some(bad));
    }
    // A count larger than the vertices given: the next entity arrives too early.
    nff_error(
        &format!("{VIEW}p 4\n0 0 0\n1 0 0\n0 1 0\ns 0 0 0 1\n"),
        8,
        &["x of vertex 4 of 4 is missing", "line 4"],
    );
    // A count smaller than the vertices given: a vertex is left where an entity should be.
    nff_error(
        &format!("{VIEW}p 3\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"),
        8,
        &["a number where an entity keyword should start"],
    );
    // A huge count with few vertices must not allocate for the claimed count.
    nff_error(
        &format!("{VIEW}pp 4000000000000\n0 0 0 0 0 1\n"),
        4,
        &["file ends inside", "x of vertex 2 of 4000000000000"],
    );
}

#[test]
fn bad_views() {
    nff_error("v\nfrom 0 0 1\nat 0 0 1\nup 0 1 0\nangle 45\ns 0 0 0 1", 1, &["impossible view", "coincide"]);
    nff_error("v\nfrom 0 0 1\nat 0 0 0\nup 0 0 1\nangle 45\ns 0 0 0 1", 1, &["impossible view", "parallel"]);
    nff_error("v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 180\ns 0 0 0 1", 5, &["between 0 and 180"]);
    nff_error("v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 0\ns 0 0 0 1", 5, &["between 0 and 180"]);
    nff_error("v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\ns 0 0 0 1", 1, &["lacks 'angle'"]);
    nff_error("v\nangle 30\ns 0 0 0 1", 1, &["lacks 'from', 'at', 'up'"]);
    nff_error(
        "v\nfrom 0 0 1\nfrom 0 0 2\nat 0 0 0\nup 0 1 0\nangle 45\ns 0 0 0 1",
        3,
        &["'from' is given twice"],
    );
    nff_error(&format!("{VIEW}hither -1\n"), 4, &["hither distance -1 is negative"]);
    nff_error(&format!("{VIEW}resolution 0 100\n"), 4, &["resolution width must be between 1"]);
    nff_error(&format!("{VIEW}resolution 512 512.5\n"), 4, &["resolution height must be a whole number"]);
    nff_error(&format!("{VIEW}s 0 0 0 1\n{VIEW}"), 5, &["second 'v'", "line 1"]);
    // A view keyword outside a 'v' is not an entity.
    let token = nff_error(&format!("{VIEW}s 0 0 0 1\nfrom 1 2 3\n"), 5, &["unknown keyword"]);
    assert_eq!(token.as_deref(), Some("from"));
}

#[test]
fn transmitting_fill_needs_a_positive_ior() {
    nff_error(
        &format!("{VIEW}f 1 1 1 0.1 0.1 100 0.9 0\n"),
        4,
        &["index of refraction", "transmitting", "positive"],
    );
}

#[test]
fn missing_view_and_empty_scenes() {
    invalid_error("s 0 0 0 1\n", &["no 'v'"]);
    invalid_error("", &["no 'v'"]);
    invalid_error("# only a comment\n", &["no 'v'"]);
    invalid_error(&format!("{VIEW}l 1 1 1\nf 1 1 1 1 0 1 0 1\n"), &["no primitives"]);
}

#[test]
fn load_reads_files_and_reports_io_and_encoding_errors() {
    let dir = std::env::temp_dir().join(format!("cuberay-nff-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("good.nff");
    std::fs::write(&good, format!("{VIEW}s 0 0 0 1\n")).unwrap();
    let loaded = cuberay::load::load(&good, &Default::default()).expect("loads through the dispatcher");
    assert_eq!(loaded.scene.counts().spheres, 1);

    let binary = dir.join("binary.nff");
    std::fs::write(&binary, b"v\nfrom 0 0 1\n\xff\xfe\n").unwrap();
    match cuberay::load::nff::load(&binary) {
        Err(Error::Nff { line, message, .. }) => {
            assert_eq!(line, 3);
            assert!(message.contains("UTF-8"), "{message}");
        }
        other => panic!("expected an encoding error, got {other:?}"),
    }
    let missing = dir.join("missing.nff");
    match cuberay::load::nff::load(&missing) {
        Err(e @ Error::Io { .. }) => assert!(e.to_string().contains("missing.nff"), "{e}"),
        other => panic!("expected an I/O error, got {other:?}"),
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Whatever the tokens, the parser returns a scene or an error, never panics, and a
    /// scene it returns is valid.
    #[test]
    fn arbitrary_token_soup_never_panics(words in prop::collection::vec(prop::sample::select(vec![
        "v", "from", "at", "up", "angle", "hither", "resolution", "b", "l", "f", "c", "s", "p", "pp",
        "#", "\n", "\n", "0", "1", "-1", "2.5", "3", "4", "144", "45", "nan", "inf", "1e400", "-0",
        "x", "1e-320", "1e300", "-1e300", "99999999999999999999",
    ]), 0..80)) {
        let text = format!("{VIEW}{}", words.join(" "));
        if let Ok(loaded) = same_as_serial(&text, Path::new("soup.nff")) {
            prop_assert!(loaded.scene.validate().is_ok());
        }
        let _ = same_as_serial(&words.join(" "), Path::new("soup.nff"));
    }
}
