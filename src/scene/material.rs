//! Whitted materials and textures. The mapping from NFF and glTF is documented in the
//! parent module.

use glam::DVec3;

use crate::error::{Error, Result};

/// A Whitted/Phong material (Whitted 1980, Haines' NFF):
/// `L = ambient·kd·C + Σ_lights vis·I·(kd·C·max(N·L,0) + ks·max(R·V,0)^shine)
///      + mirror·L_reflected + transmittance·T·L_refracted + emission`, with `T = C` for a
/// tinted transmission (glTF) and 1 otherwise (NFF).
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
    /// glTF `doubleSided` (recorded; the renderers intersect both sides of triangles).
    pub double_sided: bool,
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
        if let Some(t) = &self.base_color_texture {
            if t.texture as usize >= texture_count {
                return Err(Error::Scene(format!(
                    "texture index {} out of range ({} textures)",
                    t.texture, texture_count
                )));
            }
        }
        Ok(())
    }
}

/// A material's reference to a texture and the UV set it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextureRef {
    pub texture: u32,
    /// glTF `texCoord`: which TEXCOORD_n the loader put into [`super::Triangle::uv`].
    pub texcoord: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
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
}
