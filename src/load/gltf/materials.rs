//! glTF metallic-roughness materials mapped onto the Whitted material, and the images
//! they need.
//!
//! Only materials that the scene's triangles use are converted, and only the images
//! those materials need are decoded (in parallel). Base colour, metallic-roughness,
//! emissive, transmission and normal textures become scene textures, sampled per hit with
//! their own texCoord set and KHR_texture_transform; a material with metallic-roughness,
//! emissive or transmission textures keeps its factors and textures ([`PbrMaps`]) and its
//! scalar Whitted terms become bounds over the maps (their largest values). Occlusion maps
//! are never decoded (glTF has no ambient light for them to darken), and a warning says so.
//! The mapping itself is documented in [`crate::scene`].

use std::borrow::Cow;
use std::collections::{BTreeSet, HashMap};

use glam::{DAffine2, DVec2, DVec3};
use gltf::material::AlphaMode;
use gltf::texture::{MagFilter, WrappingMode};
use gltf::Document;
use image::{ImageFormat, RgbaImage};
use rayon::prelude::*;
use serde::Deserialize;

use super::data::{read_uri, Buffers};
use super::layers;
use super::Ctx;
use crate::error::Error;
use crate::scene::{
    srgb_to_linear, Alpha, Clearcoat, MapRanges, Material, NormalMap, PbrMaps, Primitive, Texture,
    TextureRef, Wrap, TEXCOORD_SETS,
};

/// The scene's materials and textures, and how glTF materials map onto them.
pub struct MaterialTable {
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// glTF material index (None: the default material) → scene material index.
    by_gltf: HashMap<Option<usize>, u32>,
}

/// What a primitive of a material must carry for its textures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Needs {
    /// TEXCOORD_0 and TEXCOORD_1.
    pub uv: [bool; 2],
    /// Tangents, in the UV set of the normal map.
    pub tangents: Option<u32>,
}

impl MaterialTable {
    /// The scene material for a glTF material (None: the default material) and what its
    /// primitives must carry for its textures.
    pub fn lookup(&self, gltf: Option<usize>) -> (u32, Needs) {
        let i = self.by_gltf[&gltf];
        let m = &self.materials[i as usize];
        let mut needs = Needs::default();
        for t in m.texture_refs() {
            needs.uv[t.texcoord as usize] = true;
        }
        // The base's normal map, else the coat's, names the UV set of generated tangents.
        let coat_normal = m.clearcoat.as_ref().and_then(|c| c.normal_map);
        needs.tangents = m.normal_map.or(coat_normal).map(|n| n.texture.texcoord);
        (i, needs)
    }
}

/// KHR_texture_transform's UV transform: translation · rotation · scale, the rotation
/// turning UVs counter-clockwise by `rotation` radians (the extension's matrix).
pub fn uv_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> DAffine2 {
    let v = |a: [f32; 2]| DVec2::new(a[0] as f64, a[1] as f64);
    DAffine2::from_scale_angle_translation(v(scale), rotation as f64, v(offset))
}

/// Decodes image `index` (PNG, JPEG or WebP, from a file, a data URI or a buffer view) to
/// RGBA8.
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
        Ok(f @ (ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::WebP)) => f,
        Ok(f) => return Err(ctx.err(loc, format!("is {f:?}; only PNG, JPEG and WebP images are supported"))),
        Err(_) => return Err(ctx.err(loc, "is neither a PNG nor a JPEG nor a WebP image")),
    };
    let img = image::load_from_memory_with_format(&bytes, format)
        .map_err(|e| ctx.err(&loc, format!("cannot decode the {format:?} image: {e}")))?;
    Ok(img.into_rgba8())
}

/// The smallest and largest 8-bit value of one channel of a texture.
fn channel_extremes(t: &Texture, channel: usize) -> (u8, u8) {
    t.texels.iter().fold((255u8, 0u8), |(lo, hi), p| (lo.min(p[channel]), hi.max(p[channel])))
}

/// The smallest and largest value of one channel of a data texture, in [0, 1].
fn channel_range(t: &Texture, channel: usize) -> (f64, f64) {
    let (lo, hi) = channel_extremes(t, channel);
    (lo as f64 / 255.0, hi as f64 / 255.0)
}

/// The largest linear value of each colour channel of an sRGB-encoded texture.
fn max_srgb(t: &Texture) -> DVec3 {
    let hi = |c: usize| srgb_to_linear(channel_extremes(t, c).1);
    DVec3::new(hi(0), hi(1), hi(2))
}

fn wrap(w: WrappingMode) -> Wrap {
    match w {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

/// KHR_texture_transform as written: offset, rotation, scale and the texCoord it overrides.
#[derive(serde::Deserialize)]
#[serde(default, rename_all = "camelCase")]
struct Xform {
    offset: [f32; 2],
    rotation: f32,
    scale: [f32; 2],
    tex_coord: Option<u32>,
}

impl Default for Xform {
    fn default() -> Xform {
        Xform { offset: [0.0; 2], rotation: 0.0, scale: [1.0; 2], tex_coord: None }
    }
}

/// One texture slot of a material, read from its glTF `textureInfo`.
struct Slot<'d> {
    info: gltf::Texture<'d>,
    tex_coord: u32,
    transform: Option<Xform>,
    /// JSON path of the textureInfo, for messages.
    loc: String,
    srgb: bool,
}

impl<'d> Slot<'d> {
    fn of(info: gltf::texture::Info<'d>, loc: String, srgb: bool) -> Slot<'d> {
        let transform = info.texture_transform().map(|t| Xform {
            offset: t.offset(),
            rotation: t.rotation(),
            scale: t.scale(),
            tex_coord: t.tex_coord(),
        });
        Slot { tex_coord: info.tex_coord(), transform, info: info.texture(), loc, srgb }
    }

    /// The normal map's slot (gltf's `NormalTexture` has no transform accessor: the
    /// extension is read from its JSON).
    fn normal(n: &gltf::material::NormalTexture<'d>, loc: String) -> Result<Slot<'d>, String> {
        let transform = match n.extension_value("KHR_texture_transform") {
            None => None,
            Some(v) => Some(Xform::deserialize(v).map_err(|e| {
                format!("is not offset and scale (two numbers each), rotation (a number) and texCoord (a set index): {e}")
            })?),
        };
        Ok(Slot { tex_coord: n.tex_coord(), transform, info: n.texture(), loc, srgb: false })
    }

    /// A slot read from a textureInfo's JSON (for extensions the gltf crate does not parse).
    fn json(doc: &'d Document, v: &serde_json::Value, loc: String, srgb: bool) -> Result<Slot<'d>, String> {
        #[derive(Deserialize)]
        #[serde(rename_all = "camelCase")]
        struct Info {
            index: usize,
            #[serde(default)]
            tex_coord: u32,
            #[serde(default)]
            extensions: Option<Extensions>,
        }
        #[derive(Deserialize)]
        struct Extensions {
            #[serde(rename = "KHR_texture_transform")]
            transform: Option<Xform>,
        }
        let info = Info::deserialize(v).map_err(|e| format!("is not a textureInfo: {e}"))?;
        let texture = doc
            .textures()
            .nth(info.index)
            .ok_or_else(|| format!("index: textures[{}] does not exist", info.index))?;
        let transform = info.extensions.and_then(|e| e.transform);
        Ok(Slot { info: texture, tex_coord: info.tex_coord, transform, loc, srgb })
    }

    fn image(&self) -> usize {
        self.info.source().index()
    }
}

/// Builds scene textures for slots, each glTF texture once per colour space.
struct Textures<'a> {
    images: &'a HashMap<usize, RgbaImage>,
    out: Vec<Texture>,
    ids: HashMap<(usize, bool), u32>,
}

impl Textures<'_> {
    /// The scene texture reference of `slot`, or `None` (with a warning) where it reads a
    /// texture coordinate set beyond the two supported.
    fn add(
        &mut self,
        ctx: &Ctx,
        slot: &Slot,
        warnings: &mut Vec<String>,
    ) -> Result<Option<TextureRef>, Error> {
        let texcoord = slot.transform.as_ref().and_then(|t| t.tex_coord).unwrap_or(slot.tex_coord);
        if texcoord >= TEXCOORD_SETS {
            warnings.push(format!(
                "{}: reads TEXCOORD_{texcoord}; only TEXCOORD_0 and TEXCOORD_1 are read, so the texture is not applied",
                slot.loc
            ));
            return Ok(None);
        }
        let transform = match &slot.transform {
            None => DAffine2::IDENTITY,
            Some(t) => {
                let m = uv_transform(t.offset, t.rotation, t.scale);
                if !m.is_finite() {
                    let loc = format!("{}.extensions.KHR_texture_transform", slot.loc);
                    return Err(ctx.err(loc, "offset, rotation and scale must be finite"));
                }
                m
            }
        };
        let key = (slot.info.index(), slot.srgb);
        let texture = match self.ids.get(&key) {
            Some(&id) => id,
            None => {
                let img = &self.images[&slot.image()];
                let sampler = slot.info.sampler();
                self.out.push(Texture {
                    name: slot.info.name().or(slot.info.source().name()).map(String::from),
                    width: img.width(),
                    height: img.height(),
                    texels: img.pixels().map(|p| p.0).collect(),
                    wrap_s: wrap(sampler.wrap_s()),
                    wrap_t: wrap(sampler.wrap_t()),
                    linear: sampler.mag_filter() != Some(MagFilter::Nearest),
                    srgb: slot.srgb,
                });
                let id = (self.out.len() - 1) as u32;
                self.ids.insert(key, id);
                id
            }
        };
        Ok(Some(TextureRef { texture, texcoord, transform }))
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

    // Every texture slot of every used material; then the images they need, decoded at once.
    let mut slots: Vec<MaterialSlots> = Vec::new();
    for &i in &used_gltf {
        slots.push(slots_of(ctx, doc, &materials[i], i)?);
    }
    let needed: BTreeSet<usize> = slots.iter().flat_map(|s| s.all().map(Slot::image)).collect();
    let needed: Vec<usize> = needed.into_iter().collect();
    let decoded: Vec<RgbaImage> =
        needed.par_iter().map(|&i| decode_image(ctx, doc, buffers, i)).collect::<Result<_, _>>()?;
    let images: HashMap<usize, RgbaImage> = needed.into_iter().zip(decoded).collect();

    let mut table = MaterialTable { materials: Vec::new(), textures: Vec::new(), by_gltf: HashMap::new() };
    let mut textures = Textures { images: &images, out: Vec::new(), ids: HashMap::new() };
    // Materials whose occlusion map is not applied (one warning for all, at the end).
    let mut occlusion_maps = Vec::new();
    for (&i, slots) in used_gltf.iter().zip(&slots) {
        let m = &materials[i];
        if m.occlusion_texture().is_some() {
            occlusion_maps.push(i);
        }
        let mat = material(ctx, m, i, slots, &mut textures, warnings)?;
        mat.validate(textures.out.len()).map_err(|e| ctx.err(format!("materials[{i}]"), e.into_message()))?;
        table.by_gltf.insert(Some(i), table.materials.len() as u32);
        table.materials.push(mat);
    }
    table.textures = textures.out;
    if !occlusion_maps.is_empty() {
        let list = occlusion_maps.iter().map(|i| format!("materials[{i}]")).collect::<Vec<_>>().join(", ");
        warnings.push(format!(
            "{list}: occlusion maps are not applied (glTF has no ambient light for them to darken)"
        ));
    }
    if used.contains(&None) {
        table.by_gltf.insert(None, table.materials.len() as u32);
        table.materials.push(Material { name: Some("default".into()), ..Material::default() });
    }
    Ok(table)
}

/// The texture slots of glTF material `m` (`materials[i]`): the maps it reads, before any
/// image is decoded.
fn slots_of<'d>(
    ctx: &Ctx,
    doc: &'d Document,
    m: &gltf::Material<'d>,
    i: usize,
) -> Result<MaterialSlots<'d>, Error> {
    let loc = format!("materials[{i}]");
    let pbr = m.pbr_metallic_roughness();
    let emits = m.emissive_factor().iter().any(|&c| c != 0.0) && m.emissive_strength().unwrap_or(1.0) != 0.0;
    let transmission = m.transmission().filter(|t| t.transmission_factor() > 0.0);
    let pbr_loc = format!("{loc}.pbrMetallicRoughness");
    let base = || pbr.base_color_texture().map(|t| Slot::of(t, format!("{pbr_loc}.baseColorTexture"), true));
    if m.unlit() {
        // KHR_materials_unlit: the base colour's texture is what it emits (and its alpha the
        // coverage); no other map applies.
        return Ok(MaterialSlots { base: base(), emissive: base(), ..MaterialSlots::default() });
    }
    let specular = m.specular();
    let spec_loc = format!("{loc}.extensions.KHR_materials_specular");
    let coat = layers::coat_json(ctx, m, i)?;
    let coat_loc = format!("{loc}.extensions.KHR_materials_clearcoat");
    let coat_slot = |key: &str, srgb: bool| -> Result<Option<Slot<'d>>, Error> {
        let Some(v) = coat.as_ref().and_then(|c| c.raw.get(key)) else { return Ok(None) };
        let loc = format!("{coat_loc}.{key}");
        Slot::json(doc, v, loc.clone(), srgb).map(Some).map_err(|e| ctx.err(loc, e))
    };
    Ok(MaterialSlots {
        base: base(),
        metallic_roughness: pbr
            .metallic_roughness_texture()
            .map(|t| Slot::of(t, format!("{pbr_loc}.metallicRoughnessTexture"), false)),
        emissive: m
            .emissive_texture()
            .filter(|_| emits)
            .map(|t| Slot::of(t, format!("{loc}.emissiveTexture"), true)),
        transmission: transmission.and_then(|t| t.transmission_texture()).map(|t| {
            Slot::of(t, format!("{loc}.extensions.KHR_materials_transmission.transmissionTexture"), false)
        }),
        normal: match m.normal_texture() {
            None => None,
            Some(n) => {
                let nloc = format!("{loc}.normalTexture");
                Some(
                    Slot::normal(&n, nloc.clone())
                        .map_err(|e| ctx.err(format!("{nloc}.extensions.KHR_texture_transform"), e))?,
                )
            }
        },
        specular: specular
            .as_ref()
            .and_then(|s| s.specular_texture())
            .map(|t| Slot::of(t, format!("{spec_loc}.specularTexture"), false)),
        specular_color: specular
            .as_ref()
            .and_then(|s| s.specular_color_texture())
            .map(|t| Slot::of(t, format!("{spec_loc}.specularColorTexture"), true)),
        clearcoat: coat_slot("clearcoatTexture", false)?,
        clearcoat_roughness: coat_slot("clearcoatRoughnessTexture", false)?,
        clearcoat_normal: coat_slot("clearcoatNormalTexture", false)?,
        coat: coat.as_ref().map(|c| c.factors),
    })
}

/// The scene material of glTF material `m` (`materials[i]`) with its texture `slots`, its
/// maps added to `textures`.
fn material(
    ctx: &Ctx,
    m: &gltf::Material,
    i: usize,
    slots: &MaterialSlots,
    textures: &mut Textures,
    warnings: &mut Vec<String>,
) -> Result<Material, Error> {
    let pbr = m.pbr_metallic_roughness();
    let bc = pbr.base_color_factor();
    let factors = layers::factors(ctx, m, i)?;
    // Unlit materials do not transmit, so their attenuation is never applied.
    let attenuation = layers::volume_attenuation(ctx, m, i)?;
    let mut add = |slot: &Option<Slot>| -> Result<Option<TextureRef>, Error> {
        match slot {
            None => Ok(None),
            Some(s) => textures.add(ctx, s, warnings),
        }
    };
    let base_color_texture = add(&slots.base)?;
    let maps = PbrMaps {
        metallic: factors.metallic,
        roughness: factors.roughness,
        transmission: factors.transmission,
        emission: factors.emission,
        metallic_roughness: add(&slots.metallic_roughness)?,
        emissive: add(&slots.emissive)?,
        transmission_texture: add(&slots.transmission)?,
        specular: factors.specular,
        specular_color: factors.specular_color,
        specular_texture: add(&slots.specular)?,
        specular_color_texture: add(&slots.specular_color)?,
        ranges: MapRanges::ONES,
    };
    let normal_map = add(&slots.normal)?
        .map(|texture| NormalMap { texture, scale: m.normal_texture().map_or(1.0, |n| n.scale() as f64) });
    let clearcoat = match slots.coat {
        None => None,
        Some(c) => Some(Box::new(Clearcoat {
            factor: c.factor,
            roughness: c.roughness,
            texture: add(&slots.clearcoat)?,
            roughness_texture: add(&slots.clearcoat_roughness)?,
            normal_map: add(&slots.clearcoat_normal)?
                .map(|texture| NormalMap { texture, scale: c.normal_scale }),
            max_strength: c.factor,
            min_roughness: c.roughness,
        })),
    };
    // The scalar terms: the factors' where no map varies them; else bounds over the maps
    // ([`PbrMaps::bounds`]), from the extremes of their texels.
    let (mut maps, mut clearcoat) = (maps, clearcoat);
    set_ranges(&mut maps, clearcoat.as_deref_mut(), &textures.out);
    let has_maps = maps.has_texture();
    let sh = if has_maps { maps.bounds(factors.base, factors.ior) } else { factors.whitted() };
    let alpha = match m.alpha_mode() {
        AlphaMode::Opaque => Alpha::Opaque,
        AlphaMode::Mask => Alpha::Mask { cutoff: m.alpha_cutoff().unwrap_or(0.5) as f64 },
        AlphaMode::Blend => Alpha::Blend,
    };
    Ok(Material {
        name: m.name().map(String::from),
        color: sh.color,
        kd: sh.kd,
        ks: sh.ks,
        shine: sh.shine,
        mirror: sh.mirror,
        transmittance: sh.transmittance,
        tinted_transmission: true,
        ior: factors.ior,
        emission: sh.emission,
        base_color_texture,
        maps: has_maps.then(|| Box::new(maps)),
        normal_map,
        alpha,
        opacity: (bc[3] as f64).clamp(0.0, 1.0),
        double_sided: m.double_sided(),
        attenuation,
        clearcoat,
    })
}

/// The extremes `maps` and `coat` read from their textures (`textures`, the scene's so far):
/// what their bounds are made from.
fn set_ranges(maps: &mut PbrMaps, coat: Option<&mut Clearcoat>, textures: &[Texture]) {
    let image = |r: Option<TextureRef>| r.map(|r| &textures[r.texture as usize]);
    let r = &mut maps.ranges;
    if let Some(t) = image(maps.metallic_roughness) {
        let (m, rough) = (channel_range(t, 2), channel_range(t, 1));
        (r.metallic, r.roughness_min) = ([m.0, m.1], rough.0);
    }
    if let Some(t) = image(maps.transmission_texture) {
        r.transmission_max = channel_range(t, 0).1;
    }
    if let Some(t) = image(maps.emissive) {
        r.emission_max = max_srgb(t);
    }
    if let Some(t) = image(maps.specular_texture) {
        r.specular_max = channel_range(t, 3).1;
    }
    if let Some(t) = image(maps.specular_color_texture) {
        r.specular_color_max = max_srgb(t);
    }
    if let Some(c) = coat {
        if let Some(t) = image(c.texture) {
            c.max_strength *= channel_range(t, 0).1;
        }
        if let Some(t) = image(c.roughness_texture) {
            c.min_roughness *= channel_range(t, 1).0;
        }
    }
}

/// Widens the map bounds of every material some of whose triangles lack a UV set its maps
/// read: there the maps count as 1 ([`PbrMaps`]), which the bounds must cover too.
pub fn widen_bounds_for_missing_uvs(materials: &mut [Material], primitives: &[Primitive]) {
    let mut lacking = vec![false; materials.len()];
    for p in primitives {
        let Primitive::Triangle(t) = p else { continue };
        let m = &materials[t.material as usize];
        let has = [t.uv.is_some(), t.uv1.is_some()];
        let maps = m.maps.as_deref().into_iter().flat_map(PbrMaps::textures);
        let coat =
            m.clearcoat.as_deref().into_iter().flat_map(|c| [c.texture, c.roughness_texture]).flatten();
        lacking[t.material as usize] |= maps.chain(coat).any(|r| !has[r.texcoord as usize]);
    }
    for (m, lacks) in materials.iter_mut().zip(lacking) {
        if !lacks {
            continue;
        }
        // Where the strength texture counts as 1 the strength is the factor. (The least
        // roughness is already at most the factor's, a texel being at most 1.)
        if let Some(c) = m.clearcoat.as_deref_mut() {
            c.max_strength = c.factor;
        }
        let Some(maps) = m.maps.as_deref_mut() else { continue };
        maps.ranges = maps.ranges.with_fallback();
        let sh = maps.bounds(m.color, m.ior);
        (m.mirror, m.transmittance, m.emission) = (sh.mirror, sh.transmittance, sh.emission);
    }
}

/// The texture slots of one material.
#[derive(Default)]
struct MaterialSlots<'d> {
    base: Option<Slot<'d>>,
    metallic_roughness: Option<Slot<'d>>,
    emissive: Option<Slot<'d>>,
    transmission: Option<Slot<'d>>,
    normal: Option<Slot<'d>>,
    specular: Option<Slot<'d>>,
    specular_color: Option<Slot<'d>>,
    clearcoat: Option<Slot<'d>>,
    clearcoat_roughness: Option<Slot<'d>>,
    clearcoat_normal: Option<Slot<'d>>,
    /// KHR_materials_clearcoat's factors, read with its slots (none for an unlit material).
    coat: Option<layers::CoatFactors>,
}

impl MaterialSlots<'_> {
    fn all(&self) -> impl Iterator<Item = &Slot<'_>> {
        [
            &self.base,
            &self.metallic_roughness,
            &self.emissive,
            &self.transmission,
            &self.normal,
            &self.specular,
            &self.specular_color,
            &self.clearcoat,
            &self.clearcoat_roughness,
            &self.clearcoat_normal,
        ]
        .into_iter()
        .flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_extremes_are_linear() {
        let t = Texture {
            name: None,
            width: 2,
            height: 1,
            texels: vec![[255, 0, 188, 255], [0, 10, 20, 255]],
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            linear: true,
            srgb: true,
        };
        let m = max_srgb(&t);
        assert!((m.x - 1.0).abs() < 1e-12 && (m.z - 0.5).abs() < 0.01, "{m}");
        assert_eq!(channel_range(&t, 2), (20.0 / 255.0, 188.0 / 255.0));
    }
}
