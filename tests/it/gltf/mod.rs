//! glTF loader tests: the sample models under `../shared/scenes/gltf` (counts, cameras,
//! lights, materials), transforms and primitive modes on small files written here, and
//! one test per kind of bad input.
//!
//! This module holds what the areas share: loading, the small documents the tests write (and
//! a tetrahedron to put in them), and the check of an error's text. The tests are in one
//! sub-module per area of the loader:
//!
//! - `geometry`: the sample models' triangle counts, `.gltf` and `.glb` alike, primitive
//!   modes, accessors (sparse, degenerate triangles and bad normals, vertex colours),
//!   embedded buffers;
//! - `transforms`: node transforms and the hierarchy (normals, mirroring, instancing);
//! - `materials`: textures and UV sets, normal and metallic-roughness maps, texture
//!   transforms;
//! - `layers`: the material extensions beyond metallic-roughness (volume, clear coat,
//!   specular) against their closed forms on both backends;
//! - `cameras_and_lights`: the sample models' cameras and punctual lights, the default light
//!   and automatic camera, spot and directional lights;
//! - `bad_input`: each kind of bad input gives an error naming the file and the place.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::DVec3;
use serde_json::{json, Value};

use cuberay::load::{self, LoadOptions, Loaded};
use cuberay::scene::{Primitive, Scene, Triangle};
use cuberay::Error;

mod bad_input;
mod cameras_and_lights;
mod geometry;
mod layers;
mod materials;
mod transforms;

// ---------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------

/// The shared glTF sample models (`gltf/` of the shared scenes folder).
fn models_dir() -> PathBuf {
    crate::common::shared_scenes().join("gltf")
}

fn model(rel: &str) -> PathBuf {
    let p = models_dir().join(rel);
    assert!(p.is_file(), "sample model {} is missing", p.display());
    p
}

fn load_with(path: &Path, camera: Option<usize>) -> Loaded {
    match load::load(path, &LoadOptions { camera, time: None }) {
        Ok(l) => l,
        Err(e) => panic!("{} failed to load: {e}", path.display()),
    }
}

fn load(path: &Path) -> Loaded {
    load_with(path, None)
}

fn load_err(path: &Path) -> Error {
    match load::load(path, &LoadOptions::default()) {
        Ok(_) => panic!("{} loaded, but it should have been rejected", path.display()),
        Err(e) => e,
    }
}

/// The number in the loader's "dropped N degenerate triangles" warning (0 without one).
fn dropped(loaded: &Loaded) -> usize {
    loaded
        .warnings
        .iter()
        .find_map(|w| w.strip_prefix("dropped ")?.strip_suffix(" degenerate triangles")?.parse().ok())
        .unwrap_or(0)
}

fn triangles(scene: &Scene) -> Vec<&Triangle> {
    scene
        .primitives
        .iter()
        .map(|p| match p {
            Primitive::Triangle(t) => t,
            other => panic!("a glTF scene holds only triangles, found {other:?}"),
        })
        .collect()
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).length() <= tol
}

/// A temporary directory removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> TempDir {
        static N: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "cuberay-gltf-test-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A small glTF document under construction: one binary buffer (`data.bin`) holding the
/// accessors added so far, plus whatever JSON the test supplies.
struct Doc {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Doc {
    fn new() -> Doc {
        Doc { bin: Vec::new(), views: Vec::new(), accessors: Vec::new() }
    }

    fn view(&mut self, bytes: &[u8]) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views.push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let min: Vec<f32> = (0..3).map(|k| v.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min)).collect();
        let max: Vec<f32> =
            (0..3).map(|k| v.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max)).collect();
        self.accessor(json!({"bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC3",
                             "min": min, "max": max}))
    }

    fn vec2(&mut self, v: &[[f32; 2]]) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessor(json!({"bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC2"}))
    }

    fn vec4(&mut self, v: &[[f32; 4]]) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessor(json!({"bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC4"}))
    }

    fn indices(&mut self, idx: &[u16]) -> usize {
        let bytes: Vec<u8> = idx.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessor(
            json!({"bufferView": view, "componentType": 5123, "count": idx.len(), "type": "SCALAR"}),
        )
    }

    /// The complete JSON: `rest` (meshes, nodes, scenes...) plus asset, buffer, views
    /// and accessors, with the buffer at `uri`.
    fn json(&self, uri: &str, rest: Value) -> Value {
        let mut doc = json!({
            "asset": {"version": "2.0"},
            "buffers": [{"uri": uri, "byteLength": self.bin.len()}],
            "bufferViews": self.views,
            "accessors": self.accessors,
        });
        for (k, v) in rest.as_object().expect("rest is a JSON object") {
            doc[k] = v.clone();
        }
        doc
    }

    /// Writes `name` (.gltf) and `data.bin` into `dir`; returns the .gltf path.
    fn write(&self, dir: &TempDir, name: &str, rest: Value) -> PathBuf {
        std::fs::write(dir.path("data.bin"), &self.bin).unwrap();
        let path = dir.path(name);
        std::fs::write(&path, serde_json::to_vec_pretty(&self.json("data.bin", rest)).unwrap()).unwrap();
        path
    }
}

/// A regular tetrahedron around the origin with counter-clockwise (outward) winding,
/// four unshared vertices per face... (3 per face, 12 in all), each with its face normal.
fn tetrahedron(doc: &mut Doc) -> Value {
    let v = [[1.0f32, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];
    let faces = [[0usize, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
    let mut pos = Vec::new();
    let mut nrm = Vec::new();
    for f in faces {
        let p: Vec<DVec3> = f.iter().map(|&i| DVec3::from(v[i].map(f64::from))).collect();
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        assert!(n.dot(p[0] + p[1] + p[2]) > 0.0, "test data: face {f:?} is not wound outwards");
        for &i in &f {
            pos.push(v[i]);
            nrm.push([n.x as f32, n.y as f32, n.z as f32]);
        }
    }
    let p = doc.vec3(&pos);
    let n = doc.vec3(&nrm);
    json!({"primitives": [{"attributes": {"POSITION": p, "NORMAL": n}}]})
}

/// Loads a one-mesh document whose single node has `node` properties (besides "mesh").
fn load_mesh_with_node(doc: &Doc, mesh: Value, node: Value) -> Loaded {
    let dir = TempDir::new();
    let mut n = node;
    n["mesh"] = json!(0);
    let path = doc.write(
        &dir,
        "t.gltf",
        json!({"meshes": [mesh], "nodes": [n], "scenes": [{"nodes": [0]}], "scene": 0}),
    );
    load(&path)
}

/// Asserts that the error names the file and contains every fragment.
fn assert_error(err: &Error, file: &Path, fragments: &[&str]) {
    let text = err.to_string();
    eprintln!("{text}");
    let name = file.file_name().unwrap().to_str().unwrap();
    assert!(text.contains(name), "error does not name the file {name}: {text}");
    for f in fragments {
        assert!(text.contains(f), "error lacks '{f}': {text}");
    }
}
