//! glTF geometry: the sample models' triangle counts, `.gltf` and `.glb` giving one scene,
//! primitive modes (strips, fans, non-indexed triangles, points), accessors (sparse ones,
//! degenerate triangles and bad normals, vertex colours) and embedded buffers.

use glam::DVec3;
use serde_json::json;

use cuberay::load::Loaded;

use super::{
    assert_error, dropped, load, load_err, load_mesh_with_node, model, tetrahedron, triangles, Doc, TempDir,
};

/// Loads a sample model and checks its triangle count against the table of
/// shared/scenes/README.md. The loader drops degenerate triangles (with a count in a
/// warning), so the check is loaded + dropped == the table's count.
fn check_count(rel: &str, expected: usize) -> Loaded {
    let loaded = load(&model(rel));
    let n = loaded.scene.counts().triangles;
    assert_eq!(
        n + dropped(&loaded),
        expected,
        "{rel}: {n} triangles loaded + {} dropped as degenerate",
        dropped(&loaded)
    );
    assert_eq!(loaded.scene.primitives.len(), n, "{rel}: only triangles");
    loaded
}

macro_rules! model_counts {
    ($($name:ident: $rel:literal => $count:expr;)*) => {$(
        #[test]
        fn $name() {
            check_count($rel, $count);
        }
    )*};
}

model_counts! {
    count_box_gltf: "Box/Box.gltf" => 12;
    count_box_glb: "Box/Box.glb" => 12;
    count_box_textured_gltf: "BoxTextured/BoxTextured.gltf" => 12;
    count_box_textured_glb: "BoxTextured/BoxTextured.glb" => 12;
    count_cameras: "Cameras/Cameras.gltf" => 2;
    count_cornell_box_glb: "CornellBox/CornellBox.glb" => 36;
    count_avocado: "Avocado/Avocado.gltf" => 682;
    count_suzanne: "Suzanne/Suzanne.gltf" => 3_936;
    count_lights_punctual_lamp: "LightsPunctualLamp/LightsPunctualLamp.gltf" => 6_000;
    count_damaged_helmet: "DamagedHelmet/DamagedHelmet.gltf" => 15_452;
    count_flight_helmet: "FlightHelmet/FlightHelmet.gltf" => 94_722;
    count_toy_car: "ToyCar/ToyCar.gltf" => 108_936;
}

/// 1,040,409 triangles: 98 sphere meshes sharing accessors, each instanced by a node. How
/// long loading takes is measured by `cuberay bench` (`load_s`), not here.
#[test]
fn count_metal_rough_spheres() {
    let loaded = check_count("MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf", 1_040_409);
    // 98 sphere materials and the labels' default material.
    assert_eq!(loaded.scene.materials.len(), 99);
}

#[test]
fn box_gltf_and_glb_give_the_same_scene() {
    for name in ["Box/Box", "BoxTextured/BoxTextured"] {
        let a = load(&model(&format!("{name}.gltf"))).scene;
        let b = load(&model(&format!("{name}.glb"))).scene;
        assert_eq!(a.primitives, b.primitives, "{name}");
        assert_eq!(a.materials, b.materials, "{name}");
        assert_eq!(a.textures, b.textures, "{name}");
        assert_eq!(a.camera, b.camera, "{name}");
        assert_eq!(a.lights, b.lights, "{name}");
    }
}

#[test]
fn strips_fans_and_non_indexed_triangles() {
    // A unit quad in the z = 0 plane, counter-clockwise seen from +Z, four ways.
    let mut doc = Doc::new();
    let strip = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]);
    let fan = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]);
    let soup = doc.vec3(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]);
    let idx = doc.indices(&[0, 1, 2, 0, 2, 3]);
    let points = doc.vec3(&[[0.0, 0.0, 5.0]]);
    let mesh = json!({"primitives": [
        {"attributes": {"POSITION": strip}, "mode": 5},
        {"attributes": {"POSITION": fan}, "mode": 6},
        {"attributes": {"POSITION": soup}},
        {"attributes": {"POSITION": fan}, "indices": idx},
        {"attributes": {"POSITION": points}, "mode": 0},
    ]});
    let loaded = load_mesh_with_node(&doc, mesh, json!({}));
    let tris = triangles(&loaded.scene);
    assert_eq!(tris.len(), 8);
    for t in &tris {
        assert!(t.cross().normalize().z > 0.999, "winding: {t:?}");
        assert!(t.n.is_none() && t.uv.is_none());
    }
    let area: f64 = tris.iter().map(|t| t.cross().length() / 2.0).sum();
    assert!((area - 4.0).abs() < 1e-12);
    assert!(
        loaded.warnings.iter().any(|w| w.contains("primitives[4]") && w.contains("Points")),
        "{:?}",
        loaded.warnings
    );
}

#[test]
fn sparse_accessors_substitute_elements() {
    let mut doc = Doc::new();
    let p = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let indices = doc.view(&[2u8]);
    let values = doc.view(&[0f32, 2.0, 0.0].map(f32::to_le_bytes).concat());
    doc.accessors[p]["sparse"] = json!({"count": 1, "indices": {"bufferView": indices, "componentType": 5121},
                                        "values": {"bufferView": values}});
    doc.accessors[p]["max"] = json!([1.0, 2.0, 0.0]);
    let loaded =
        load_mesh_with_node(&doc, json!({"primitives": [{"attributes": {"POSITION": p}}]}), json!({}));
    assert_eq!(triangles(&loaded.scene)[0].p, [DVec3::ZERO, DVec3::X, DVec3::new(0.0, 2.0, 0.0)]);
}

#[test]
fn degenerate_triangles_and_bad_normals() {
    let mut doc = Doc::new();
    let p = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [2.0, 0.0, 0.0]]);
    let n = doc.vec3(&[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 2.0], [0.0, 0.0, 1.0]]);
    // Triangle 1 is collinear, triangle 2 repeats a vertex.
    let idx = doc.indices(&[0, 1, 2, 0, 1, 3, 2, 2, 1]);
    let loaded = load_mesh_with_node(
        &doc,
        json!({"primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": idx}]}),
        json!({}),
    );
    let tris = triangles(&loaded.scene);
    assert_eq!(tris.len(), 1);
    assert_eq!(dropped(&loaded), 2, "{:?}", loaded.warnings);
    // The zero normal became the geometric normal; the long one was normalised.
    assert_eq!(tris[0].n.unwrap(), [DVec3::Z; 3]);
    assert!(
        loaded.warnings.iter().any(|w| w.contains("NORMAL (accessors[1])") && w.contains("1 normals")),
        "{:?}",
        loaded.warnings
    );
}

/// COLOR_0 as floats (VEC3) and as normalised unsigned shorts (VEC4, alpha not read) gives
/// the triangles' vertex colours; one that is neither is refused with its JSON path.
#[test]
fn vertex_colors_as_floats_and_normalised_shorts() {
    let mut doc = Doc::new();
    let p = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let floats = doc.vec3(&[[1.0, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.25]]);
    let shorts: Vec<u8> = [65535u16, 0, 0, 65535, 0, 32768, 0, 0, 0, 0, 65535, 0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let view = doc.view(&shorts);
    let normalised = doc.accessor(
        json!({"bufferView": view, "componentType": 5123, "normalized": true, "count": 3, "type": "VEC4"}),
    );
    let mesh = |c: usize| json!({"primitives": [{"attributes": {"POSITION": p, "COLOR_0": c}}]});
    let tris =
        |c: usize| *triangles(&load_mesh_with_node(&doc, mesh(c), json!({})).scene)[0].color.clone().unwrap();
    assert_eq!(tris(floats), [DVec3::X, DVec3::new(0.0, 0.5, 0.0), DVec3::new(0.0, 0.0, 0.25)]);
    let c = tris(normalised);
    assert_eq!(c[0], DVec3::X);
    assert!((c[1] - DVec3::new(0.0, 32768.0 / 65535.0, 0.0)).length() < 1e-7, "{c:?}");
    assert_eq!(c[2], DVec3::Z);
    // A VEC2 is no colour.
    let uv = doc.vec2(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
    let dir = TempDir::new();
    let rest = json!({"meshes": [mesh(uv)], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0});
    let path = doc.write(&dir, "bad_color.gltf", rest);
    assert_error(&load_err(&path), &path, &["COLOR_0", "VEC3"]);
}

#[test]
fn embedded_buffers_and_root_nodes_without_a_scene() {
    use base64::Engine as _;
    let mut doc = Doc::new();
    let mesh = tetrahedron(&mut doc);
    let dir = TempDir::new();
    let external = doc.write(&dir, "ext.gltf", json!({"meshes": [mesh.clone()], "nodes": [{"mesh": 0}]}));
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&doc.bin)
    );
    let embedded = dir.path("emb.gltf");
    std::fs::write(&embedded, doc.json(&uri, json!({"meshes": [mesh], "nodes": [{"mesh": 0}]})).to_string())
        .unwrap();
    let a = load(&external).scene;
    let b = load(&embedded).scene;
    assert_eq!(a.primitives.len(), 4);
    assert_eq!(a.primitives, b.primitives);
}
