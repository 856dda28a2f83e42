//! Malformed compressed glTF is refused with an error that names the file and the buffer
//! view, accessor or extension at fault, and `cuberay` exits 1 without a panic. The files
//! are the `compressed` fuzz target's seeds (fuzz/seeds/compressed/, the project's own
//! tetrahedron as gltfpack and gltf-transform write it) with one field or stream broken.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

/// A seed of the `compressed` fuzz target.
fn seed(name: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/compressed").join(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The JSON chunk of a GLB.
pub fn glb_json(glb: &[u8]) -> Value {
    let n = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&glb[20..20 + n]).expect("the GLB's JSON")
}

/// `glb` with its JSON chunk replaced by `json` (the binary chunk kept).
fn with_json(glb: &[u8], json: &Value) -> Vec<u8> {
    let n = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let rest = &glb[20 + n..];
    let mut text = serde_json::to_vec(json).unwrap();
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((20 + text.len() + rest.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend(rest);
    out
}

/// Writes `bytes` as `name` in a fresh folder and loads it, which must fail; returns the
/// message, which must name the file and each of `fragments`.
fn refused(name: &str, bytes: &[u8], fragments: &[&str]) -> (tempfile::TempDir, PathBuf, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    let err = match cuberay::load::load(&path, &Default::default()) {
        Ok(_) => panic!("{name} loaded, but it should have been refused"),
        Err(e) => e.to_string(),
    };
    eprintln!("{err}");
    assert!(err.contains(name), "the error does not name the file: {err}");
    for f in fragments {
        assert!(err.contains(f), "the error lacks '{f}': {err}");
    }
    (dir, path, err)
}

/// The first buffer view compressed with meshopt, and its index.
fn meshopt_view(doc: &mut Value) -> (usize, &mut Value) {
    let views = doc["bufferViews"].as_array_mut().unwrap();
    let (i, v) = views
        .iter_mut()
        .enumerate()
        .find(|(_, v)| v["extensions"]["EXT_meshopt_compression"].is_object())
        .unwrap();
    (i, &mut v["extensions"]["EXT_meshopt_compression"])
}

#[test]
fn a_truncated_meshopt_stream_names_its_buffer_view_and_exits_1() {
    let glb = seed("meshopt.glb");
    let mut doc = glb_json(&glb);
    let (i, ext) = meshopt_view(&mut doc);
    ext["byteLength"] = json!(6);
    let view = format!("bufferViews[{i}].extensions.EXT_meshopt_compression");
    let (_dir, path, _) = refused("t.glb", &with_json(&glb, &doc), &[&view, "do not decode"]);
    // The command line says the same on stderr and exits 1.
    let out = crate::common::cuberay().arg("info").arg(&path).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.starts_with("error:") && stderr.contains(&view) && !stderr.contains("panicked"),
        "{stderr}"
    );
}

#[test]
fn meshopt_fields_the_decoder_asserts_on_are_refused_first() {
    let glb = seed("meshopt.glb");
    for (field, value, says) in [
        ("byteStride", json!(260), "byteStride 260"),
        ("mode", json!("QUADS"), "mode QUADS"),
        ("filter", json!("SPLINE"), "filter SPLINE"),
        ("count", json!(1u64 << 40), "more than the"),
        ("buffer", json!(1), "fallback buffer"),
    ] {
        let mut doc = glb_json(&glb);
        meshopt_view(&mut doc).1[field] = value;
        refused("t.glb", &with_json(&glb, &doc), &["EXT_meshopt_compression", says]);
    }
    // A view of the fallback buffer that is not compressed itself has no data to read.
    let mut doc = glb_json(&glb);
    let (i, _) = meshopt_view(&mut doc);
    doc["bufferViews"][i]["extensions"] = json!({});
    refused(
        "t.glb",
        &with_json(&glb, &doc),
        &[&format!("bufferViews[{i}] lies in buffers[1], a meshopt fallback buffer")],
    );
}

#[test]
fn a_broken_draco_stream_names_its_primitive_and_buffer_view() {
    let glb = seed("draco.glb");
    let doc = glb_json(&glb);
    let ext = &doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"];
    let view = ext["bufferView"].as_u64().unwrap() as usize;
    let at = format!("meshes[0].primitives[0].extensions.KHR_draco_mesh_compression (bufferViews[{view}])");
    // Cut short.
    let mut short = doc.clone();
    short["bufferViews"][view]["byteLength"] = json!(24);
    refused("t.glb", &with_json(&glb, &short), &[&at, "is not a Draco mesh this decoder reads"]);
    // Every byte after the header flipped.
    let bin = 20 + u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize + 8;
    let start = bin + doc["bufferViews"][view]["byteOffset"].as_u64().unwrap_or(0) as usize;
    let len = doc["bufferViews"][view]["byteLength"].as_u64().unwrap() as usize;
    let mut flipped = glb.clone();
    for b in &mut flipped[start + 11..start + len] {
        *b = !*b;
    }
    refused("t.glb", &flipped, &[&at]);
    // An attribute the stream does not hold.
    let mut missing = doc.clone();
    missing["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"]
        ["NORMAL"] = json!(77);
    refused("t.glb", &with_json(&glb, &missing), &["attributes.NORMAL", "no attribute of unique id 77"]);
}

#[test]
fn quantized_accessors_outside_what_the_extension_allows_are_refused() {
    let glb = seed("quantized.glb");
    let doc = glb_json(&glb);
    let normal = doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"].as_u64().unwrap() as usize;
    let mut bad = doc.clone();
    bad["accessors"][normal]["componentType"] = json!(5121); // UNSIGNED_BYTE, normalized
    bad["accessors"][normal]["normalized"] = json!(true);
    let at = format!("attributes.NORMAL (accessors[{normal}])");
    refused("t.glb", &with_json(&glb, &bad), &[&at, "normalized UNSIGNED_BYTE", "normalized BYTE"]);
}

#[test]
fn basisu_textures_are_refused_with_the_command_that_rewrites_them() {
    let glb = seed("meshopt.glb");
    let mut doc = glb_json(&glb);
    doc["textures"][0] = json!({"extensions": {"KHR_texture_basisu": {"source": 0}}});
    doc["extensionsUsed"].as_array_mut().unwrap().push(json!("KHR_texture_basisu"));
    let (.., err) =
        refused("t.glb", &with_json(&glb, &doc), &["textures[0]", "KHR_texture_basisu", "ktxdecompress"]);
    assert!(err.contains("npx @gltf-transform/cli ktxdecompress"), "{err}");
    doc["extensionsRequired"].as_array_mut().unwrap().push(json!("KHR_texture_basisu"));
    refused(
        "t.glb",
        &with_json(&glb, &doc),
        &["extensionsRequired[2]", "KHR_texture_basisu", "ktxdecompress"],
    );
}

#[test]
fn info_lists_each_extension_with_its_status() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/compressed/instanced_meshopt.glb");
    let out = crate::common::cuberay().args(["info", "--json"]).arg(&path).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let status = |name: &str| {
        let e = v["extensions"].as_array().unwrap().iter().find(|e| e["name"] == name);
        e.map(|e| (e["status"].as_str().unwrap().to_string(), e["required"].as_bool().unwrap()))
    };
    assert_eq!(status("EXT_meshopt_compression"), Some(("read".into(), true)));
    assert_eq!(status("EXT_mesh_gpu_instancing"), Some(("read".into(), true)));
    assert_eq!(status("KHR_materials_transmission"), Some(("approximated".into(), false)));
    assert_eq!(v["triangles"], 16, "four instances of the tetrahedron");
    let text = crate::common::cuberay().arg("info").arg(&path).output().unwrap();
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(text.contains("extensions: KHR_mesh_quantization (read, required)"), "{text}");
    // A material extension the Whitted model has no term for is listed as ignored.
    let glb = seed("meshopt.glb");
    let mut doc = glb_json(&glb);
    doc["extensionsUsed"].as_array_mut().unwrap().push(json!("KHR_materials_sheen"));
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sheen.glb");
    std::fs::write(&p, with_json(&glb, &doc)).unwrap();
    let out = crate::common::cuberay().arg("info").arg(&p).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("KHR_materials_sheen (ignored)"), "{text}");
}
