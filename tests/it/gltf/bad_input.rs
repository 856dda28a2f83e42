//! glTF bad input: each kind gives an error naming the file and the place, never a panic.

use serde_json::{json, Value};

use cuberay::load::LoadOptions;
use cuberay::Error;

use super::{assert_error, load, load_err, model, tetrahedron, Doc, TempDir};

/// A valid one-tetrahedron document and its parts, for tests to break.
fn valid_doc() -> (Doc, Value) {
    let mut doc = Doc::new();
    let mesh = tetrahedron(&mut doc);
    let rest = json!({"meshes": [mesh], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0});
    (doc, rest)
}

#[test]
fn bad_truncated_and_invalid_json() {
    let (doc, rest) = valid_doc();
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest);
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, &text[..text.len() / 2]).unwrap();
    assert_error(&load_err(&path), &path, &["JSON", "EOF"]);
    std::fs::write(&path, "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [,]}").unwrap();
    assert_error(&load_err(&path), &path, &["JSON", "line 1"]);
    std::fs::write(&path, "").unwrap();
    assert_error(&load_err(&path), &path, &["JSON"]);
}

#[test]
fn bad_truncated_glb() {
    let bytes = std::fs::read(model("Box/Box.glb")).unwrap();
    let dir = TempDir::new();
    let path = dir.path("cut.glb");
    for len in [4, 11, 12, 20, bytes.len() / 2, bytes.len() - 1] {
        std::fs::write(&path, &bytes[..len]).unwrap();
        assert_error(&load_err(&path), &path, &["GLB"]);
    }
    // A header that declares fewer bytes than the header itself.
    let mut short = bytes.clone();
    short[8..12].copy_from_slice(&4u32.to_le_bytes());
    std::fs::write(&path, &short).unwrap();
    assert_error(&load_err(&path), &path, &["GLB header", "declares 4 bytes"]);
    // A consistent header over a cut chunk: the chunk's own length is wrong.
    let cut = bytes.len() - 100;
    let mut chunk = bytes[..cut].to_vec();
    chunk[8..12].copy_from_slice(&(cut as u32).to_le_bytes());
    std::fs::write(&path, &chunk).unwrap();
    assert_error(&load_err(&path), &path, &["GLB", "chunk"]);
    // The JSON chunk alone: buffers[0] refers to a binary chunk that is not there.
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut json_only = bytes[..20 + json_len].to_vec();
    json_only[8..12].copy_from_slice(&((20 + json_len) as u32).to_le_bytes());
    std::fs::write(&path, &json_only).unwrap();
    assert_error(&load_err(&path), &path, &["buffers[0]", "binary chunk"]);
}

/// gltf-json 1.4's validation indexed `accessors` with a primitive's POSITION unchecked:
/// such a file panicked (`cuberay info` exit 101) instead of being refused.
#[test]
fn bad_position_accessor_that_does_not_exist() {
    let (doc, mut rest) = valid_doc();
    let dir = TempDir::new();
    rest["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(7);
    let path = doc.write(&dir, "t.gltf", rest.clone());
    let n = doc.accessors.len();
    assert_error(
        &load_err(&path),
        &path,
        &[
            "meshes[0].primitives[0].attributes.POSITION",
            &format!("names accessors[7], but the file has {n} accessors"),
        ],
    );
    // No accessors at all (a misspelt `accessors` array).
    let mut text: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    text.as_object_mut().unwrap().remove("accessors");
    text["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(2);
    std::fs::write(&path, serde_json::to_string(&text).unwrap()).unwrap();
    assert_error(
        &load_err(&path),
        &path,
        &["attributes.POSITION", "names accessors[2], but the file has 0 accessors"],
    );
}

#[test]
fn bad_missing_bin() {
    let (doc, rest) = valid_doc();
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest);
    std::fs::remove_file(dir.path("data.bin")).unwrap();
    assert_error(&load_err(&path), &path, &["buffers[0]", "data.bin"]);
}

#[test]
fn bad_short_buffer() {
    let (doc, rest) = valid_doc();
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest);
    std::fs::write(dir.path("data.bin"), &doc.bin[..doc.bin.len() - 8]).unwrap();
    assert_error(&load_err(&path), &path, &["buffers[0]", "byteLength"]);
}

#[test]
fn bad_missing_image() {
    let (doc, mut rest) = valid_doc();
    with_image(&mut rest, json!({"uri": "nowhere.png"}));
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest);
    assert_error(&load_err(&path), &path, &["images[0]", "nowhere.png"]);
}

#[test]
fn bad_image_data() {
    let (doc, mut rest) = valid_doc();
    with_image(&mut rest, json!({"uri": "fake.png"}));
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest);
    std::fs::write(dir.path("fake.png"), b"not an image at all").unwrap();
    assert_error(&load_err(&path), &path, &["images[0]", "neither a PNG nor a JPEG"]);
    // A PNG signature followed by garbage.
    std::fs::write(dir.path("fake.png"), b"\x89PNG\r\n\x1a\n garbage").unwrap();
    assert_error(&load_err(&path), &path, &["images[0]", "cannot decode"]);
}

#[test]
fn bad_accessor_out_of_buffer_range() {
    let (doc, mut rest) = valid_doc();
    let dir = TempDir::new();
    // The POSITION accessor (accessors[0]) claims more elements than its view holds.
    let mut d = Doc { bin: doc.bin.clone(), views: doc.views.clone(), accessors: doc.accessors.clone() };
    d.accessors[0]["count"] = json!(13);
    rest["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(1);
    let path = d.write(&dir, "t.gltf", rest.clone());
    let err = load_err(&path);
    assert_error(&err, &path, &["meshes[0].primitives[0].attributes.POSITION (accessors[0])", "do not fit"]);
    // A byteOffset beyond the view.
    let mut d = Doc { bin: doc.bin.clone(), views: doc.views.clone(), accessors: doc.accessors.clone() };
    d.accessors[1]["byteOffset"] = json!(4);
    let path = d.write(&dir, "t.gltf", rest.clone());
    assert_error(&load_err(&path), &path, &["attributes.NORMAL (accessors[1])", "do not fit"]);
    // A buffer view beyond the buffer.
    let mut d = Doc { bin: doc.bin.clone(), views: doc.views.clone(), accessors: doc.accessors.clone() };
    d.views[1]["byteOffset"] = json!(doc.bin.len());
    let path = d.write(&dir, "t.gltf", rest);
    assert_error(&load_err(&path), &path, &["accessors[1]", "bufferViews[1]", "buffers[0]"]);
}

#[test]
fn bad_component_type() {
    let (doc, rest) = valid_doc();
    let mut d = Doc { bin: doc.bin.clone(), views: doc.views.clone(), accessors: doc.accessors.clone() };
    d.accessors[0]["componentType"] = json!(5125);
    let dir = TempDir::new();
    let path = d.write(&dir, "t.gltf", rest);
    assert_error(&load_err(&path), &path, &["POSITION (accessors[0])", "UNSIGNED_INT", "FLOAT"]);
}

#[test]
fn bad_index_out_of_range() {
    let (mut doc, mut rest) = valid_doc();
    let idx = doc.indices(&[0, 1, 2, 3, 4, 12]);
    rest["meshes"][0]["primitives"][0]["indices"] = json!(idx);
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest);
    assert_error(
        &load_err(&path),
        &path,
        &["meshes[0].primitives[0].indices (accessors[2])", "index 12", "12 vertices"],
    );
}

#[test]
fn bad_nan_position() {
    let mut doc = Doc::new();
    let p = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]]);
    let dir = TempDir::new();
    let rest = json!({"meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}], "nodes": [{"mesh": 0}]});
    let path = doc.write(&dir, "t.gltf", rest);
    assert_error(
        &load_err(&path),
        &path,
        &["attributes.POSITION (accessors[0])", "position 1", "not finite"],
    );
}

#[test]
fn bad_unsupported_required_extension() {
    let (doc, mut rest) = valid_doc();
    rest["extensionsUsed"] = json!(["KHR_texture_basisu"]);
    rest["extensionsRequired"] = json!(["KHR_texture_basisu"]);
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest.clone());
    assert_error(&load_err(&path), &path, &["extensionsRequired[0]", "KHR_texture_basisu"]);
    // The same extension, merely used, is a warning.
    rest.as_object_mut().unwrap().remove("extensionsRequired");
    let path = doc.write(&dir, "t.gltf", rest);
    let loaded = load(&path);
    assert_eq!(loaded.warnings.iter().filter(|w| w.contains("KHR_texture_basisu")).count(), 1);
}

#[test]
fn bad_scene_without_meshes() {
    let (doc, _) = valid_doc();
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", json!({"nodes": [{"name": "empty"}], "scenes": [{"nodes": [0]}]}));
    let err = load_err(&path);
    assert!(matches!(err, Error::Invalid { .. }), "{err:?}");
    assert_error(&err, &path, &["no triangles"]);
    // Only points: still nothing to render.
    let (mut doc, _) = valid_doc();
    let p = doc.vec3(&[[0.0, 0.0, 0.0]]);
    let path = doc.write(
        &dir,
        "t.gltf",
        json!({"meshes": [{"primitives": [{"attributes": {"POSITION": p}, "mode": 0}]}], "nodes": [{"mesh": 0}]}),
    );
    assert!(matches!(load_err(&path), Error::Invalid { .. }));
}

#[test]
fn bad_huge_counts_are_refused_before_allocating() {
    // An accessor without a buffer view is zeros plus sparse substitutions: nothing but a
    // limit bounds its count.
    let zero_filled = |count: u64| {
        let mut doc = Doc::new();
        let indices = doc.view(&0u32.to_le_bytes());
        let values = doc.view(&[0u8; 12]);
        doc.accessor(json!({"componentType": 5126, "count": count, "type": "VEC3",
                            "min": [0, 0, 0], "max": [0, 0, 0],
                            "sparse": {"count": 1, "indices": {"bufferView": indices, "componentType": 5125},
                                       "values": {"bufferView": values}}}));
        doc
    };
    let dir = TempDir::new();
    let mesh = json!({"primitives": [{"attributes": {"POSITION": 0}}]});
    let path = zero_filled(1_000_000_000_000).write(
        &dir,
        "t.gltf",
        json!({"meshes": [mesh], "nodes": [{"mesh": 0}]}),
    );
    assert_error(&load_err(&path), &path, &["POSITION (accessors[0])", "without a bufferView"]);
    // A small file whose 70 nodes each instance a million triangles.
    let nodes: Vec<Value> = (0..70).map(|_| json!({"mesh": 0})).collect();
    let roots: Vec<usize> = (0..70).collect();
    let path = zero_filled(3_000_000).write(
        &dir,
        "t.gltf",
        json!({"meshes": [mesh], "nodes": nodes, "scenes": [{"nodes": roots}]}),
    );
    let err = load_err(&path);
    assert!(matches!(err, Error::Invalid { .. }), "{err:?}");
    assert_error(&err, &path, &["70000000 triangles", "at most"]);
}

#[test]
fn bad_node_cycle() {
    let (doc, mut rest) = valid_doc();
    rest["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}]);
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest);
    assert_error(&load_err(&path), &path, &["nodes[0]", "reached twice"]);
}

/// Applies `edit` to the valid document and asserts that loading fails with an error
/// containing `fragments` (and the file name).
fn assert_rejected(what: &str, edit: impl Fn(&mut Value), fragments: &[&str]) {
    let (doc, mut rest) = valid_doc();
    edit(&mut rest);
    let dir = TempDir::new();
    let path = doc.write(&dir, "t.gltf", rest);
    match load::load(&path, &LoadOptions::default()) {
        Ok(_) => panic!("{what}: loaded, but it should have been rejected"),
        Err(e) => assert_error(&e, &path, fragments),
    }
}

/// Adds a material whose base colour texture is image 0 described by `image`.
fn with_image(r: &mut Value, image: Value) {
    r["images"] = json!([image]);
    r["textures"] = json!([{"source": 0}]);
    r["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    r["meshes"][0]["primitives"][0]["material"] = json!(0);
}

#[test]
fn bad_references_and_values_do_not_panic() {
    assert_rejected("mesh index", |r| r["nodes"][0]["mesh"] = json!(7), &["nodes[0].mesh"]);
    let with_camera = |r: &mut Value, camera: Value| {
        r["cameras"] = json!([camera]);
        r["nodes"] = json!([{"mesh": 0}, {"camera": 0}]);
        r["scenes"] = json!([{"nodes": [0, 1]}]);
    };
    assert_rejected(
        "camera type without its object",
        |r| {
            with_camera(
                r,
                json!({"type": "perspective", "orthographic": {"xmag": 1, "ymag": 1, "zfar": 10, "znear": 1}}),
            )
        },
        &["cameras[0]"],
    );
    assert_rejected(
        "field of view",
        |r| with_camera(r, json!({"type": "perspective", "perspective": {"yfov": 4.0, "znear": 0.1}})),
        &["cameras[0]", "field of view"],
    );
    assert_rejected(
        "orthographic magnification",
        |r| {
            with_camera(
                r,
                json!({"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 0, "zfar": 10, "znear": 1}}),
            )
        },
        &["cameras[0]", "ymag"],
    );
    assert_rejected(
        "zero quaternion",
        |r| r["nodes"][0]["rotation"] = json!([0, 0, 0, 0]),
        &["nodes[0]", "zero quaternion"],
    );
    assert_rejected(
        "projective matrix",
        |r| r["nodes"][0]["matrix"] = json!([1, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
        &["nodes[0]", "not affine"],
    );
    assert_rejected(
        "light index",
        |r| r["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 0}}),
        &["nodes[0]", "light"],
    );
    assert_rejected(
        "spot cones",
        |r| {
            r["extensions"] = json!({"KHR_lights_punctual": {"lights": [
                {"type": "spot", "spot": {"innerConeAngle": 0.6, "outerConeAngle": 0.5}}]}});
            r["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 0}});
        },
        &["KHR_lights_punctual.lights[0]", "cone"],
    );
    assert_rejected(
        "image without source",
        |r| with_image(r, json!({"name": "nothing"})),
        &["images[0]", "neither a uri nor a bufferView"],
    );
    assert_rejected(
        "unsupported URI scheme",
        |r| with_image(r, json!({"uri": "https://example.com/a.png"})),
        &["images[0]", "https://example.com/a.png"],
    );
    assert_rejected(
        "index of refraction",
        |r| {
            r["materials"] = json!([{"extensions": {"KHR_materials_ior": {"ior": 0.5}}}]);
            r["meshes"][0]["primitives"][0]["material"] = json!(0);
        },
        &["materials[0]", "ior 0.5"],
    );
}
