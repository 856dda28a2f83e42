//! Tests of the NFF loader: every entity, every kind of bad input (each error must name the
//! line and say what is wrong), ear clipping of concave polygons, and every SPD file of the
//! shared scenes (counts checked against an independent scan of the file).

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use crate::common::shared_scenes;
use cuberay::load::nff::parse;
use cuberay::load::Loaded;
use cuberay::scene::{FovSpan, LightSource, Material, Primitive, Projection, Triangle};
use cuberay::Error;
use glam::{DVec2, DVec3};
use proptest::prelude::*;

// ---------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------

/// A view that every small test scene starts with (3 lines).
const VIEW: &str = "v\nfrom 0 0 10 at 0 0 0 up 0 1 0\nangle 45\n";

fn parse_ok(text: &str) -> Loaded {
    match parse(text, Path::new("test.nff")) {
        Ok(loaded) => loaded,
        Err(e) => panic!("expected the scene to load, got: {e}\n--- input ---\n{text}"),
    }
}

/// Parses `text`, expects an NFF error on `line` whose message contains every one of
/// `words`, and returns the offending token.
#[track_caller]
fn nff_error(text: &str, line: usize, words: &[&str]) -> Option<String> {
    match parse(text, Path::new("bad.nff")) {
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
    match parse(text, Path::new("bad.nff")) {
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

/// NFF text of one polygon.
fn polygon_text(points: &[DVec3]) -> String {
    let mut s = format!("{VIEW}p {}\n", points.len());
    for p in points {
        s += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    s
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

/// Even-odd point-in-polygon test in 2D.
fn inside_polygon(p: DVec2, poly: &[DVec2]) -> bool {
    let mut inside = false;
    let mut j = poly.len() - 1;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[j]);
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
        j = i;
    }
    inside
}

fn inside_triangle(p: DVec2, t: [DVec2; 3]) -> bool {
    let d = [
        (t[1] - t[0]).perp_dot(p - t[0]),
        (t[2] - t[1]).perp_dot(p - t[1]),
        (t[0] - t[2]).perp_dot(p - t[2]),
    ];
    d.iter().all(|x| *x > 0.0) || d.iter().all(|x| *x < 0.0)
}

/// Triangulates a planar polygon through the loader and checks that the triangles tile it
/// exactly: their areas add up to the polygon's, they keep its orientation, and every
/// sample point of its plane lies in exactly one triangle when inside the polygon and in
/// none when outside. Returns the number of triangles kept.
#[track_caller]
fn check_tiling(points: &[DVec3], samples_per_axis: usize) -> usize {
    let loaded = parse_ok(&polygon_text(points));
    let tris = triangles(&loaded);
    assert_eq!(
        tris.len() + dropped(&loaded),
        points.len() - 2,
        "a polygon of n vertices gives n - 2 triangles"
    );

    let area = vector_area(points);
    let tri_area: f64 = tris.iter().map(|t| t.cross().length() * 0.5).sum();
    assert!(
        (tri_area - area.length()).abs() <= 1e-9 * area.length(),
        "triangle areas {tri_area} != polygon area {}",
        area.length()
    );
    for t in &tris {
        assert!(t.cross().dot(area) > 0.0, "a triangle is wound against the polygon");
    }

    // Project onto the plane through an orthonormal basis and sample a grid.
    let n = area.normalize();
    let e1 = n.any_orthonormal_vector();
    let e2 = n.cross(e1);
    let flat = |p: DVec3| DVec2::new(p.dot(e1), p.dot(e2));
    let poly: Vec<DVec2> = points.iter().map(|p| flat(*p)).collect();
    let tri2: Vec<[DVec2; 3]> = tris.iter().map(|t| t.p.map(flat)).collect();
    let (lo, hi) =
        poly.iter().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let step = (hi - lo) / samples_per_axis as f64;
    for i in 0..samples_per_axis {
        for j in 0..samples_per_axis {
            // Odd offsets keep the samples off the (rational) edges of the test polygons.
            let p = lo + step * DVec2::new(i as f64 + 0.5137, j as f64 + 0.4771);
            let hits = tri2.iter().filter(|t| inside_triangle(p, **t)).count();
            let expected = usize::from(inside_polygon(p, &poly));
            assert_eq!(hits, expected, "sample {p} is in {hits} triangles, expected {expected}");
        }
    }
    tris.len()
}

fn plane_points(points2: &[(f64, f64)], origin: DVec3, e1: DVec3, e2: DVec3) -> Vec<DVec3> {
    points2.iter().map(|&(x, y)| origin + e1 * x + e2 * y).collect()
}

fn xy(points2: &[(f64, f64)]) -> Vec<DVec3> {
    plane_points(points2, DVec3::ZERO, DVec3::X, DVec3::Y)
}

fn star(tips: usize, outer: f64, inner: f64) -> Vec<(f64, f64)> {
    (0..2 * tips)
        .map(|k| {
            let a = PI * k as f64 / tips as f64;
            let r = if k % 2 == 0 { outer } else { inner };
            (r * a.cos(), r * a.sin())
        })
        .collect()
}

fn spd_files() -> Vec<PathBuf> {
    let dir = shared_scenes().join("spd/nff");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "nff"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no .nff files in {}", dir.display());
    files
}

/// What a plain scan of an NFF file finds, independently of the loader.
#[derive(Debug, Default)]
struct Scan {
    spheres: usize,
    cylinders: usize,
    polygons: usize,
    patches: usize,
    lights: usize,
    fills: usize,
    /// Whether a primitive comes before the first `f`.
    primitive_before_fill: bool,
    /// Σ (n − 2) over the polygons and patches.
    triangles: usize,
    /// Σ of the polygons' vector areas and of their areas.
    vector_area: DVec3,
    area: f64,
}

fn scan(text: &str) -> Scan {
    let tokens: Vec<&str> =
        text.lines().flat_map(|l| l.split('#').next().unwrap().split_whitespace()).collect();
    let mut s = Scan::default();
    let mut i = 0;
    while i < tokens.len() {
        // Numbers are never keywords, so counting keyword tokens counts the entities.
        match tokens[i] {
            "s" | "c" | "p" | "pp" => s.primitive_before_fill |= s.fills == 0,
            _ => {}
        }
        match tokens[i] {
            "s" => s.spheres += 1,
            "c" => s.cylinders += 1,
            "l" => s.lights += 1,
            "f" => s.fills += 1,
            "p" | "pp" => {
                let per_vertex = if tokens[i] == "p" { 3 } else { 6 };
                if tokens[i] == "p" {
                    s.polygons += 1
                } else {
                    s.patches += 1
                }
                let n: usize = tokens[i + 1].parse().unwrap();
                s.triangles += n - 2;
                let num = |k: usize| -> f64 { tokens[k].parse().unwrap() };
                let points: Vec<DVec3> = (0..n)
                    .map(|v| {
                        let k = i + 2 + v * per_vertex;
                        DVec3::new(num(k), num(k + 1), num(k + 2))
                    })
                    .collect();
                let a = vector_area(&points);
                s.vector_area += a;
                s.area += a.length();
                i += 1 + n * per_vertex;
            }
            _ => {}
        }
        i += 1;
    }
    s
}

// ---------------------------------------------------------------------------------------
// Entities
// ---------------------------------------------------------------------------------------

#[test]
fn view_background_and_resolution() {
    let loaded = parse_ok(
        "b 0.1 0.2 0.3\nv\nfrom 1 2 3\nat 1 2 -7\nup 0 1 0\nangle 60\nhither 0.5\nresolution 320 200\ns 0 0 0 1\n",
    );
    let scene = &loaded.scene;
    assert_eq!(scene.background, DVec3::new(0.1, 0.2, 0.3));
    assert_eq!(scene.camera.eye, DVec3::new(1.0, 2.0, 3.0));
    assert!((scene.camera.forward - DVec3::NEG_Z).length() < 1e-15);
    assert!((scene.camera.up - DVec3::Y).length() < 1e-15);
    assert_eq!(
        scene.camera.projection,
        Projection::Perspective { fov_y: PI / 3.0, span: FovSpan::EdgePixelCenters }
    );
    assert_eq!(scene.camera.near, 0.5);
    assert_eq!(scene.resolution, Some((320, 200)));
}

#[test]
fn view_without_hither_or_resolution() {
    let loaded = parse_ok(&format!("{VIEW}s 0 0 0 1"));
    assert_eq!(loaded.scene.camera.near, 0.0);
    assert_eq!(loaded.scene.resolution, None);
    assert_eq!(loaded.scene.background, DVec3::ZERO, "no 'b' means black");
}

#[test]
fn lights_share_the_spd_intensity_and_ambient() {
    let loaded = parse_ok(&format!("{VIEW}l 1 2 3\nl 4 5 6 0.5 0.25 1\nl 7 8 9\nl 0 0 1\ns 0 0 0 1"));
    let scene = &loaded.scene;
    assert_eq!(scene.lights.len(), 4);
    let expected = 4f64.sqrt() / (2.0 * 4.0);
    for l in &scene.lights {
        assert_eq!(l.source, LightSource::File);
        assert!(!l.inverse_square);
        assert!((l.intensity - expected).abs() < 1e-15);
    }
    assert_eq!(scene.lights[0].position, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(scene.lights[0].color, DVec3::ONE);
    assert_eq!(scene.lights[1].position, DVec3::new(4.0, 5.0, 6.0));
    assert_eq!(scene.lights[1].color, DVec3::new(0.5, 0.25, 1.0));
    assert_eq!(scene.lights[2].position, DVec3::new(7.0, 8.0, 9.0));
    assert!((scene.ambient - DVec3::splat(expected)).length() < 1e-15);
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
}

#[test]
fn no_light_gets_the_default_with_a_warning() {
    let loaded = parse_ok(&format!("{VIEW}s 0 0 0 1"));
    assert_eq!(loaded.scene.lights.len(), 1);
    assert_eq!(loaded.scene.lights[0].source, LightSource::Default);
    assert_eq!(loaded.scene.file_lights().count(), 0);
    assert_eq!(loaded.scene.ambient, DVec3::splat(0.5), "the ambient of a single light");
    assert!(loaded.warnings.iter().any(|w| w.contains("no light")), "{:?}", loaded.warnings);
}

#[test]
fn fill_maps_onto_the_whitted_material() {
    let loaded = parse_ok(&format!(
        "{VIEW}f 1 0.5 0.25 0.7 0.3 20 0.6 1.5\ns 0 0 0 1\nf 0.2 0.2 0.2 1 0 100000 0 0\ns 3 0 0 1"
    ));
    let m = &loaded.scene.materials;
    assert_eq!(m.len(), 2, "one material per 'f', no default when unused");
    assert_eq!(m[0].color, DVec3::new(1.0, 0.5, 0.25));
    assert_eq!((m[0].kd, m[0].ks, m[0].shine, m[0].transmittance, m[0].ior), (0.7, 0.3, 20.0, 0.6, 1.5));
    assert_eq!(m[0].mirror, DVec3::splat(0.3));
    assert_eq!(m[0].emission, DVec3::ZERO);
    assert_eq!(m[1].ior, 1.0, "opaque 'f' with ior 0 (as SPD writes) stores 1");
    assert_eq!(m[1].mirror, DVec3::ZERO);
    assert_eq!(loaded.scene.primitives[0].material(), 0);
    assert_eq!(loaded.scene.primitives[1].material(), 1);
}

#[test]
fn default_material_only_before_the_first_fill() {
    let loaded = parse_ok(&format!(
        "{VIEW}s 0 0 0 1\nf 1 0 0 1 0 1 0 1\ns 3 0 0 1\nf 0 1 0 1 0 1 0 1\nf 0 0 1 1 0 1 0 1\n"
    ));
    let scene = &loaded.scene;
    assert_eq!(scene.materials.len(), 4);
    assert_eq!(scene.materials[0], Material::default());
    assert_eq!(scene.primitives[0].material(), 0);
    assert_eq!(scene.primitives[1].material(), 1);
    assert_eq!(scene.materials[1].color, DVec3::X);
}

#[test]
fn spheres_and_negative_radius() {
    let loaded = parse_ok(&format!("{VIEW}s 1 2 3 0.5\ns 0 0 0 -2"));
    let Primitive::Sphere(a) = &loaded.scene.primitives[0] else { panic!() };
    let Primitive::Sphere(b) = &loaded.scene.primitives[1] else { panic!() };
    assert_eq!((a.center, a.radius, a.inside_only), (DVec3::new(1.0, 2.0, 3.0), 0.5, false));
    assert_eq!((b.radius, b.inside_only), (2.0, true));
}

#[test]
fn cylinders_cones_and_their_layouts() {
    // The spec's three-line layout and the generators' one-line layout read the same.
    let three = parse_ok(&format!("{VIEW}c\n0 0 0 1\n0 0 2 0.5\n"));
    let one = parse_ok(&format!("{VIEW}c 0 0 0 1 0 0 2 0.5\n"));
    assert_eq!(three.scene.primitives, one.scene.primitives);
    let Primitive::Cylinder(c) = &one.scene.primitives[0] else { panic!() };
    assert_eq!(
        (c.base, c.base_radius, c.apex, c.apex_radius),
        (DVec3::ZERO, 1.0, DVec3::new(0.0, 0.0, 2.0), 0.5)
    );
    assert!(!c.inside_only);

    let loaded = parse_ok(&format!("{VIEW}c 0 0 0 -1 0 0 2 -1\nc 0 0 0 1 0 0 1 0\nc 0 0 0 -1 0 0 1 0"));
    let cyl: Vec<_> = loaded
        .scene
        .primitives
        .iter()
        .map(|p| if let Primitive::Cylinder(c) = p { c.clone() } else { panic!() })
        .collect();
    assert!(cyl[0].inside_only && cyl[0].base_radius == 1.0 && cyl[0].apex_radius == 1.0);
    assert!(!cyl[1].inside_only && cyl[1].apex_radius == 0.0, "a cone may end in a point");
    assert!(cyl[2].inside_only);
}

#[test]
fn comments_and_line_endings() {
    let text = format!(
        "# a scene\r\n{}s 0 0 0 1 # trailing comment\r\ns 2 0 0 1#glued\r\n# s 9 9 9 9\r\n",
        VIEW.replace('\n', "\r\n")
    );
    let loaded = parse_ok(&text);
    assert_eq!(loaded.scene.counts().spheres, 2);
    // Line numbers still count from 1 with comments and CRLF.
    nff_error(&format!("{text}s 0 0 0 zero\r\n"), 8, &["sphere radius"]);
}

#[test]
fn patches_keep_their_normals() {
    let n0 = DVec3::new(0.0, 0.0, 2.0);
    let n1 = DVec3::new(0.6, 0.0, 0.8);
    let n2 = DVec3::new(0.0, -3.0, 4.0);
    let loaded = parse_ok(&format!(
        "{VIEW}pp 3\n0 0 0 {} {} {}\n1 0 0 {} {} {}\n0 1 0 {} {} {}\n",
        n0.x, n0.y, n0.z, n1.x, n1.y, n1.z, n2.x, n2.y, n2.z
    ));
    let t = triangles(&loaded)[0];
    let n = t.n.expect("pp keeps its normals");
    for (got, want) in n.iter().zip([n0, n1, n2]) {
        assert!((*got - want.normalize()).length() < 1e-15, "{got} != {want} normalised");
    }
    assert!(loaded.warnings.iter().all(|w| !w.contains("normal")));
    // A plain polygon has no shading normals.
    assert!(triangles(&parse_ok(&format!("{VIEW}p 3 0 0 0 1 0 0 0 1 0")))[0].n.is_none());
}

#[test]
fn patch_normals_follow_the_polygon_through_triangulation() {
    // A concave patch (an L) whose normals encode the vertex index: each triangle corner
    // must carry the normal given with its position.
    let outline = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)];
    let normal_of = |x: f64, y: f64| DVec3::new(x - 1.0, y - 1.0, 3.0).normalize();
    let mut text = format!("{VIEW}pp {}\n", outline.len());
    for (x, y) in outline {
        let n = normal_of(x, y);
        text += &format!("{x} {y} 0 {} {} {}\n", n.x, n.y, n.z);
    }
    let loaded = parse_ok(&text);
    let tris = triangles(&loaded);
    assert_eq!(tris.len(), 4);
    for t in tris {
        for (p, n) in t.p.iter().zip(t.n.unwrap()) {
            assert!((n - normal_of(p.x, p.y)).length() < 1e-12);
        }
    }
}

#[test]
fn zero_patch_normal_becomes_the_geometric_normal() {
    let loaded = parse_ok(&format!("{VIEW}pp 3\n0 0 0 0 0 0\n1 0 0 0 0 1\n0 1 0 0 0 1\n"));
    let n = triangles(&loaded)[0].n.unwrap();
    assert_eq!(n[0], DVec3::Z);
    assert!(
        loaded.warnings.iter().any(|w| w.contains("normal") && w.contains("line 4")),
        "{:?}",
        loaded.warnings
    );
}

// ---------------------------------------------------------------------------------------
// Triangulation
// ---------------------------------------------------------------------------------------

#[test]
fn l_shape_is_tiled() {
    // A fan from vertex 0 would be right here by luck; from vertex 3 (the reflex corner)
    // ear clipping must still avoid the outside.
    let l = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)];
    assert_eq!(check_tiling(&xy(&l), 40), 4);
    let mut rotated = l.to_vec();
    rotated.rotate_left(4);
    assert_eq!(check_tiling(&xy(&rotated), 40), 4);
}

#[test]
fn star_is_tiled() {
    assert_eq!(check_tiling(&xy(&star(5, 1.0, 0.38)), 60), 8);
}

#[test]
fn comb_where_a_fan_fails_is_tiled() {
    // A comb with its first vertex at a tooth tip: the fan from it crosses the gaps.
    let mut comb = vec![(0.0, 3.0), (0.0, 0.0), (9.0, 0.0), (9.0, 3.0)];
    for tooth in (0..4).rev() {
        let x = 2.0 * tooth as f64 + 1.0;
        comb.extend([(x + 1.0, 3.0), (x + 1.0, 1.0), (x, 1.0), (x, 3.0)]);
    }
    comb.pop();
    check_tiling(&xy(&comb), 60);
}

#[test]
fn tilted_and_clockwise_polygons_are_tiled() {
    let e1 = DVec3::new(1.0, 2.0, 3.0).normalize().any_orthonormal_vector();
    let e2 = DVec3::new(1.0, 2.0, 3.0).normalize().cross(e1);
    let s = star(7, 2.0, 0.7);
    check_tiling(&plane_points(&s, DVec3::new(5.0, -3.0, 1.0), e1, e2), 60);
    // Clockwise seen from +z (the dominant axis negative): triangles keep that winding.
    let mut cw = s.clone();
    cw.reverse();
    check_tiling(&plane_points(&cw, DVec3::ZERO, e2, DVec3::new(0.1, 0.2, -1.0).normalize()), 60);
}

#[test]
fn collinear_and_repeated_vertices() {
    // A unit square with points on its edges, a repeated vertex and a closing duplicate.
    let square = [
        (0.0, 0.0),
        (0.5, 0.0),
        (1.0, 0.0),
        (1.0, 0.0),
        (1.0, 0.25),
        (1.0, 1.0),
        (0.0, 1.0),
        (0.0, 0.5),
        (0.0, 0.0),
    ];
    let loaded = parse_ok(&polygon_text(&xy(&square)));
    // The two repeated vertices give triangles without area; the points on the edges may
    // be kept as triangle corners (no T-junctions), so at least 2 triangles remain.
    let tris = triangles(&loaded);
    assert!(dropped(&loaded) >= 2, "{:?}", loaded.warnings);
    assert!(tris.len() >= 2);
    assert_eq!(tris.len() + dropped(&loaded), square.len() - 2);
    assert!(
        loaded.warnings[0].contains("line 4"),
        "the warning names the polygon's line: {:?}",
        loaded.warnings
    );
    check_tiling(&xy(&square), 30);
    // Collinear vertices on a concave outline.
    let l = [
        (0.0, 0.0),
        (1.0, 0.0),
        (2.0, 0.0),
        (2.0, 1.0),
        (1.5, 1.0),
        (1.0, 1.0),
        (1.0, 2.0),
        (0.0, 2.0),
        (0.0, 1.0),
    ];
    check_tiling(&xy(&l), 40);
}

#[test]
fn gear_face_is_tiled() {
    // The first 144-vertex face of gears_s1.
    let text = std::fs::read_to_string(shared_scenes().join("spd/nff/gears_s1.nff")).unwrap();
    let tokens: Vec<&str> = text.split_whitespace().collect();
    let start = tokens.windows(2).position(|w| w == ["p", "144"]).expect("gears_s1 has a 144-vertex face");
    let num = |k: usize| -> f64 { tokens[k].parse().unwrap() };
    let face: Vec<DVec3> = (0..144)
        .map(|v| {
            let k = start + 2 + 3 * v;
            DVec3::new(num(k), num(k + 1), num(k + 2))
        })
        .collect();
    assert_eq!(check_tiling(&face, 150), 142);
}

#[test]
fn degenerate_polygons_are_dropped() {
    let loaded = parse_ok(&format!("{VIEW}p 3 0 0 0 1 1 1 2 2 2\np 4 0 0 0 0 0 0 0 0 0 0 0 0\ns 0 0 0 1"));
    assert_eq!(loaded.scene.counts().triangles, 0);
    assert_eq!(dropped(&loaded), 3);
    assert_eq!(loaded.scene.materials.len(), 1, "the dropped polygons use no material");
    invalid_error(&format!("{VIEW}p 3 0 0 0 1 1 1 2 2 2"), &["no primitives", "degenerate"]);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random star-shaped (hence simple, often very concave) polygons in random planes.
    #[test]
    fn random_star_shaped_polygons_are_tiled(
        radii in prop::collection::vec(0.05f64..1.0, 3..40),
        jitter in prop::collection::vec(0.0f64..0.9, 40),
        normal in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0).prop_filter("non-zero", |n| n.0.abs() + n.1.abs() + n.2.abs() > 0.1),
    ) {
        let n = radii.len();
        let outline: Vec<(f64, f64)> = radii.iter().enumerate().map(|(k, r)| {
            let a = 2.0 * PI * (k as f64 + jitter[k]) / n as f64;
            (r * a.cos(), r * a.sin())
        }).collect();
        let axis = DVec3::new(normal.0, normal.1, normal.2).normalize();
        let e1 = axis.any_orthonormal_vector();
        let points = plane_points(&outline, DVec3::new(0.3, -2.0, 1.0), e1, axis.cross(e1));
        check_tiling(&points, 40);
    }

    /// Whatever the tokens, the parser returns a scene or an error, never panics, and a
    /// scene it returns is valid.
    #[test]
    fn arbitrary_token_soup_never_panics(words in prop::collection::vec(prop::sample::select(vec![
        "v", "from", "at", "up", "angle", "hither", "resolution", "b", "l", "f", "c", "s", "p", "pp",
        "#", "\n", "\n", "0", "1", "-1", "2.5", "3", "4", "144", "45", "nan", "inf", "1e400", "-0",
        "x", "1e-320", "1e300", "-1e300", "99999999999999999999",
    ]), 0..80)) {
        let text = format!("{VIEW}{}", words.join(" "));
        if let Ok(loaded) = parse(&text, Path::new("soup.nff")) {
            prop_assert!(loaded.scene.validate().is_ok());
        }
        let _ = parse(&words.join(" "), Path::new("soup.nff"));
    }
}

// ---------------------------------------------------------------------------------------
// Bad input: each error names the line (and token) and says what is wrong
// ---------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------
// The SPD databases
// ---------------------------------------------------------------------------------------

#[test]
fn every_spd_file_loads_with_the_files_counts() {
    for path in spd_files() {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&path).unwrap();
        let expect = scan(&text);
        let loaded = cuberay::load::nff::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        let scene = &loaded.scene;
        let counts = scene.counts();
        assert_eq!(counts.spheres, expect.spheres, "{name}: spheres");
        assert_eq!(counts.cylinders, expect.cylinders, "{name}: cylinders");
        assert_eq!(
            counts.triangles + dropped(&loaded),
            expect.triangles,
            "{name}: triangles (Σ(n-2) − dropped)"
        );
        assert_eq!(scene.file_lights().count(), expect.lights, "{name}: lights");
        assert_eq!(
            scene.materials.len(),
            expect.fills + usize::from(expect.primitive_before_fill),
            "{name}: materials"
        );
        assert!(matches!(
            scene.camera.projection,
            Projection::Perspective { span: FovSpan::EdgePixelCenters, .. }
        ));
        assert!(scene.resolution.is_some(), "{name}: every SPD file gives a resolution");

        // The triangles tile the polygons: same total area and vector area, so no triangle
        // overlaps another or leaves its polygon.
        let tris = triangles(&loaded);
        let area: f64 = tris.iter().map(|t| t.cross().length() * 0.5).sum();
        let vector: DVec3 = tris.iter().map(|t| t.cross() * 0.5).sum();
        assert!(
            (area - expect.area).abs() <= 1e-9 * expect.area.max(1e-300),
            "{name}: area {area} vs {}",
            expect.area
        );
        assert!(
            (vector - expect.vector_area).length() <= 1e-9 * expect.area.max(1e-300),
            "{name}: vector area"
        );
    }
}

#[test]
fn balls_s4_and_gears_s4_have_the_published_counts() {
    let dir = shared_scenes().join("spd/nff");
    let balls = cuberay::load::nff::load(&dir.join("balls_s4.nff")).unwrap();
    let balls_scan = scan(&std::fs::read_to_string(dir.join("balls_s4.nff")).unwrap());
    assert_eq!(balls.scene.counts().spheres, 7381);
    assert_eq!(balls_scan.polygons, 1);
    assert_eq!(balls.scene.counts().triangles, 2, "balls' one polygon is a quad");

    let gears_text = std::fs::read_to_string(dir.join("gears_s4.nff")).unwrap();
    let gears_scan = scan(&gears_text);
    assert_eq!(gears_scan.polygons, 9345);
    let gears = cuberay::load::nff::load(&dir.join("gears_s4.nff")).unwrap();
    assert_eq!(gears.scene.counts().triangles + dropped(&gears), gears_scan.triangles);
    assert_eq!(gears.scene.counts().spheres + gears.scene.counts().cylinders, 0);
}
