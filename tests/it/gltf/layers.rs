//! The material extensions a Whitted tracer can follow, each against its closed form on both
//! backends: KHR_materials_volume (Beer–Lambert inside a body), KHR_materials_clearcoat
//! (Schlick's Fresnel at IOR 1.5), KHR_materials_specular (the dielectric F0), and their
//! textures on the GPU against the CPU.

use glam::DVec3;
use serde_json::{json, Value};

use cuberay::job::RenderOptions;
use cuberay::scene::{coat_fresnel, Scene};

use super::{load, Doc, TempDir};

/// A square of half-size 2 in the plane z = `z`, facing +z (`front`) or −z, with UVs.
fn square(doc: &mut Doc, z: f32, front: bool) -> Value {
    let mut pos = [[-2.0f32, -2.0, z], [2.0, -2.0, z], [2.0, 2.0, z], [-2.0, 2.0, z]];
    let mut uv = [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    if !front {
        pos.swap(1, 3);
        uv.swap(1, 3);
    }
    let n = if front { 1.0 } else { -1.0 };
    let p = doc.vec3(&pos);
    let nrm = doc.vec3(&[[0.0, 0.0, n]; 4]);
    let t = doc.vec2(&uv);
    let i = doc.indices(&[0, 1, 2, 0, 2, 3]);
    json!({"attributes": {"POSITION": p, "NORMAL": nrm, "TEXCOORD_0": t}, "indices": i, "material": 0})
}

/// Loads `primitives` with `material`, seen by a camera 5 away from the origin whose view
/// makes `angle` (radians) with −z, tilted about x; a white background and no environment.
fn scene_of(
    doc: &Doc,
    dir: &TempDir,
    primitives: Vec<Value>,
    material: Value,
    extra: Value,
    angle: f64,
) -> Scene {
    let (s, c) = angle.sin_cos();
    let half = -angle / 2.0;
    let mut rest = json!({
        "meshes": [{"primitives": primitives}],
        "materials": [material],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.2, "znear": 0.01}}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.0, 5.0 * s, 5.0 * c],
                   "rotation": [half.sin(), 0.0, 0.0, half.cos()]}],
        "scenes": [{"nodes": [0, 1]}],
        "scene": 0,
    });
    for (k, v) in extra.as_object().unwrap() {
        rest[k] = v.clone();
    }
    let mut scene = load(&doc.write(dir, "layers.gltf", rest)).scene;
    scene.set_environment(None, 0);
    scene.background = DVec3::ONE;
    scene
}

/// The centre pixel (of an odd-sized image, so its ray is the view direction) on the GPU and
/// on the CPU.
fn centre(scene: &Scene) -> [(&'static str, DVec3); 2] {
    let opts = RenderOptions::new(17, 17);
    let hidden = indicatif::ProgressBar::hidden();
    let gpu = crate::common::renderer().render(scene, &opts, &hidden).unwrap();
    let cpu = cuberay::reference::render(scene, &opts, &hidden).unwrap();
    let at = |p: [f32; 4]| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
    [("gpu", at(gpu.image.pixels[8 * 17 + 8])), ("cpu", at(cpu.image.pixels[8 * 17 + 8]))]
}

/// A slab of thickness t of a body with attenuation distance d and colour c transmits
/// c^(t/d) of each channel: exp(−t/d) where c = 1/e. Straight through (ior 1, rough, so no
/// mirror), a white background behind it. A thin wall (thickness 0) attenuates nothing.
#[test]
fn a_slab_transmits_beer_lambert() {
    let dir = TempDir::new();
    let (t, d) = (0.5f64, 0.25f64);
    // Per channel: 1/e, e^−1/2, e^−1/4, so exp(−t/d), exp(−t/2d), exp(−t/4d).
    let color = [(-1.0f64).exp(), (-0.5f64).exp(), (-0.25f64).exp()];
    for thickness in [1.0, 0.0] {
        let mut doc = Doc::new();
        let prims =
            vec![square(&mut doc, (t / 2.0) as f32, true), square(&mut doc, (-t / 2.0) as f32, false)];
        let material = json!({
            "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0,
                                     "roughnessFactor": 1.0},
            "extensions": {
                "KHR_materials_transmission": {"transmissionFactor": 1.0},
                "KHR_materials_ior": {"ior": 1.0},
                "KHR_materials_volume": {"thicknessFactor": thickness, "attenuationDistance": d,
                                         "attenuationColor": color}
            }
        });
        let used = json!({"extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior",
                                             "KHR_materials_volume"]});
        let scene = scene_of(&doc, &dir, prims, material, used, 0.0);
        assert_eq!(scene.effects().volume, thickness > 0.0, "{:?}", scene.effects());
        let want = if thickness > 0.0 {
            DVec3::new((-t / d).exp(), (-t / (2.0 * d)).exp(), (-t / (4.0 * d)).exp())
        } else {
            DVec3::ONE
        };
        for (name, got) in centre(&scene) {
            for k in 0..3 {
                assert!(
                    (got[k] / want[k] - 1.0).abs() < 0.01,
                    "{name}, thickness {thickness}: channel {k} is {}, not {}",
                    got[k],
                    want[k]
                );
            }
        }
    }
}

/// A clear coat of factor 1 over a black base reflects the background with Schlick's
/// Fresnel at IOR 1.5, at normal and grazing views alike.
#[test]
fn a_clearcoat_on_black_reflects_with_schlick_fresnel() {
    let dir = TempDir::new();
    for degrees in [0.0f64, 45.0, 70.0] {
        let angle = degrees.to_radians();
        let mut doc = Doc::new();
        let prims = vec![square(&mut doc, 0.0, true)];
        let material = json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0,
                                     "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.0}}
        });
        let used = json!({"extensionsUsed": ["KHR_materials_clearcoat"]});
        let scene = scene_of(&doc, &dir, prims, material, used, angle);
        assert!(scene.effects().clearcoat && scene.effects().reflection, "{:?}", scene.effects());
        let want = coat_fresnel(angle.cos());
        let schlick = 0.04 + 0.96 * (1.0 - angle.cos()).powi(5);
        assert!((want - schlick).abs() < 1e-12);
        for (name, got) in centre(&scene) {
            for k in 0..3 {
                assert!(
                    (got[k] / want - 1.0).abs() < 0.01,
                    "{name} at {degrees}°: channel {k} is {}, not {want}",
                    got[k]
                );
            }
        }
    }
}

/// KHR_materials_specular scales and tints the dielectric F0: smooth glass of specular 0.5
/// and colour (1, 0.5, 0) mirrors min(0.04·colour, 1)·0.5; a rough plastic of specular 0 has
/// no highlight; without the extension nothing changes.
#[test]
fn specular_scales_and_tints_the_dielectric_reflectance() {
    let dir = TempDir::new();
    let mut doc = Doc::new();
    let prims = vec![square(&mut doc, 0.0, true)];
    let glass = json!({
        "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                       "KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [1.0, 0.5, 0.0]}}
    });
    let used = json!({"extensionsUsed": ["KHR_materials_transmission", "KHR_materials_specular"]});
    let scene = scene_of(&doc, &dir, prims.clone(), glass, used.clone(), 0.0);
    let m = &scene.materials[0];
    assert!((m.mirror - DVec3::new(0.02, 0.01, 0.0)).length() < 1e-9, "{}", m.mirror);
    let plastic = |spec: Option<f64>| {
        let mut mat = json!({"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.5}});
        if let Some(s) = spec {
            mat["extensions"] = json!({"KHR_materials_specular": {"specularFactor": s}});
        }
        scene_of(&doc, &dir, prims.clone(), mat, used.clone(), 0.0).materials[0].ks
    };
    assert_eq!(plastic(Some(0.0)), 0.0);
    assert!((plastic(None) - 0.5 * 0.04).abs() < 1e-12);
}

/// The coat's and the specular extension's textures, and a coat normal map, evaluated per hit
/// on the GPU as on the CPU.
#[test]
fn layer_textures_agree_with_the_cpu() {
    let dir = TempDir::new();
    // A 4×4 texture whose channels vary over the square.
    let img = image::RgbaImage::from_fn(4, 4, |x, y| {
        image::Rgba([(x * 80) as u8, (y * 80) as u8, ((x + y) * 40) as u8, (255 - x * 60) as u8])
    });
    img.save(dir.path("layers.png")).unwrap();
    let mut doc = Doc::new();
    let mut prim = square(&mut doc, 0.0, true);
    let tangents = doc.vec4(&[[1.0, 0.0, 0.0, 1.0]; 4]);
    prim["attributes"]["TANGENT"] = json!(tangents);
    let tex = json!({"index": 0});
    let material = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.3, 0.2, 1.0], "metallicFactor": 0.3,
                                 "roughnessFactor": 0.4, "metallicRoughnessTexture": tex},
        "extensions": {
            "KHR_materials_clearcoat": {"clearcoatFactor": 0.9, "clearcoatTexture": tex,
                                        "clearcoatRoughnessFactor": 0.5, "clearcoatRoughnessTexture": tex,
                                        "clearcoatNormalTexture": {"index": 0, "scale": 0.5}},
            "KHR_materials_specular": {"specularFactor": 0.8, "specularTexture": tex,
                                       "specularColorFactor": [1.0, 0.8, 0.6], "specularColorTexture": tex}
        }
    });
    let extra = json!({
        "images": [{"uri": "layers.png"}],
        "textures": [{"source": 0}],
        "extensionsUsed": ["KHR_materials_clearcoat", "KHR_materials_specular"],
    });
    let mut scene = scene_of(&doc, &dir, vec![prim], material, extra, 0.6);
    // Lit by the headlight, besides the background the coat reflects.
    scene.background = DVec3::new(0.8, 0.9, 1.0);
    let e = scene.effects();
    assert!(e.clearcoat && e.maps && e.normal_maps && e.textures, "{e:?}");
    let opts = RenderOptions::new(48, 48);
    let (gpu, _) = crate::gpu::agree("layer textures", &scene, &opts, 0.01);
    // The maps vary the image, and the coat is in it.
    let lum = |p: &[f32; 4]| (p[0] + p[1] + p[2]) as f64;
    let (lo, hi) =
        gpu.image.pixels.iter().map(lum).fold((f64::MAX, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    assert!(hi - lo > 0.1, "the image is flat: {lo}..{hi}");
    let mut bare = scene.clone();
    bare.materials[0].clearcoat = None;
    let hidden = indicatif::ProgressBar::hidden();
    let without = cuberay::reference::render(&bare, &opts, &hidden).unwrap();
    let moved =
        gpu.image.pixels.iter().zip(&without.image.pixels).filter(|(a, b)| (lum(a) - lum(b)).abs() > 0.01);
    assert!(moved.count() > 48 * 48 / 4, "the coat changes too few pixels");
}

/// Bad layer inputs are refused with the file and the JSON path: a coat factor out of range,
/// a coat texture that does not exist, a volume whose attenuation distance is not positive.
#[test]
fn bad_layers_are_refused_with_their_json_path() {
    let dir = TempDir::new();
    let cases = [
        (
            json!({"KHR_materials_clearcoat": {"clearcoatFactor": 2.0}}),
            vec!["KHR_materials_clearcoat.clearcoatFactor", "[0, 1]"],
        ),
        (
            json!({"KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatTexture": {"index": 9}}}),
            vec!["KHR_materials_clearcoat.clearcoatTexture", "textures[9] does not exist"],
        ),
        (json!({"KHR_materials_clearcoat": [1, 2]}), vec!["KHR_materials_clearcoat", "is not an object"]),
        (
            json!({"KHR_materials_transmission": {"transmissionFactor": 1.0},
                   "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationDistance": -1.0}}),
            vec!["attenuationDistance"],
        ),
    ];
    for (i, (extensions, fragments)) in cases.into_iter().enumerate() {
        let mut doc = Doc::new();
        let prims = vec![square(&mut doc, 0.0, true)];
        let rest = json!({
            "meshes": [{"primitives": prims}],
            "materials": [{"extensions": extensions}],
            "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}],
        });
        let path = doc.write(&dir, &format!("bad{i}.gltf"), rest);
        super::assert_error(&super::load_err(&path), &path, &fragments);
    }
}
