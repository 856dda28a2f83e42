//! glTF materials and their maps: the sample models' textures (BoxTextured, DamagedHelmet),
//! the texture coordinate sets a texture reads, normal maps and tangents, the bounds of a
//! metallic-roughness map, KHR_texture_transform.

use glam::{DVec2, DVec3};
use serde_json::{json, Value};

use super::{assert_error, load, load_err, model, triangles, Doc, TempDir};

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

/// KHR_materials_unlit: the base colour is emitted as is, with no light, specular, mirror or
/// transmission, so every pixel that sees the surface shows the base colour exactly, on both
/// backends (before the tone map, which a PNG then applies to it as to any radiance).
#[test]
fn unlit_shows_its_base_colour() {
    let dir = TempDir::new();
    let mut doc = Doc::new();
    let mesh = super::tetrahedron(&mut doc);
    let base = [0.2f32, 0.5, 0.8];
    let material = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0], "metallicFactor": 0.0},
        "extensions": {"KHR_materials_unlit": {}}
    });
    let mut mesh: Value = mesh;
    mesh["primitives"][0]["material"] = json!(0);
    let rest = json!({"meshes": [mesh], "materials": [material], "nodes": [{"mesh": 0}],
                      "scenes": [{"nodes": [0]}], "scene": 0, "extensionsUsed": ["KHR_materials_unlit"]});
    let path = doc.write(&dir, "unlit.gltf", rest);
    let loaded = load(&path);
    assert!(!loaded.warnings.iter().any(|w| w.contains("KHR_materials_unlit")), "{:?}", loaded.warnings);
    let scene = loaded.scene;
    let m = &scene.materials[0];
    let want = DVec3::new(base[0] as f64, base[1] as f64, base[2] as f64);
    assert_eq!((m.kd, m.ks, m.mirror, m.transmittance), (0.0, 0.0, DVec3::ZERO, 0.0), "{m:?}");
    assert_eq!(m.emission, want);
    let opts = cuberay::job::RenderOptions::new(16, 16);
    let hidden = indicatif::ProgressBar::hidden();
    let gpu = crate::common::renderer().render(&scene, &opts, &hidden).unwrap();
    let cpu = cuberay::reference::render(&scene, &opts, &hidden).unwrap();
    for (name, image) in [("gpu", &gpu.image), ("cpu", &cpu.image)] {
        let centre = image.pixels[8 * 16 + 8];
        for k in 0..3 {
            assert!(
                (centre[k] as f64 - want[k]).abs() < 1e-6,
                "{name}: the centre shows {centre:?}, not {want}"
            );
        }
    }
}
