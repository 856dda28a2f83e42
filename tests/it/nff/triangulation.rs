//! Ear clipping of NFF polygons: concave, star-shaped, comb-shaped, tilted, clockwise, with
//! collinear and repeated vertices, and random star-shaped polygons; the triangles must tile
//! each polygon exactly.

use std::f64::consts::PI;

use crate::common::shared_scenes;
use glam::{DVec2, DVec3};
use proptest::prelude::*;

use super::{dropped, invalid_error, parse_ok, triangles, vector_area, VIEW};

/// NFF text of one polygon.
fn polygon_text(points: &[DVec3]) -> String {
    let mut s = format!("{VIEW}p {}\n", points.len());
    for p in points {
        s += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    s
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

}
