//! glTF cameras and lights: the sample models' cameras (Cameras, and ToyCar's with its
//! extensions' warnings) and punctual lights (LightsPunctualLamp), the default light and the
//! automatic camera (CornellBox), spot and directional lights on a file written here.

use glam::{DQuat, DVec3};
use serde_json::json;

use cuberay::load::LoadOptions;
use cuberay::scene::{LightKind, LightSource, Projection};

use super::{close, load, load_with, model, tetrahedron, Doc, TempDir};

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
    // Sheen is ignored, said once; the clear coat is applied, so not warned.
    let said = |ext: &str| loaded.warnings.iter().filter(|w| w.contains(ext)).count();
    assert_eq!(said("KHR_materials_sheen"), 1, "{:?}", loaded.warnings);
    assert_eq!(said("KHR_materials_clearcoat"), 0, "{:?}", loaded.warnings);
    assert!(loaded.scene.materials.iter().any(|m| m.clearcoat.is_some()));
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
