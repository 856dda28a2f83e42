//! Whitted materials and textures, and the glTF metallic-roughness inputs that a material
//! with per-hit maps maps onto the Whitted terms at every hit ([`Pbr::whitted`]). The
//! mapping from NFF and glTF is documented in the parent module.

use glam::{DAffine2, DVec2, DVec3};

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
    /// vary the Whitted terms per hit ([`Pbr::whitted`]); boxed, as few materials have them.
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

/// glTF metallic-roughness factors and the textures that vary them per hit: metallic is the
/// metallic-roughness texture's blue channel times `metallic`, roughness its green channel
/// times `roughness`, transmission the transmission texture's red channel times
/// `transmission`, emission the emissive texture (sRGB) times `emission`. A texture that is
/// absent, or whose UV set a triangle lacks, counts as 1.
#[derive(Clone, Debug, PartialEq)]
pub struct PbrMaps {
    pub metallic: f64,
    pub roughness: f64,
    pub transmission: f64,
    /// emissiveFactor × KHR_materials_emissive_strength.
    pub emission: DVec3,
    pub metallic_roughness: Option<TextureRef>,
    pub emissive: Option<TextureRef>,
    pub transmission_texture: Option<TextureRef>,
    /// What the textures take over the hits, for [`PbrMaps::bounds`].
    pub ranges: MapRanges,
}

/// The extremes a material's map channels take over its hits, in [0, 1] (emission: linear):
/// over the texels, and 1 where a hit may lack the texture ([`MapRanges::with_fallback`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapRanges {
    /// Least and largest metallic (the blue channel).
    pub metallic: [f64; 2],
    /// Least roughness (the green channel).
    pub roughness_min: f64,
    /// Largest transmission (the red channel).
    pub transmission_max: f64,
    /// Largest emission per channel.
    pub emission_max: DVec3,
}

impl MapRanges {
    /// Ranges of maps that are all absent: every channel 1.
    pub const ONES: MapRanges = MapRanges {
        metallic: [1.0, 1.0],
        roughness_min: 1.0,
        transmission_max: 1.0,
        emission_max: DVec3::ONE,
    };

    /// The ranges with the value of an absent texture (1) joined: for a material some of
    /// whose triangles lack the UV set its maps read.
    pub fn with_fallback(self) -> MapRanges {
        MapRanges {
            metallic: [self.metallic[0].min(1.0), 1.0],
            roughness_min: self.roughness_min.min(1.0),
            transmission_max: 1.0,
            emission_max: DVec3::ONE,
        }
    }
}

impl PbrMaps {
    /// The Whitted terms whose `mirror`, `transmittance` and `emission` bound every hit's
    /// (base colour `base`, index `ior`): the mirror of the most metallic and least rough
    /// texel (a metal's F0 taken at the factor's base colour, at most max(0.04, base)), the
    /// transmittance of the most transmitting and least metallic, the brightest emission.
    /// `kd`, `ks` and `shine` are the latter texel's, not bounds: shading never reads them.
    pub fn bounds(&self, base: DVec3, ior: f64) -> Shading {
        let r = &self.ranges;
        let roughness = self.roughness * r.roughness_min;
        let glass = Pbr {
            base,
            metallic: self.metallic * r.metallic[0],
            roughness,
            transmission: self.transmission * r.transmission_max,
            ior,
            emission: self.emission * r.emission_max,
        };
        let metal = Pbr { metallic: self.metallic * r.metallic[1], transmission: 0.0, ..glass };
        let mut sh = glass.whitted();
        // F0 = mix(0.04, base, m) lies between 0.04 and the base colour.
        let f0_max = base.clamp(DVec3::ZERO, DVec3::ONE).max(DVec3::splat(0.04));
        let metal_mirror = if metal.whitted().mirror.max_element() > 0.0 {
            f0_max * (1.0 - roughness.clamp(0.0, 1.0)).powi(2)
        } else {
            DVec3::ZERO
        };
        sh.mirror = sh.mirror.max(metal_mirror);
        sh
    }
}

/// The Whitted terms at one hit (a material's scalars, or its maps evaluated there).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shading {
    /// The base colour at the hit (factor × texture × vertex colour).
    pub color: DVec3,
    pub kd: f64,
    pub ks: f64,
    pub shine: f64,
    pub mirror: DVec3,
    pub transmittance: f64,
    pub emission: DVec3,
}

/// Metallic-roughness inputs at one point (or their bounds over a material).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pbr {
    pub base: DVec3,
    pub metallic: f64,
    pub roughness: f64,
    /// KHR_materials_transmission factor.
    pub transmission: f64,
    /// KHR_materials_ior (1.5 when absent).
    pub ior: f64,
    pub emission: DVec3,
}

impl Pbr {
    /// The Whitted terms for these inputs, exactly as documented in [`crate::scene`]. Inputs
    /// are clamped to [0, 1] first (the twin in `shaders/shared/shade.wgsl` is `whitted`).
    pub fn whitted(&self) -> Shading {
        let base = self.base.clamp(DVec3::ZERO, DVec3::ONE);
        let m = self.metallic.clamp(0.0, 1.0);
        let rough = self.roughness.clamp(0.0, 1.0);
        let transmittance = self.transmission.clamp(0.0, 1.0) * (1.0 - m);
        let alpha = rough * rough;
        // α = 0 gives +∞, which the clamp turns into the largest exponent.
        let shine = (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 10_000.0);
        let smooth = (1.0 - rough) * (1.0 - rough);
        let mirror = if m > 0.0 {
            smooth * DVec3::splat(0.04).lerp(base, m)
        } else if transmittance > 0.0 {
            smooth * DVec3::splat(((self.ior - 1.0) / (self.ior + 1.0)).powi(2))
        } else {
            DVec3::ZERO
        };
        Shading {
            color: base,
            kd: (1.0 - m) * (1.0 - transmittance),
            ks: (1.0 - rough) * (0.04 + 0.96 * m),
            shine,
            mirror,
            transmittance,
            emission: self.emission.max(DVec3::ZERO),
        }
    }
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
        }
    }
}

impl Material {
    pub fn reflects(&self) -> bool {
        self.mirror.max_element() > 0.0
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
        [
            self.base_color_texture,
            maps.and_then(|m| m.metallic_roughness),
            maps.and_then(|m| m.emissive),
            maps.and_then(|m| m.transmission_texture),
            self.normal_map.map(|n| n.texture),
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
            let finite = [m.metallic, m.roughness, m.transmission].iter().all(|v| v.is_finite());
            if !finite || !m.emission.is_finite() {
                return Err(Error::Scene("a metallic-roughness factor is not finite".into()));
            }
            if m.metallic_roughness.is_none() && m.emissive.is_none() && m.transmission_texture.is_none() {
                return Err(Error::Scene("per-hit maps without a texture".into()));
            }
        }
        if let Some(n) = &self.normal_map {
            if !n.scale.is_finite() {
                return Err(Error::Scene(format!("normal map scale {} is not finite", n.scale)));
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
