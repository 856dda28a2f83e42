//! Whitted materials and textures: what every hit is shaded with, whatever the file
//! format (a material with per-hit maps or layers holds them, evaluated through
//! [`super::pbr`]). The mapping from NFF and glTF is documented in the parent module.

use glam::{DAffine2, DVec2, DVec3};

use super::pbr::{Clearcoat, PbrMaps, Shading};
use crate::error::{Error, Result};

/// A Whitted/Phong material (Whitted 1980, Haines' NFF):
/// `L = ambient·kd·C + Σ_lights vis·I·(kd·C·max(N·L,0) + ks·max(R·V,0)^shine)
///      + mirror·L_reflected + transmittance·T·L_refracted + emission`, with `T = C` for a
/// tinted transmission (glTF) and 1 otherwise (NFF).
///
/// A material with [`Material::maps`] is evaluated per hit from them; its `mirror`,
/// `transmittance` and `emission` are then upper bounds over its hits ([`PbrMaps::bounds`]:
/// a map's extreme, not its mean), which is what decides whether a scene spawns reflection
/// and refraction rays.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: Option<String>,
    /// Diffuse colour, linear RGB in [0, 1] (multiplied by the base colour texture).
    pub color: DVec3,
    /// Diffuse weight.
    pub kd: f64,
    /// Phong highlight weight.
    pub ks: f64,
    /// Phong exponent.
    pub shine: f64,
    /// Weight of the mirror-reflected ray, per channel.
    pub mirror: DVec3,
    /// Weight of the refracted ray; > 0 makes the surface two-sided and refracting.
    pub transmittance: f64,
    /// The refracted ray is also weighted by the base colour at the hit (`color` times the
    /// base colour texture), as KHR_materials_transmission tints transmitted light; NFF's
    /// `T` is not tinted.
    pub tinted_transmission: bool,
    /// Index of refraction of the inside.
    pub ior: f64,
    /// Emitted radiance, linear RGB.
    pub emission: DVec3,
    pub base_color_texture: Option<TextureRef>,
    /// glTF metallic-roughness inputs with textures other than the base colour's, which
    /// vary the Whitted terms per hit ([`super::Pbr::whitted`]); boxed, as few materials have them.
    pub maps: Option<Box<PbrMaps>>,
    /// A tangent-space normal map (glTF `normalTexture`).
    pub normal_map: Option<NormalMap>,
    /// How the base colour's alpha makes the surface transparent (glTF `alphaMode`).
    pub alpha: Alpha,
    /// The alpha of the base colour factor (glTF `baseColorFactor[3]`), times the base colour
    /// texture's alpha at a hit.
    pub opacity: f64,
    /// glTF `doubleSided` (recorded; the renderers intersect both sides of triangles).
    pub double_sided: bool,
    /// Beer–Lambert attenuation per unit length inside a transmitting body, per channel
    /// (KHR_materials_volume: −ln(attenuationColor) / attenuationDistance; zero: none).
    /// Radiance reaching a hit from inside the body (the ray met the surface's back) is
    /// multiplied by `exp(−attenuation·t)` over the ray's length `t`.
    pub attenuation: DVec3,
    /// A clear coat over the surface (KHR_materials_clearcoat); boxed, as few materials have
    /// one.
    pub clearcoat: Option<Box<Clearcoat>>,
}

/// glTF `alphaMode`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Alpha {
    #[default]
    Opaque,
    /// A hit whose alpha is below `cutoff` is no hit, for every ray.
    Mask { cutoff: f64 },
    /// The surface lets `1 − alpha` of the light straight through (camera and spawned rays:
    /// a pass-through ray; shadow rays: [`Alpha::BLEND_SHADOW_CUTOFF`] as a mask).
    Blend,
}

impl Alpha {
    /// Shadow rays are binary: they treat a blended surface as masked at this alpha.
    pub const BLEND_SHADOW_CUTOFF: f64 = 0.5;

    /// The cutoff below which a hit is no hit for a ray of this kind (`shadow`), if any.
    pub fn cutoff(self, shadow: bool) -> Option<f64> {
        match self {
            Alpha::Opaque => None,
            Alpha::Mask { cutoff } => Some(cutoff),
            Alpha::Blend => shadow.then_some(Alpha::BLEND_SHADOW_CUTOFF),
        }
    }
}

/// A tangent-space normal map: `n = normalize(T·x·s + B·y·s + N·z)`, with (x, y, z) the
/// texel mapped from [0, 1] to [−1, 1] and `s` = `scale` (glTF `normalTexture`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalMap {
    pub texture: TextureRef,
    pub scale: f64,
}

impl Default for Material {
    /// Matte white: what NFF uses before the first `f`, and what glTF primitives without a
    /// material get (see the mapping in the parent module).
    fn default() -> Self {
        Material {
            name: None,
            color: DVec3::ONE,
            kd: 1.0,
            ks: 0.0,
            shine: 1.0,
            mirror: DVec3::ZERO,
            transmittance: 0.0,
            tinted_transmission: false,
            ior: 1.0,
            emission: DVec3::ZERO,
            base_color_texture: None,
            maps: None,
            normal_map: None,
            alpha: Alpha::Opaque,
            opacity: 1.0,
            double_sided: false,
            attenuation: DVec3::ZERO,
            clearcoat: None,
        }
    }
}

impl Material {
    /// Whether some hit spawns a reflection ray (its mirror, or its clear coat's).
    pub fn reflects(&self) -> bool {
        self.mirror.max_element() > 0.0 || self.clearcoat.as_ref().is_some_and(|c| c.mirror_bound() > 0.0)
    }

    /// Whether light travelling inside the body is attenuated (it must transmit for any to).
    pub fn attenuates(&self) -> bool {
        self.transmits() && self.attenuation.max_element() > 0.0
    }

    pub fn transmits(&self) -> bool {
        self.transmittance > 0.0
    }

    pub fn emits(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Whether some hit may be no hit, or let light straight through (alpha mask or blend).
    pub fn cut_out(&self) -> bool {
        self.alpha != Alpha::Opaque
    }

    /// The scalar Whitted terms with base colour `color` (what a material without maps has
    /// at every hit).
    pub fn shading(&self, color: DVec3) -> Shading {
        Shading {
            color,
            kd: self.kd,
            ks: self.ks,
            shine: self.shine,
            mirror: self.mirror,
            transmittance: self.transmittance,
            emission: self.emission,
        }
    }

    /// Every texture the material reads.
    pub fn texture_refs(&self) -> impl Iterator<Item = TextureRef> + '_ {
        let maps = self.maps.as_deref();
        let coat = self.clearcoat.as_deref();
        [
            self.base_color_texture,
            maps.and_then(|m| m.metallic_roughness),
            maps.and_then(|m| m.emissive),
            maps.and_then(|m| m.transmission_texture),
            maps.and_then(|m| m.specular_texture),
            maps.and_then(|m| m.specular_color_texture),
            self.normal_map.map(|n| n.texture),
            coat.and_then(|c| c.texture),
            coat.and_then(|c| c.roughness_texture),
            coat.and_then(|c| c.normal_map.map(|n| n.texture)),
        ]
        .into_iter()
        .flatten()
    }

    pub fn validate(&self, texture_count: usize) -> Result<()> {
        let scalars = [
            ("kd", self.kd),
            ("ks", self.ks),
            ("shine", self.shine),
            ("transmittance", self.transmittance),
            ("ior", self.ior),
        ];
        for (what, v) in scalars {
            if !v.is_finite() {
                return Err(Error::Scene(format!("{what} is not finite")));
            }
        }
        for (what, v) in [("colour", self.color), ("mirror", self.mirror), ("emission", self.emission)] {
            if !v.is_finite() {
                return Err(Error::Scene(format!("{what} is not finite")));
            }
        }
        if self.ior <= 0.0 {
            return Err(Error::Scene(format!("index of refraction {} is not positive", self.ior)));
        }
        if !(self.opacity.is_finite() && (0.0..=1.0).contains(&self.opacity)) {
            return Err(Error::Scene(format!("opacity {} is not in [0, 1]", self.opacity)));
        }
        if let Alpha::Mask { cutoff } = self.alpha {
            if !cutoff.is_finite() || cutoff < 0.0 {
                return Err(Error::Scene(format!("alpha cutoff {cutoff} is not a non-negative number")));
            }
        }
        if let Some(m) = &self.maps {
            let finite = [m.metallic, m.roughness, m.transmission, m.specular].iter().all(|v| v.is_finite());
            if !finite || !m.emission.is_finite() || !m.specular_color.is_finite() {
                return Err(Error::Scene("a metallic-roughness factor is not finite".into()));
            }
            if !m.has_texture() {
                return Err(Error::Scene("per-hit maps without a texture".into()));
            }
        }
        if let Some(n) = &self.normal_map {
            if !n.scale.is_finite() {
                return Err(Error::Scene(format!("normal map scale {} is not finite", n.scale)));
            }
        }
        if !(self.attenuation.is_finite() && self.attenuation.min_element() >= 0.0) {
            return Err(Error::Scene(format!(
                "attenuation {} is not finite and non-negative",
                self.attenuation
            )));
        }
        if let Some(c) = &self.clearcoat {
            let finite =
                [c.factor, c.roughness, c.max_strength, c.min_roughness].iter().all(|v| v.is_finite());
            if !finite || !c.normal_map.is_none_or(|n| n.scale.is_finite()) {
                return Err(Error::Scene("a clear coat factor is not finite".into()));
            }
        }
        for t in self.texture_refs() {
            if t.texture as usize >= texture_count {
                return Err(Error::Scene(format!(
                    "texture index {} out of range ({} textures)",
                    t.texture, texture_count
                )));
            }
            if t.texcoord >= TEXCOORD_SETS {
                return Err(Error::Scene(format!("texture coordinate set {} is not 0 or 1", t.texcoord)));
            }
            if !t.transform.is_finite() {
                return Err(Error::Scene("a texture transform is not finite".into()));
            }
        }
        Ok(())
    }
}

/// How many texture coordinate sets a triangle may carry (glTF TEXCOORD_0 and TEXCOORD_1,
/// the two every glTF implementation must read).
pub const TEXCOORD_SETS: u32 = 2;

/// A material's reference to a texture, the UV set it reads and the transform its UVs take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: u32,
    /// glTF `texCoord`: 0 reads [`super::Triangle::uv`], 1 [`super::Triangle::uv1`].
    pub texcoord: u32,
    /// KHR_texture_transform (identity without one), applied at the hit.
    pub transform: DAffine2,
}

impl TextureRef {
    /// Where the texture is read at a point with UV sets `uv` (`None` where a set is absent).
    pub fn uv(&self, uv: [Option<DVec2>; 2]) -> Option<DVec2> {
        uv[self.texcoord as usize].map(|p| self.transform.transform_point2(p))
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

/// The sRGB electro-optical transfer function: an 8-bit sRGB value to linear [0, 1] (what
/// every reader of an sRGB [`Texture`] decodes with).
pub fn srgb_to_linear(v: u8) -> f64 {
    let c = v as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Bilinear interpolation between texel centres at texel-space position (`x`, `y`) (texel
/// `i`'s centre at `i + 0.5`) of `texel(i, j)`, which wraps or clamps the indices as its
/// image does: how textures and environment maps are sampled (the kernels' twin:
/// `shaders/shared/bilinear.wgsl`).
pub fn bilinear<T>(x: f64, y: f64, texel: impl Fn(i64, i64) -> T) -> T
where
    T: Copy + std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T>,
{
    let (x, y) = (x - 0.5, y - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (i, j) = (x0 as i64, y0 as i64);
    let top = texel(i, j) * (1.0 - fx) + texel(i + 1, j) * fx;
    let bottom = texel(i, j + 1) * (1.0 - fx) + texel(i + 1, j + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

/// An RGBA8 image. Colour channels are sRGB-encoded, alpha linear (as glTF stores them).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub name: Option<String>,
    pub width: u32,
    pub height: u32,
    /// Row-major from the top-left texel.
    pub texels: Vec<[u8; 4]>,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    /// Bilinear (true) or nearest (false) magnification.
    pub linear: bool,
    /// Colour channels are sRGB-encoded (base colour, emission) rather than linear data
    /// (metallic-roughness, transmission, normals).
    pub srgb: bool,
}
