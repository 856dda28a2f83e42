//! glTF node transforms, on files written by the tests: normals under a non-uniform scale,
//! mirroring transforms, instancing and the node hierarchy, a matrix against TRS.

use glam::{DMat3, DMat4, DQuat, DVec3};
use serde_json::json;

use super::{close, load, load_mesh_with_node, tetrahedron, triangles, Doc, TempDir};

#[test]
fn non_uniform_scale_transforms_normals_by_the_inverse_transpose() {
    // A sloped triangle whose vertex normals equal its face normal; after a rotation and
    // a non-uniform scale the shading normals must still equal the face normal.
    let mut doc = Doc::new();
    let p = doc.vec3(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let s = 1.0 / 3f32.sqrt();
    let n = doc.vec3(&[[s, s, s]; 3]);
    let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let node =
        json!({"scale": [2.0, 0.5, 3.0], "rotation": [q.x, q.y, q.z, q.w], "translation": [1.0, 2.0, 3.0]});
    let loaded = load_mesh_with_node(
        &doc,
        json!({"primitives": [{"attributes": {"POSITION": p, "NORMAL": n}}]}),
        node,
    );
    let tris = triangles(&loaded.scene);
    assert_eq!(tris.len(), 1);
    let t = tris[0];
    let m = DMat4::from_scale_rotation_translation(DVec3::new(2.0, 0.5, 3.0), q, DVec3::new(1.0, 2.0, 3.0));
    for (got, orig) in t.p.iter().zip([DVec3::X, DVec3::Y, DVec3::Z]) {
        assert!(close(*got, m.transform_point3(orig), 1e-6), "{got} vs {}", m.transform_point3(orig));
    }
    let face = t.cross().normalize();
    for n in t.n.unwrap() {
        assert!(close(n, face, 1e-6), "shading normal {n} vs face normal {face}");
    }
    // A plain linear map of the normal would differ: the test can tell the two apart.
    let naive = (DMat3::from_mat4(m) * DVec3::splat(1.0)).normalize();
    assert!(!close(naive, face, 1e-3));
}

#[test]
fn mirroring_transforms_flip_the_winding() {
    // Negative determinant by TRS scale, by matrix, and by a mirrored parent; every face
    // of the tetrahedron must still have its geometric normal pointing outwards and
    // agreeing with its shading normals.
    let mut doc = Doc::new();
    let mesh = tetrahedron(&mut doc);
    let mirror = [-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 5.0, 0.0, 0.0, 1.0];
    let cases = [
        json!({"scale": [1.0, 1.0, 1.0]}),
        json!({"scale": [-1.0, 2.0, 1.0], "translation": [0.0, 0.0, 4.0]}),
        json!({"matrix": mirror}),
        json!({"scale": [-1.0, -1.0, -1.0]}),
    ];
    for node in cases {
        let loaded = load_mesh_with_node(&doc, mesh.clone(), node.clone());
        let tris = triangles(&loaded.scene);
        assert_eq!(tris.len(), 4);
        let centre = tris.iter().map(|t| t.p[0] + t.p[1] + t.p[2]).sum::<DVec3>() / 12.0;
        for t in &tris {
            let g = t.cross().normalize();
            let face_centre = (t.p[0] + t.p[1] + t.p[2]) / 3.0;
            assert!(g.dot(face_centre - centre) > 0.0, "{node}: face normal {g} points inwards");
            for n in t.n.unwrap() {
                assert!(close(n, g, 1e-6), "{node}: shading normal {n} vs geometric {g}");
            }
        }
    }
}

#[test]
fn instancing_and_hierarchy() {
    // One mesh used by three nodes: two children of a rotated, translated parent and one
    // root. Each instance gives its own triangles, in traversal order.
    let mut doc = Doc::new();
    let mesh = tetrahedron(&mut doc);
    let q = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
    let dir = TempDir::new();
    let path = doc.write(
        &dir,
        "inst.gltf",
        json!({
            "meshes": [mesh],
            "nodes": [
                {"children": [1, 2], "rotation": [q.x, q.y, q.z, q.w], "translation": [0.0, 10.0, 0.0]},
                {"mesh": 0, "translation": [1.0, 0.0, 0.0]},
                {"mesh": 0, "translation": [0.0, 0.0, 2.0]},
                {"mesh": 0},
            ],
            "scenes": [{"nodes": [0, 3]}],
        }),
    );
    let scene = load(&path).scene;
    let tris = triangles(&scene);
    assert_eq!(tris.len(), 12);
    let parent = DMat4::from_rotation_translation(q, DVec3::new(0.0, 10.0, 0.0));
    let worlds = [
        parent * DMat4::from_translation(DVec3::X),
        parent * DMat4::from_translation(DVec3::new(0.0, 0.0, 2.0)),
        DMat4::IDENTITY,
    ];
    let local = triangles(&scene)[8..12].iter().map(|t| t.p).collect::<Vec<_>>();
    for (k, world) in worlds.iter().enumerate() {
        for (t, l) in tris[4 * k..4 * k + 4].iter().zip(&local) {
            for (p, lp) in t.p.iter().zip(l) {
                assert!(close(*p, world.transform_point3(*lp), 1e-9), "instance {k}: {p}");
            }
        }
    }
    // The default scene is scene 0 even without a "scene" property.
    assert_eq!(scene.materials.len(), 1);
}

#[test]
fn matrix_and_trs_give_the_same_triangles() {
    let mut doc = Doc::new();
    let mesh = tetrahedron(&mut doc);
    let q = DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.4, 1.1);
    let (s, t) = (DVec3::new(1.5, 0.5, 2.0), DVec3::new(-1.0, 2.0, 0.5));
    let m = DMat4::from_scale_rotation_translation(s, q, t);
    let trs = load_mesh_with_node(
        &doc,
        mesh.clone(),
        json!({"scale": s.to_array(), "rotation": [q.x, q.y, q.z, q.w], "translation": t.to_array()}),
    );
    let mat = load_mesh_with_node(&doc, mesh, json!({"matrix": m.to_cols_array()}));
    for (a, b) in triangles(&trs.scene).iter().zip(triangles(&mat.scene)) {
        for k in 0..3 {
            assert!(close(a.p[k], b.p[k], 1e-6));
        }
    }
}
