//! Textures and how materials read them: RGBA8 images (sRGB colour, linear data), a
//! material's reference to one (UV set and KHR_texture_transform), normal maps, wrap modes,
//! the sRGB decoding and the bilinear lookup every reader samples with.

use glam::{DAffine2, DVec2};

/// A tangent-space normal map: `n = normalize(T·x·s + B·y·s + N·z)`, with (x, y, z) the
/// texel mapped from [0, 1] to [−1, 1] and `s` = `scale` (glTF `normalTexture`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalMap {
    pub texture: TextureRef,
    pub scale: f64,
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
