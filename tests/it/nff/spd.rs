//! The SPD databases of the shared scenes: every file loads with the counts an independent
//! scan of it finds, and the largest have the published counts.

use std::path::PathBuf;

use crate::common::shared_scenes;
use cuberay::scene::{FovSpan, Projection};
use glam::DVec3;

use super::{dropped, triangles, vector_area};

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
