//! glTF metallic-roughness materials mapped onto the Whitted material, and the images
//! they need.
//!
//! Only materials that the scene's triangles use are converted, and only the images
//! those materials need are decoded (in parallel): base colour textures become scene
//! textures; metallic-roughness, emissive and transmission textures are reduced to their
//! mean value (the Whitted material has one number for each), with a warning that gives
//! the values. Normal and occlusion maps are never decoded, and a warning says so. The
//! mapping itself is documented in [`crate::scene`].

use std::borrow::Cow;
use std::collections::{BTreeSet, HashMap};

use glam::{DAffine2, DVec2, DVec3};
use gltf::material::AlphaMode;
use gltf::texture::{MagFilter, WrappingMode};
use gltf::Document;
use image::{ImageFormat, RgbaImage};
use rayon::prelude::*;

use super::data::{read_uri, Buffers};
use super::Ctx;
use crate::error::Error;
use crate::scene::{Material, Texture, TextureRef, Wrap};

/// The scene's materials and textures, and how glTF materials map onto them.
pub struct MaterialTable {
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// glTF material index (None: the default material) → scene material index.
    by_gltf: HashMap<Option<usize>, u32>,
    /// Scene material index → the KHR_texture_transform of its base colour texture, which
    /// the loader applies to the UVs of the triangles that use it (the base colour texture
    /// is the only one sampled per hit, so the UVs serve it alone).
    uv_transforms: HashMap<u32, DAffine2>,
}

impl MaterialTable {
    /// The scene material for a glTF material (None: the default material), the TEXCOORD
    /// set its base colour texture reads, if it has one, and the transform its UVs take.
    pub fn lookup(&self, gltf: Option<usize>) -> (u32, Option<u32>, Option<DAffine2>) {
        let i = self.by_gltf[&gltf];
        let set = self.materials[i as usize].base_color_texture.map(|t| t.texcoord);
        (i, set, self.uv_transforms.get(&i).copied())
    }
}

/// Metallic-roughness inputs, after textures have been reduced to their means.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PbrInputs {
    pub base: DVec3,
    pub metallic: f64,
    pub roughness: f64,
    /// KHR_materials_transmission factor.
    pub transmission: f64,
    /// KHR_materials_ior (1.5 when absent).
    pub ior: f64,
    /// emissiveFactor × emissive_strength (× the emissive texture's mean).
    pub emission: DVec3,
}

/// The Whitted material for metallic-roughness inputs, exactly as documented in
/// [`crate::scene`]. Factors are clamped to [0, 1] first.
pub fn whitted(p: &PbrInputs) -> Material {
    let base = p.base.clamp(DVec3::ZERO, DVec3::ONE);
    let m = p.metallic.clamp(0.0, 1.0);
    let rough = p.roughness.clamp(0.0, 1.0);
    let transmittance = p.transmission.clamp(0.0, 1.0) * (1.0 - m);
    let alpha = rough * rough;
    // α = 0 gives +∞, which the clamp turns into the largest exponent.
    let shine = (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 10_000.0);
    let smooth = (1.0 - rough) * (1.0 - rough);
    let mirror = if m > 0.0 {
        smooth * DVec3::splat(0.04).lerp(base, m)
    } else if transmittance > 0.0 {
        smooth * DVec3::splat(((p.ior - 1.0) / (p.ior + 1.0)).powi(2))
    } else {
        DVec3::ZERO
    };
    Material {
        name: None,
        color: base,
        kd: (1.0 - m) * (1.0 - transmittance),
        ks: (1.0 - rough) * (0.04 + 0.96 * m),
        shine,
        mirror,
        transmittance,
        tinted_transmission: true,
        ior: p.ior,
        emission: p.emission.max(DVec3::ZERO),
        base_color_texture: None,
        double_sided: false,
    }
}

/// KHR_texture_transform's UV transform: translation · rotation · scale, the rotation
/// turning UVs counter-clockwise by `rotation` radians (the extension's matrix).
pub fn uv_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> DAffine2 {
    let v = |a: [f32; 2]| DVec2::new(a[0] as f64, a[1] as f64);
    DAffine2::from_scale_angle_translation(v(scale), rotation as f64, v(offset))
}

/// Decodes image `index` (PNG or JPEG, from a file, a data URI or a buffer view) to RGBA8.
fn decode_image(ctx: &Ctx, doc: &Document, buffers: &Buffers, index: usize) -> Result<RgbaImage, Error> {
    let loc = format!("images[{index}]");
    let json = &doc.as_json().images[index];
    let bytes: Cow<[u8]> = match (&json.uri, &json.buffer_view) {
        (Some(uri), _) => read_uri(ctx, uri, &loc)?,
        (None, Some(v)) => {
            let view = doc
                .views()
                .nth(v.value())
                .ok_or_else(|| ctx.err(&loc, format!("bufferViews[{}] does not exist", v.value())))?;
            Cow::Borrowed(buffers.view(ctx, &view, &loc)?)
        }
        (None, None) => return Err(ctx.err(loc, "has neither a uri nor a bufferView")),
    };
    let format = match image::guess_format(&bytes) {
        Ok(f @ (ImageFormat::Png | ImageFormat::Jpeg)) => f,
        Ok(f) => return Err(ctx.err(loc, format!("is {f:?}; only PNG and JPEG images are supported"))),
        Err(_) => return Err(ctx.err(loc, "is neither a PNG nor a JPEG image")),
    };
    let img = image::load_from_memory_with_format(&bytes, format)
        .map_err(|e| ctx.err(&loc, format!("cannot decode the {format:?} image: {e}")))?;
    Ok(img.into_rgba8())
}

/// Mean of one channel, as a linear value in [0, 1].
fn mean_channel(img: &RgbaImage, channel: usize) -> f64 {
    let n = (img.width() as u64 * img.height() as u64).max(1);
    let sum: u64 = img.pixels().map(|p| p.0[channel] as u64).sum();
    sum as f64 / (255.0 * n as f64)
}

/// Mean colour of an sRGB-encoded image, in linear RGB.
fn mean_srgb(img: &RgbaImage) -> DVec3 {
    let lut: Vec<f64> = (0..256)
        .map(|i| {
            let c = i as f64 / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        })
        .collect();
    let n = (img.width() as u64 * img.height() as u64).max(1) as f64;
    let sum = img.pixels().fold(DVec3::ZERO, |s, p| {
        s + DVec3::new(lut[p.0[0] as usize], lut[p.0[1] as usize], lut[p.0[2] as usize])
    });
    sum / n
}

fn wrap(w: WrappingMode) -> Wrap {
    match w {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

/// Converts the used glTF materials (`None`: the default material) into scene materials
/// and textures. Materials keep glTF order; the default material, if used, comes last.
pub fn build(
    ctx: &Ctx,
    doc: &Document,
    buffers: &Buffers,
    used: &BTreeSet<Option<usize>>,
    warnings: &mut Vec<String>,
) -> Result<MaterialTable, Error> {
    let materials: Vec<gltf::Material> = doc.materials().collect();
    let used_gltf: Vec<usize> = used.iter().flatten().copied().collect();
    let source = |info: &gltf::texture::Info| info.texture().source().index();

    // Which images are needed, and decode them all at once.
    let mut needed = BTreeSet::new();
    for &i in &used_gltf {
        let m = &materials[i];
        let pbr = m.pbr_metallic_roughness();
        needed.extend(pbr.base_color_texture().map(|t| source(&t)));
        needed.extend(pbr.metallic_roughness_texture().map(|t| source(&t)));
        if m.emissive_factor().iter().any(|&c| c != 0.0) && m.emissive_strength().unwrap_or(1.0) != 0.0 {
            needed.extend(m.emissive_texture().map(|t| source(&t)));
        }
        if let Some(t) = m.transmission().filter(|t| t.transmission_factor() > 0.0) {
            needed.extend(t.transmission_texture().map(|t| source(&t)));
        }
    }
    let needed: Vec<usize> = needed.into_iter().collect();
    let decoded: Vec<RgbaImage> =
        needed.par_iter().map(|&i| decode_image(ctx, doc, buffers, i)).collect::<Result<_, _>>()?;
    let images: HashMap<usize, RgbaImage> = needed.into_iter().zip(decoded).collect();

    let mut table = MaterialTable {
        materials: Vec::new(),
        textures: Vec::new(),
        by_gltf: HashMap::new(),
        uv_transforms: HashMap::new(),
    };
    let mut texture_ids: HashMap<usize, u32> = HashMap::new();
    // Materials whose normal or occlusion map is not applied (one warning each, at the end).
    let (mut normal_maps, mut occlusion_maps) = (Vec::new(), Vec::new());
    for &i in &used_gltf {
        let m = &materials[i];
        let loc = format!("materials[{i}]");
        let named = format!("{loc}{}", m.name().map(|n| format!(" ({n})")).unwrap_or_default());
        if m.normal_texture().is_some() {
            normal_maps.push(i);
        }
        if m.occlusion_texture().is_some() {
            occlusion_maps.push(i);
        }
        let pbr = m.pbr_metallic_roughness();
        let f3 = |v: [f32; 3]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
        let bc = pbr.base_color_factor();
        let mut inputs = PbrInputs {
            base: f3([bc[0], bc[1], bc[2]]),
            metallic: pbr.metallic_factor() as f64,
            roughness: pbr.roughness_factor() as f64,
            transmission: m.transmission().map_or(0.0, |t| t.transmission_factor() as f64),
            ior: m.ior().map_or(1.5, f64::from),
            emission: f3(m.emissive_factor()) * m.emissive_strength().map_or(1.0, f64::from),
        };
        // Textures the Whitted material cannot sample contribute their mean, and say so: a
        // mostly metallic map, say, makes a dark mirror of the whole surface.
        let mut averaged = Vec::new();
        if let Some(img) = pbr.metallic_roughness_texture().and_then(|t| images.get(&source(&t))) {
            inputs.metallic *= mean_channel(img, 2);
            inputs.roughness *= mean_channel(img, 1);
            averaged.push(format!(
                "metallicRoughnessTexture (metallic {:.2}, roughness {:.2})",
                inputs.metallic, inputs.roughness
            ));
        }
        if let Some(img) = m.emissive_texture().and_then(|t| images.get(&source(&t))) {
            inputs.emission *= mean_srgb(img);
            let e = inputs.emission;
            averaged.push(format!("emissiveTexture (emission {:.3}, {:.3}, {:.3})", e.x, e.y, e.z));
        }
        if let Some(img) =
            m.transmission().and_then(|t| t.transmission_texture()).and_then(|t| images.get(&source(&t)))
        {
            inputs.transmission *= mean_channel(img, 0);
            averaged.push(format!("transmissionTexture (transmission {:.2})", inputs.transmission));
        }
        if !averaged.is_empty() {
            warnings.push(format!(
                "{named}: applied as the mean over the texture, not per hit (only base colour textures \
                 are sampled): {}",
                averaged.join(", ")
            ));
        }
        if inputs.ior.is_nan() || inputs.ior < 1.0 {
            return Err(ctx.err(loc, format!("KHR_materials_ior: ior {} is not at least 1", inputs.ior)));
        }
        let mut mat = whitted(&inputs);
        mat.name = m.name().map(String::from);
        mat.double_sided = m.double_sided();
        if let Some(info) = pbr.base_color_texture() {
            let texture = info.texture();
            let id = match texture_ids.get(&texture.index()) {
                Some(&id) => id,
                None => {
                    let img = &images[&source(&info)];
                    let sampler = texture.sampler();
                    table.textures.push(Texture {
                        name: texture.name().or(texture.source().name()).map(String::from),
                        width: img.width(),
                        height: img.height(),
                        texels: img.pixels().map(|p| p.0).collect(),
                        wrap_s: wrap(sampler.wrap_s()),
                        wrap_t: wrap(sampler.wrap_t()),
                        linear: sampler.mag_filter() != Some(MagFilter::Nearest),
                    });
                    let id = (table.textures.len() - 1) as u32;
                    texture_ids.insert(texture.index(), id);
                    id
                }
            };
            let transform = info.texture_transform();
            let texcoord = transform.as_ref().and_then(|t| t.tex_coord()).unwrap_or(info.tex_coord());
            mat.base_color_texture = Some(TextureRef { texture: id, texcoord });
            if let Some(t) = transform {
                let m = uv_transform(t.offset(), t.rotation(), t.scale());
                if !m.is_finite() {
                    let loc = format!(
                        "{loc}.pbrMetallicRoughness.baseColorTexture.extensions.KHR_texture_transform"
                    );
                    return Err(ctx.err(loc, "offset, rotation and scale must be finite"));
                }
                table.uv_transforms.insert(table.materials.len() as u32, m);
            }
        }
        mat.validate(table.textures.len()).map_err(|e| ctx.err(&loc, e.into_message()))?;
        match m.alpha_mode() {
            AlphaMode::Opaque => {}
            mode => warnings.push(format!("{named}: alphaMode {mode:?} is ignored; the surface is opaque")),
        }
        table.by_gltf.insert(Some(i), table.materials.len() as u32);
        table.materials.push(mat);
    }
    let list = |v: &[usize]| v.iter().map(|i| format!("materials[{i}]")).collect::<Vec<_>>().join(", ");
    if !normal_maps.is_empty() {
        warnings.push(format!(
            "{}: normal maps are not applied; shading uses the interpolated vertex normals",
            list(&normal_maps)
        ));
    }
    if !occlusion_maps.is_empty() {
        warnings.push(format!("{}: occlusion maps are not applied", list(&occlusion_maps)));
    }
    if used.contains(&None) {
        table.by_gltf.insert(None, table.materials.len() as u32);
        table.materials.push(Material { name: Some("default".into()), ..Material::default() });
    }
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs() -> PbrInputs {
        PbrInputs {
            base: DVec3::new(0.8, 0.5, 0.2),
            metallic: 0.0,
            roughness: 1.0,
            transmission: 0.0,
            ior: 1.5,
            emission: DVec3::ZERO,
        }
    }

    #[test]
    fn rough_dielectric_is_matte() {
        let m = whitted(&inputs());
        assert_eq!((m.kd, m.ks, m.shine, m.mirror), (1.0, 0.0, 1.0, DVec3::ZERO));
        assert_eq!(m.color, DVec3::new(0.8, 0.5, 0.2));
    }

    #[test]
    fn smooth_metal_mirrors_its_base_colour() {
        let m = whitted(&PbrInputs { metallic: 1.0, roughness: 0.0, ..inputs() });
        assert_eq!(m.kd, 0.0);
        assert_eq!(m.ks, 1.0);
        assert_eq!(m.shine, 10_000.0);
        assert!((m.mirror - DVec3::new(0.8, 0.5, 0.2)).length() < 1e-12);
    }

    #[test]
    fn glass_transmits_with_fresnel_mirror() {
        let m = whitted(&PbrInputs { transmission: 1.0, roughness: 0.0, ..inputs() });
        assert_eq!((m.transmittance, m.kd), (1.0, 0.0));
        assert!((m.mirror.x - 0.04).abs() < 1e-12, "{}", m.mirror);
        // Half rough: α = 0.25, shine = 2/α² − 2 = 30, ks = 0.5·0.04.
        let m = whitted(&PbrInputs { roughness: 0.5, ..inputs() });
        assert!((m.shine - 30.0).abs() < 1e-9 && (m.ks - 0.02).abs() < 1e-12);
    }

    #[test]
    fn srgb_mean_is_linear() {
        let img = RgbaImage::from_pixel(2, 2, image::Rgba([255, 0, 188, 255]));
        let m = mean_srgb(&img);
        assert!((m.x - 1.0).abs() < 1e-12 && m.y == 0.0 && (m.z - 0.5).abs() < 0.01, "{m}");
        assert!((mean_channel(&img, 2) - 188.0 / 255.0).abs() < 1e-12);
    }
}
