//! The glTF sample models on the GPU against the CPU, set up as `render` sets them up, with
//! every map applied.

use cuberay::job::RenderOptions;
use cuberay::load;

use super::agree;

/// A glTF sample model agrees with the CPU and exercises `effect`.
fn gltf_model_agrees_with_the_cpu(file: &str, effect: &str) {
    let path = crate::common::shared(&format!("gltf/{file}"));
    let mut loaded = load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}"));
    // As `cuberay render` sets it up: a model without lights in the studio environment.
    load::apply_setup(&mut loaded, &path, &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}"));
    let studio = loaded.scene.environment.is_some();
    assert_eq!(studio, loaded.scene.file_lights().count() == 0, "{file}");
    // Every map is applied: no warning says one is averaged or ignored.
    for w in &loaded.warnings {
        let dropped = ["mean", "normal maps", "alphaMode", "not applied"].iter().any(|k| w.contains(k));
        assert!(!dropped || w.contains("occlusion maps are not applied"), "{file}: {w}");
    }
    let opts = RenderOptions { spp: 4, ..RenderOptions::new(64, 64) };
    let (g, _) = agree(file, &loaded.scene, &opts, 0.01);
    // The textures' memory on the device is stated: every texel of every scene texture and of
    // the environment map.
    let env_texels = loaded.scene.environment.as_ref().map_or(0, |e| e.texels.len());
    let texels: usize = loaded.scene.textures.iter().map(|t| t.texels.len()).sum::<usize>() + env_texels;
    assert_eq!(g.stats.texture_bytes, 4 * texels as u64, "{file}");
    if g.stats.texture_bytes > 0 {
        assert!(g.stats.to_text().contains("MiB on the device"), "{file}");
    }
    assert!(g.stats.effects.contains(&effect), "{file}: {:?}", g.stats.effects);
    assert_eq!(g.stats.effects.contains(&"environment"), studio, "{file}");
    assert!(g.stats.rays.eye_hit > 0, "{file}: nothing hit");
}

// glTF sample models: textures, emission, punctual lights, transmission, smooth normals.
cases!(gltf_models_agree_with_the_cpu: super::gltf_model_agrees_with_the_cpu {
    avocado_normal_maps => ("Avocado/Avocado.gltf", "normal_maps"),
    damaged_helmet_maps => ("DamagedHelmet/DamagedHelmet.gltf", "maps"),
    flight_helmet_blend => ("FlightHelmet/FlightHelmet.gltf", "blend"),
    metal_rough_spheres => ("MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf", "reflection"),
    box_shadows => ("Box/Box.gltf", "shadows"),
    box_textured => ("BoxTextured/BoxTextured.gltf", "textures"),
    cornell_box_emission => ("CornellBox/CornellBox.glb", "emission"),
    lights_punctual_lamp_refraction => ("LightsPunctualLamp/LightsPunctualLamp.gltf", "refraction"),
    cameras => ("Cameras/Cameras.gltf", "shadows"),
    suzanne => ("Suzanne/Suzanne.gltf", "shadows"),
    toy_car_clearcoat_and_tinted_glass => ("ToyCar/ToyCar.gltf", "clearcoat"),
});
