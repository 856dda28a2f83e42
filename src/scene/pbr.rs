//! The glTF metallic-roughness inputs and the layers over them (clear coat, specular) that a
//! material with per-hit maps maps onto the Whitted terms at every hit ([`Pbr::whitted`]),
//! the bounds those terms take over a material's hits, and the clear coat's Fresnel-weighted
//! mirror. The mapping is documented in the parent module.

use glam::DVec3;

use super::texture::{NormalMap, TextureRef};

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
    /// KHR_materials_specular's specularFactor and specularColorFactor (1 without it).
    pub specular: f64,
    pub specular_color: DVec3,
    pub metallic_roughness: Option<TextureRef>,
    pub emissive: Option<TextureRef>,
    pub transmission_texture: Option<TextureRef>,
    /// specularTexture (alpha channel) and specularColorTexture (sRGB).
    pub specular_texture: Option<TextureRef>,
    pub specular_color_texture: Option<TextureRef>,
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
    /// Largest specular weight (the alpha channel) and colour per channel (linear).
    pub specular_max: f64,
    pub specular_color_max: DVec3,
}

impl MapRanges {
    /// Ranges of maps that are all absent: every channel 1.
    pub const ONES: MapRanges = MapRanges {
        metallic: [1.0, 1.0],
        roughness_min: 1.0,
        transmission_max: 1.0,
        emission_max: DVec3::ONE,
        specular_max: 1.0,
        specular_color_max: DVec3::ONE,
    };

    /// The ranges with the value of an absent texture (1) joined: for a material some of
    /// whose triangles lack the UV set its maps read.
    pub fn with_fallback(self) -> MapRanges {
        MapRanges {
            metallic: [self.metallic[0].min(1.0), 1.0],
            roughness_min: self.roughness_min.min(1.0),
            transmission_max: 1.0,
            emission_max: DVec3::ONE,
            specular_max: 1.0,
            specular_color_max: DVec3::ONE,
        }
    }
}

impl PbrMaps {
    /// Whether some texture varies the terms per hit (else the factors make scalars).
    pub fn has_texture(&self) -> bool {
        self.textures().next().is_some()
    }

    /// The textures the maps read.
    pub fn textures(&self) -> impl Iterator<Item = TextureRef> + '_ {
        [
            self.metallic_roughness,
            self.emissive,
            self.transmission_texture,
            self.specular_texture,
            self.specular_color_texture,
        ]
        .into_iter()
        .flatten()
    }

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
            specular: self.specular * r.specular_max,
            specular_color: self.specular_color * r.specular_color_max,
        };
        let metal = Pbr { metallic: self.metallic * r.metallic[1], transmission: 0.0, ..glass };
        let mut sh = glass.whitted();
        // F0 = mix(dielectric F0, base, m) lies between the two.
        let f0_max = base.clamp(DVec3::ZERO, DVec3::ONE).max(glass.dielectric_f0(0.04));
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
    /// KHR_materials_specular: the weight and colour of the dielectric reflectance (1, 1
    /// without it).
    pub specular: f64,
    pub specular_color: DVec3,
}

impl Pbr {
    /// These inputs without KHR_materials_specular (weight and colour 1).
    pub fn new(
        base: DVec3,
        metallic: f64,
        roughness: f64,
        transmission: f64,
        ior: f64,
        emission: DVec3,
    ) -> Pbr {
        Pbr {
            base,
            metallic,
            roughness,
            transmission,
            ior,
            emission,
            specular: 1.0,
            specular_color: DVec3::ONE,
        }
    }

    /// The reflectance at normal incidence of the dielectric with reflectance `f0`, through
    /// KHR_materials_specular: `min(f0·specularColor, 1)·specular`.
    pub fn dielectric_f0(&self, f0: f64) -> DVec3 {
        (self.specular_color.max(DVec3::ZERO) * f0).min(DVec3::ONE) * self.specular.clamp(0.0, 1.0)
    }

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
        // The opaque dielectric's F0 is 0.04 (η = 1.5) whatever the ior: metals mix it.
        let f0 = self.dielectric_f0(0.04);
        let mirror = if m > 0.0 {
            smooth * f0.lerp(base, m)
        } else if transmittance > 0.0 {
            smooth * self.dielectric_f0(((self.ior - 1.0) / (self.ior + 1.0)).powi(2))
        } else {
            DVec3::ZERO
        };
        // The highlight is white: its weight takes F0's largest channel.
        let f = f0.max_element();
        Shading {
            color: base,
            kd: (1.0 - m) * (1.0 - transmittance),
            ks: (1.0 - rough) * (f + (1.0 - f) * m),
            shine,
            mirror,
            transmittance,
            emission: self.emission.max(DVec3::ZERO),
        }
    }
}

/// KHR_materials_clearcoat: a clear dielectric layer (IOR 1.5) over the material. At a hit
/// seen along `v` with coat normal `n` it reflects `k = c·F` of the light, `c` its strength
/// there (`factor` × the texture's red channel) and `F = 0.04 + 0.96·(1 − n·v)⁵` (Schlick),
/// as a mirror weighted by `(1 − r)²` (`r` = `roughness` × the roughness texture's green
/// channel), and lets `1 − k` of everything the base sends through (its light, mirror,
/// transmission and emission). The reflected ray leaves along the coat's normal.
#[derive(Clone, Debug, PartialEq)]
pub struct Clearcoat {
    pub factor: f64,
    pub roughness: f64,
    /// clearcoatTexture (red channel).
    pub texture: Option<TextureRef>,
    /// clearcoatRoughnessTexture (green channel).
    pub roughness_texture: Option<TextureRef>,
    /// clearcoatNormalTexture; without one the coat takes the interpolated normal, not the
    /// base's normal map.
    pub normal_map: Option<NormalMap>,
    /// The largest `factor` × texture over the hits and the least roughness, in [0, 1].
    pub max_strength: f64,
    pub min_roughness: f64,
}

/// Schlick's Fresnel reflectance of a clear coat (IOR 1.5, F0 0.04) at `cos` = n·v (the
/// kernels' twin is `coat_fresnel` in `shaders/shared/shade.wgsl`).
pub fn coat_fresnel(cos: f64) -> f64 {
    let x = 1.0 - cos.clamp(0.0, 1.0);
    let x2 = x * x;
    0.04 + 0.96 * (x2 * x2 * x)
}

impl Clearcoat {
    /// The coat's strength `c` and mirror weight `(1 − r)²` at a hit whose textures read
    /// `strength` (red) and `rough` (green), 1 where absent.
    pub fn at(&self, strength: f64, rough: f64) -> (f64, f64) {
        let c = (self.factor * strength).clamp(0.0, 1.0);
        let r = (self.roughness * rough).clamp(0.0, 1.0);
        (c, (1.0 - r) * (1.0 - r))
    }

    /// Whether some hit's coat reflects (which decides whether reflection rays are spawned):
    /// somewhere it has strength, and somewhere it is not fully rough.
    pub fn reflects(&self) -> bool {
        self.max_strength > 0.0 && self.min_roughness < 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs() -> Pbr {
        Pbr::new(DVec3::new(0.8, 0.5, 0.2), 0.0, 1.0, 0.0, 1.5, DVec3::ZERO)
    }

    #[test]
    fn rough_dielectric_is_matte() {
        let m = inputs().whitted();
        assert_eq!((m.kd, m.ks, m.shine, m.mirror), (1.0, 0.0, 1.0, DVec3::ZERO));
        assert_eq!(m.color, DVec3::new(0.8, 0.5, 0.2));
    }

    #[test]
    fn smooth_metal_mirrors_its_base_colour() {
        let m = Pbr { metallic: 1.0, roughness: 0.0, ..inputs() }.whitted();
        assert_eq!(m.kd, 0.0);
        assert_eq!(m.ks, 1.0);
        assert_eq!(m.shine, 10_000.0);
        assert!((m.mirror - DVec3::new(0.8, 0.5, 0.2)).length() < 1e-12);
    }

    #[test]
    fn glass_transmits_with_fresnel_mirror() {
        let m = Pbr { transmission: 1.0, roughness: 0.0, ..inputs() }.whitted();
        assert_eq!((m.transmittance, m.kd), (1.0, 0.0));
        assert!((m.mirror.x - 0.04).abs() < 1e-12, "{}", m.mirror);
        // Half rough: α = 0.25, shine = 2/α² − 2 = 30, ks = 0.5·0.04.
        let m = Pbr { roughness: 0.5, ..inputs() }.whitted();
        assert!((m.shine - 30.0).abs() < 1e-9 && (m.ks - 0.02).abs() < 1e-12);
    }

    #[test]
    fn specular_scales_and_tints_f0_and_leaves_the_default_alone() {
        let glass = Pbr { transmission: 1.0, roughness: 0.0, ..inputs() };
        let tinted = Pbr { specular: 0.5, specular_color: DVec3::new(1.0, 0.5, 30.0), ..glass }.whitted();
        // min(0.04·colour, 1)·0.5, the blue channel clamped at 1 first.
        assert!((tinted.mirror - DVec3::new(0.02, 0.01, 0.5)).length() < 1e-12, "{}", tinted.mirror);
        assert_eq!(glass.whitted(), Pbr { specular: 1.0, specular_color: DVec3::ONE, ..glass }.whitted());
        let plastic = Pbr { roughness: 0.5, specular: 0.0, ..inputs() }.whitted();
        assert_eq!(plastic.ks, 0.0);
    }

    #[test]
    fn coat_fresnel_is_schlick_at_ior_one_and_a_half() {
        assert!((coat_fresnel(1.0) - 0.04).abs() < 1e-15);
        assert!((coat_fresnel(0.0) - 1.0).abs() < 1e-15);
        assert!((coat_fresnel(0.5) - (0.04 + 0.96 / 32.0)).abs() < 1e-15);
    }
}
