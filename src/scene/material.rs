//! Whitted materials: what every hit is shaded with, whatever the file format (a material
//! with per-hit maps or layers holds them, evaluated through [`super::pbr`]; its textures
//! are [`super::texture`]'s). The mapping from NFF and glTF is documented in the parent module.

use glam::DVec3;

use super::pbr::{Clearcoat, PbrMaps, Shading};
use super::texture::{NormalMap, TextureRef, TEXCOORD_SETS};
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
        self.mirror.max_element() > 0.0 || self.clearcoat.as_ref().is_some_and(|c| c.reflects())
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
