//! Scene files traced with every ray checked against brute force: the small SPD databases and
//! every hard-case scene.

use cuberay::coherence::{self, audit, BuildParams, OriginKey};

use super::{small_params, sweep, World};

/// A small SPD database at 24×24 corners, depth 5, every eye and shadow ray (and the rays
/// leaving surfaces, which walk the fallback origin here) checked against brute force. The
/// tables are built for the image traced: the eye's window covers only that image's frustum
/// (the corner rays of 24×24 pixels reach half a pixel past those of the SPD files' 512×512).
fn spd_every_ray_agrees_with_brute_force(name: &str) {
    let path = crate::common::shared(&format!("spd/nff/{name}.nff"));
    let scene = cuberay::load::load(&path, &Default::default()).unwrap().scene;
    let params = BuildParams {
        eye_n: Some(64),
        light_cells: 1 << 12,
        image: Some((24, 24)),
        ..BuildParams::default()
    };
    let tables = coherence::build(&scene, &params).unwrap();
    tables.flat.check(scene.primitives.len()).unwrap();
    let r = audit::trace_counts(
        &scene,
        &tables,
        audit::AuditParams { width: 24, height: 24, corners: true, max_depth: 5, verify_every: 1 },
    );
    assert_eq!(r.mismatches, 0, "{name}: {r:?}");
    assert!(r.verified >= 625, "{name}: {r:?}");
    assert_eq!(r.eye.rays, 625);
    assert_eq!(r.eye.untabled, 0, "{name}: eye rays without a table");
}

cases!(spd_every_ray_agrees_with_brute_force: super::spd_every_ray_agrees_with_brute_force {
    balls => ("balls_s1"),
    gears => ("gears_s1"),
    mount => ("mount_s1"),
    rings => ("rings_s1"),
    teapot => ("teapot_s1"),
    tetra => ("tetra_s1"),
    tree => ("tree_s1"),
});

/// Every scene of `scenes/hard/` (the hard-case suite of `tests/it/hard/`), with the default
/// build and with small tables: rays from the eye through the image and from every light in
/// every direction (nearest and any-hit) all agree with brute force.
fn hard_scene_tables_match_brute_force(file: &str) {
    let path = crate::common::hard(file);
    let s = cuberay::load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{e}")).scene;
    for params in [BuildParams::default(), small_params()] {
        let w = World::new(&s, &params);
        for j in 0..24 {
            for i in 0..24 {
                let (o, d) = s.camera.ray(i as f64 * 64.0 / 23.0, j as f64 * 64.0 / 23.0, 64, 64);
                w.check_nearest(OriginKey::Eye, w.p(o), d.as_vec3().normalize()).unwrap();
            }
        }
        for (li, l) in s.lights.iter().enumerate() {
            if w.tables.flat.cube_of(OriginKey::Light(li)).is_some() {
                sweep(&w, &s, OriginKey::Light(li), w.p(l.position), 300);
            }
        }
    }
}

cases!(hard_scene_tables_match_brute_force: super::hard_scene_tables_match_brute_force {
    grazing_sphere => ("grazing_sphere.nff"),
    parallel_triangles => ("parallel_triangles.nff"),
    shared_edges => ("shared_edges.nff"),
    self_intersection => ("self_intersection.nff"),
    offset_origin => ("offset_origin.nff"),
    offset_1e5 => ("offset_1e5.nff"),
    tiny_sphere => ("tiny_sphere.nff"),
    huge_sphere => ("huge_sphere.nff"),
    nested_bounds => ("nested_bounds.nff"),
    camera_inside => ("camera_inside.nff"),
    cell_boundaries => ("cell_boundaries.nff"),
    degenerate_triangles => ("degenerate_triangles.nff"),
    every_field => ("every_field.nff"),
    parallel_mirrors => ("parallel_mirrors.nff"),
    equal_ties => ("equal_ties.nff"),
    light_on_geometry => ("light_on_geometry.nff"),
    coplanar_triangles => ("coplanar_triangles.nff"),
    bad_normals => ("bad_normals.gltf"),
});
