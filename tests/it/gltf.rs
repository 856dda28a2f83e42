//! glTF loader tests: the sample models under `../shared/scenes/gltf` (counts, cameras,
//! lights, materials), transforms and primitive modes on small files written here, and
//! one test per kind of bad input.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{DMat3, DMat4, DQuat, DVec2, DVec3};
use serde_json::{json, Value};

use cuberay::load::{self, LoadOptions, Loaded};
use cuberay::scene::{LightKind, LightSource, Primitive, Projection, Scene, Triangle};
use cuberay::Error;

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

// ---------------------------------------------------------------------------------------
// The sample models
// ---------------------------------------------------------------------------------------

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
fn box_textured_has_uvs_and_its_texture() {
    let scene = load(&model("BoxTextured/BoxTextured.gltf")).scene;
    assert_eq!(scene.textures.len(), 1);
    let t = &scene.textures[0];
    // CesiumLogoFlat.png is 256x256; the sampler repeats and filters linearly.
    assert_eq!((t.width, t.height, t.linear), (256, 256, true));
    assert_eq!(t.wrap_s, cuberay::scene::Wrap::Repeat);
    assert!(triangles(&scene).iter().all(|t| t.uv.is_some() && t.n.is_some()));
    assert!(scene.effects().textures);
    // Box has no texture, so its triangles carry no UVs.
    let scene = load(&model("Box/Box.gltf")).scene;
    assert!(triangles(&scene).iter().all(|t| t.uv.is_none() && t.n.is_some()));
}

#[test]
fn cameras_perspective_and_orthographic() {
    let path = model("Cameras/Cameras.gltf");
    // Both camera nodes sit at (0.5, 0.5, 3) without rotation: they look down −Z, up +Y.
    let first = load_with(&path, None).scene.camera;
    let cam0 = load_with(&path, Some(0)).scene.camera;
    assert_eq!(first, cam0, "the first camera is the default");
    assert!(close(cam0.eye, DVec3::new(0.5, 0.5, 3.0), 1e-6));
    assert!(close(cam0.forward, DVec3::NEG_Z, 1e-12) && close(cam0.up, DVec3::Y, 1e-12));
    match cam0.projection {
        Projection::Perspective { fov_y, .. } => assert!((fov_y - 0.7).abs() < 1e-6),
        p => panic!("camera 0 should be perspective, is {p:?}"),
    }
    assert_eq!(cam0.aspect_hint, Some(1.0));
    assert!((cam0.near - 0.01).abs() < 1e-6);

    let cam1 = load_with(&path, Some(1)).scene.camera;
    assert_eq!(cam1.projection, Projection::Orthographic { half_height: 1.0 });
    assert_eq!(cam1.aspect_hint, Some(1.0));
    assert!(close(cam1.eye, DVec3::new(0.5, 0.5, 3.0), 1e-6));

    let err = load::load(&path, &LoadOptions { camera: Some(2), time: None }).unwrap_err().to_string();
    assert!(err.contains("camera 2") && err.contains("2 camera nodes"), "{err}");
}

#[test]
fn toy_car_cameras_are_selectable_and_extensions_warned_once() {
    let path = model("ToyCar/ToyCar.gltf");
    let loaded = load_with(&path, Some(7));
    assert!(matches!(loaded.scene.camera.projection, Projection::Perspective { .. }));
    assert!(load::load(&path, &LoadOptions { camera: Some(8), time: None }).is_err());
    for ext in ["KHR_materials_clearcoat", "KHR_materials_sheen"] {
        let n = loaded.warnings.iter().filter(|w| w.contains(ext)).count();
        assert_eq!(n, 1, "{ext}: {:?}", loaded.warnings);
    }
    // KHR_texture_transform is applied (the fabric's base colour repeats 3×), not warned.
    assert!(!loaded.warnings.iter().any(|w| w.contains("KHR_texture_transform")), "{:?}", loaded.warnings);
    // The glass material transmits (KHR_materials_transmission).
    assert!(loaded.scene.materials.iter().any(|m| m.transmittance > 0.0));
}

#[test]
fn lights_punctual_lamp_has_five_point_lights() {
    let loaded = load(&model("LightsPunctualLamp/LightsPunctualLamp.gltf"));
    let lights = &loaded.scene.lights;
    assert_eq!(lights.len(), 5, "{lights:?}");
    for l in lights {
        assert_eq!(l.kind, LightKind::Point);
        assert_eq!(l.source, LightSource::File);
        assert!(l.inverse_square);
    }
    // The first light node (nodes[3]) holds light 0: intensity 15 at the translation of
    // its matrix, colour (1, 0.632, 0.239).
    let l = &lights[0];
    assert_eq!(l.intensity, 15.0);
    assert!(close(
        l.position,
        DVec3::new(0.04622355476021767, 0.9077973365783693, 0.006696629337966442),
        1e-6
    ));
    assert!(close(l.color, DVec3::new(1.0, 0.6318749785423279, 0.23909975588321689), 1e-6));
    let mut intensities: Vec<f64> = lights.iter().map(|l| l.intensity).collect();
    intensities.sort_by(f64::total_cmp);
    assert_eq!(intensities, [1.5, 15.0, 80.0, 80.0, 180.0]);
    assert!(!loaded.warnings.iter().any(|w| w.contains("no light")));
}

#[test]
fn cornell_box_emits_and_gets_the_default_light() {
    let loaded = load(&model("CornellBox/CornellBox.glb"));
    let scene = &loaded.scene;
    assert!(scene.effects().emission);
    assert_eq!(scene.file_lights().count(), 0);
    assert_eq!(scene.lights.len(), 1);
    assert_eq!(scene.lights[0].source, LightSource::Default);
    assert_eq!(scene.lights[0].position, scene.camera.eye);
    assert!(loaded.warnings.iter().any(|w| w.contains("no light")));
    // No camera in the file: the automatic camera sees the whole box.
    assert!(loaded.warnings.iter().any(|w| w.contains("no camera")));
    let b = scene.bounds();
    let cam = &scene.camera;
    for corner in [b.min, b.max, DVec3::new(b.min.x, b.max.y, b.min.z), DVec3::new(b.max.x, b.min.y, b.max.z)]
    {
        let d = (corner - cam.eye).normalize();
        let (x, y, z) = (d.dot(cam.right), d.dot(cam.up), d.dot(cam.forward));
        let half = match cam.projection {
            Projection::Perspective { fov_y, .. } => (fov_y / 2.0).tan(),
            p => panic!("automatic camera should be perspective, is {p:?}"),
        };
        assert!(z > 0.0 && x.abs() / z <= half && y.abs() / z <= half, "corner {corner} is out of view");
    }
}

#[test]
fn damaged_helmet_is_textured_and_emissive_but_not_black() {
    let loaded = load(&model("DamagedHelmet/DamagedHelmet.gltf"));
    // Only the occlusion map is not applied, and that is said once; nothing is averaged.
    let said = |a: &str| loaded.warnings.iter().filter(|w| w.contains(a)).count();
    assert_eq!(said("materials[0]: occlusion maps are not applied"), 1, "{:?}", loaded.warnings);
    assert_eq!(said("mean"), 0, "{:?}", loaded.warnings);
    assert_eq!(said("normal maps"), 0, "{:?}", loaded.warnings);
    let scene = loaded.scene;
    // Base colour, metallic-roughness, emissive and normal maps become scene textures, the
    // colour ones sRGB, the data ones linear (the occlusion map is not decoded).
    let srgb: Vec<bool> = scene.textures.iter().map(|t| t.srgb).collect();
    assert_eq!(srgb, [true, false, true, false]);
    let m = &scene.materials[0];
    assert!(m.base_color_texture.is_some() && m.normal_map.is_some());
    let maps = m.maps.as_deref().expect("per-hit maps");
    assert!(maps.metallic_roughness.is_some() && maps.emissive.is_some());
    // The scalars are bounds over the maps: the emissive map's brightest texel and the
    // metal parts' mirror make the helmet emit and reflect.
    assert!(m.emits() && m.reflects(), "{m:?}");
    let e = scene.effects();
    assert!(e.maps && e.normal_maps && e.reflection && !e.alpha, "{e:?}");
    // Tangents were made by MikkTSpace (the file has no TANGENT): every triangle has them but
    // one, whose texture coordinates have no area (it is shaded without the normal map).
    let tris = triangles(&scene);
    let without = tris.iter().filter(|t| t.tangent.is_none()).count();
    assert_eq!(without, 1, "{without} of {} triangles lack tangents", tris.len());
}

// ---------------------------------------------------------------------------------------
// Transforms and primitive modes, on files written by the tests
// ---------------------------------------------------------------------------------------

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
fn uvs_follow_the_base_colour_texture_coordinate_set() {
    let dir = TempDir::new();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 255])).save(dir.path("tex.png")).unwrap();
    let mut doc = Doc::new();
    let p = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let uv0 = doc.vec2(&[[0.0, 0.0]; 3]);
    let uv1 = doc.vec2(&[[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]]);
    let path = doc.write(
        &dir,
        "uv.gltf",
        json!({
            "images": [{"uri": "tex.png"}],
            "samplers": [{"magFilter": 9728, "wrapS": 33071, "wrapT": 33648}],
            "textures": [{"source": 0, "sampler": 0}],
            "materials": [
                {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 1}}},
                {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}},
            ],
            "meshes": [{"primitives": [
                {"attributes": {"POSITION": p, "TEXCOORD_0": uv0, "TEXCOORD_1": uv1}, "material": 0},
                {"attributes": {"POSITION": p, "TEXCOORD_0": uv0, "TEXCOORD_1": uv1}, "material": 1},
            ]}],
            "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}],
        }),
    );
    let scene = load(&path).scene;
    let tris = triangles(&scene);
    let uv = tris[0].uv1.as_deref().expect("textured material: TEXCOORD_1 read");
    assert!((uv[2].x - 0.5).abs() < 1e-6 && (uv[2].y - 0.6).abs() < 1e-6, "{uv:?}");
    assert!(tris[0].uv.is_none(), "no texture reads TEXCOORD_0");
    assert!(tris[1].uv.is_none() && tris[1].uv1.is_none(), "untextured material: no UVs");
    let t = &scene.textures[0];
    assert_eq!((t.width, t.height, t.texels[0]), (2, 2, [200, 100, 50, 255]));
    assert_eq!(
        (t.wrap_s, t.wrap_t, t.linear),
        (cuberay::scene::Wrap::ClampToEdge, cuberay::scene::Wrap::MirroredRepeat, false)
    );
    let m = &scene.materials[tris[0].material as usize];
    assert_eq!(m.base_color_texture.unwrap().texcoord, 1);
}

/// Normal maps: a TANGENT whose w is not ±1, or a normalTexture transform that is not
/// numbers, is refused with its JSON path; a texture reading TEXCOORD_2 is not applied, and
/// a warning says so.
#[test]
fn normal_maps_and_texture_sets_are_checked() {
    let dir = TempDir::new();
    image::RgbaImage::from_pixel(1, 1, image::Rgba([128, 128, 255, 255])).save(dir.path("n.png")).unwrap();
    let mut doc = Doc::new();
    let p = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let uv = doc.vec2(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
    let bytes: Vec<u8> = [1.0f32, 0.0, 0.0, 0.5].repeat(3).iter().flat_map(|c| c.to_le_bytes()).collect();
    let view = doc.view(&bytes);
    let tangent =
        doc.accessor(json!({"bufferView": view, "componentType": 5126, "count": 3, "type": "VEC4"}));
    let nrm = doc.vec3(&[[0.0, 0.0, 1.0]; 3]);
    let file = |doc: &Doc, name: &str, normal: Value, attrs: Value| {
        doc.write(
            &dir,
            name,
            json!({
                "images": [{"uri": "n.png"}],
                "textures": [{"source": 0}],
                "materials": [{"normalTexture": normal}],
                "meshes": [{"primitives": [{"attributes": attrs, "material": 0}]}],
                "nodes": [{"mesh": 0}],
                "scenes": [{"nodes": [0]}],
            }),
        )
    };
    let path = file(
        &doc,
        "w.gltf",
        json!({"index": 0}),
        json!({"POSITION": p, "NORMAL": nrm, "TEXCOORD_0": uv, "TANGENT": tangent}),
    );
    assert_error(&load_err(&path), &path, &["TANGENT", "w = 0.5", "1 or -1"]);
    let bad = json!({"index": 0, "extensions": {"KHR_texture_transform": {"scale": [1.0, "two"]}}});
    let path = file(&doc, "t.gltf", bad, json!({"POSITION": p, "TEXCOORD_0": uv}));
    assert_error(
        &load_err(&path),
        &path,
        &["materials[0].normalTexture.extensions.KHR_texture_transform", "two numbers", "invalid type"],
    );
    let path =
        file(&doc, "set2.gltf", json!({"index": 0, "texCoord": 2}), json!({"POSITION": p, "TEXCOORD_0": uv}));
    let loaded = load(&path);
    assert!(loaded.scene.materials[0].normal_map.is_none());
    assert!(
        loaded.warnings.iter().any(|w| w.contains("materials[0].normalTexture") && w.contains("TEXCOORD_2")),
        "{:?}",
        loaded.warnings
    );
    // Without NORMAL, TANGENT is ignored (glTF); without TANGENT, MikkTSpace makes them, in
    // glTF's handedness: u grows along +x and v along +y here, so the bitangent, up the
    // image (−v), is −y = w·(n × t) with n = +z, t = +x: w = −1.
    let attrs = json!({"POSITION": p, "TEXCOORD_0": uv, "TANGENT": tangent});
    let path = file(&doc, "flat.gltf", json!({"index": 0}), attrs);
    assert_eq!(load(&path).scene.primitives.len(), 1);
    let path = file(&doc, "mikk.gltf", json!({"index": 0}), json!({"POSITION": p, "TEXCOORD_0": uv}));
    let scene = load(&path).scene;
    let tris = triangles(&scene);
    let t = tris[0].tangent.as_deref().expect("MikkTSpace tangents");
    assert!(t.iter().all(|t| (t.truncate() - DVec3::X).length() < 1e-6 && t.w == -1.0), "{t:?}");
}

/// A metallic-roughness map that is nowhere metallic makes no mirror, however metallic the
/// factor; but where a triangle lacks the map's UV set the map counts as 1 there, and the
/// material's bounds (which decide what rays the scene spawns) must say it reflects.
#[test]
fn map_bounds_cover_triangles_without_their_uvs() {
    let dir = TempDir::new();
    image::RgbaImage::from_pixel(1, 1, image::Rgba([0, 0, 0, 255])).save(dir.path("mr.png")).unwrap();
    let mut doc = Doc::new();
    let p = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let uv = doc.vec2(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
    let file = |doc: &Doc, name: &str, attrs: Value| {
        doc.write(
            &dir,
            name,
            json!({
                "images": [{"uri": "mr.png"}],
                "textures": [{"source": 0}],
                "materials": [{"pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 1.0,
                    "metallicRoughnessTexture": {"index": 0}}}],
                "meshes": [{"primitives": [{"attributes": attrs, "material": 0}]}],
                "nodes": [{"mesh": 0}],
                "scenes": [{"nodes": [0]}],
            }),
        )
    };
    let with = load(&file(&doc, "uv.gltf", json!({"POSITION": p, "TEXCOORD_0": uv})));
    let m = &with.scene.materials[0];
    assert!(m.maps.is_some() && !m.reflects() && !with.scene.effects().reflection, "{m:?}");
    let without = load(&file(&doc, "no_uv.gltf", json!({"POSITION": p})));
    let m = &without.scene.materials[0];
    assert!(m.reflects() && without.scene.effects().reflection, "{m:?}");
    assert!(without.warnings.iter().any(|w| w.contains("TEXCOORD_0")), "{:?}", without.warnings);
}

/// KHR_texture_transform on the base colour texture becomes the texture reference's
/// transform: offset · rotation (counter-clockwise, as the extension's matrix turns (1, 0) to
/// (cos, sin)) · scale, reading the TEXCOORD set its `texCoord` names instead of the
/// textureInfo's; no warning says the extension is ignored.
#[test]
fn texture_transforms_move_the_uvs() {
    let dir = TempDir::new();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 255])).save(dir.path("tex.png")).unwrap();
    let mut doc = Doc::new();
    let p = doc.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let uv0 = doc.vec2(&[[9.0, 9.0]; 3]);
    let uv1 = doc.vec2(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
    let rot = std::f64::consts::FRAC_PI_2;
    let path = doc.write(
        &dir,
        "tt.gltf",
        json!({
            "extensionsUsed": ["KHR_texture_transform"],
            "images": [{"uri": "tex.png"}],
            "textures": [{"source": 0}],
            "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 0,
                "extensions": {"KHR_texture_transform": {
                    "offset": [0.5, 0.25], "rotation": rot, "scale": [2.0, 3.0], "texCoord": 1}}}}}],
            "meshes": [{"primitives": [
                {"attributes": {"POSITION": p, "TEXCOORD_0": uv0, "TEXCOORD_1": uv1}, "material": 0},
            ]}],
            "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}],
        }),
    );
    let loaded = load(&path);
    assert!(!loaded.warnings.iter().any(|w| w.contains("KHR_texture_transform")), "{:?}", loaded.warnings);
    let tri = &triangles(&loaded.scene)[0];
    let uv = tri.uv1.as_deref().expect("UVs");
    let r = loaded.scene.materials[0].base_color_texture.unwrap();
    assert_eq!(r.texcoord, 1);
    // (u, v) → scale (2u, 3v) → rotate a quarter turn (−3v, 2u) → offset (0.5 − 3v, 0.25 + 2u).
    let want = [DVec2::new(0.5, 0.25), DVec2::new(0.5, 2.25), DVec2::new(-2.5, 0.25)];
    for (k, want) in want.into_iter().enumerate() {
        let got = r.uv([None, Some(uv[k])]).unwrap();
        assert!((got - want).length() < 1e-6, "{got} for {want}");
    }
}

#[test]
fn spot_and_directional_lights_shine_down_their_nodes_minus_z() {
    let mut doc = Doc::new();
    let mesh = tetrahedron(&mut doc);
    let dir = TempDir::new();
    let q = DQuat::from_rotation_x(-std::f64::consts::FRAC_PI_2); // −Z becomes −Y
    let path = doc.write(
        &dir,
        "lights.gltf",
        json!({
            "extensionsUsed": ["KHR_lights_punctual"],
            "extensions": {"KHR_lights_punctual": {"lights": [
                {"type": "spot", "intensity": 3.0, "range": 20.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
                {"type": "directional", "color": [1.0, 0.5, 0.25], "intensity": 2.0},
            ]}},
            "meshes": [mesh],
            "nodes": [
                {"mesh": 0},
                {"translation": [0.0, 5.0, 0.0], "rotation": [q.x, q.y, q.z, q.w],
                 "extensions": {"KHR_lights_punctual": {"light": 0}}},
                {"extensions": {"KHR_lights_punctual": {"light": 1}}},
            ],
            "scenes": [{"nodes": [0, 1, 2]}],
        }),
    );
    let scene = load(&path).scene;
    assert_eq!(scene.lights.len(), 2);
    let (spot, sun) = (&scene.lights[0], &scene.lights[1]);
    assert!(close(spot.position, DVec3::new(0.0, 5.0, 0.0), 1e-12));
    assert!(close(spot.direction, DVec3::NEG_Y, 1e-12));
    assert_eq!(spot.kind, LightKind::Spot { inner_cone: 0.2f32 as f64, outer_cone: 0.5f32 as f64 });
    assert_eq!((spot.range, spot.inverse_square), (Some(20.0), true));
    assert_eq!(sun.kind, LightKind::Directional);
    assert!(close(sun.direction, DVec3::NEG_Z, 1e-12));
    assert!(!sun.inverse_square);
    assert_eq!(sun.color, DVec3::new(1.0, 0.5, 0.25));
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

// ---------------------------------------------------------------------------------------
// Bad input: each gives an error naming the file and the place, never a panic
// ---------------------------------------------------------------------------------------

/// A valid one-tetrahedron document and its parts, for tests to break.
fn valid_doc() -> (Doc, Value) {
    let mut doc = Doc::new();
    let mesh = tetrahedron(&mut doc);
    let rest = json!({"meshes": [mesh], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0});
    (doc, rest)
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
