//! The scene model: plain data that every renderer reads and every loader writes.
//!
//! A [`Scene`] holds a camera, lights, materials, textures and a flat list of
//! primitives (spheres, triangles, cylinders/cones). There is no file parsing and no
//! GPU code here: loaders live in [`crate::load`], renderers elsewhere.
//!
//! Invariants every loader guarantees (checked by [`Scene::validate`]):
//! - every number is finite; every direction is non-zero;
//! - sphere radii are strictly positive; cylinder/cone radii are non-negative and not both
//!   zero (a cone may end in a point: NFF apex radius 0); a negative radius in a file becomes
//!   `inside_only = true` with the absolute radius;
//! - triangles are non-degenerate (degenerate ones are dropped by the loader, with a count
//!   in a warning);
//! - every `material` index is in range, every texture index is in range;
//! - a primitive's **object id** is its index in [`Scene::primitives`]. Ids are stable:
//!   the same file always gives the same ids, in the order the file defines them.
//!
//! Geometry is stored in f64 so that the CPU reference can render exactly and the GPU path
//! can re-centre the scene on the camera before converting to f32.
//!
//! # Mapping file formats onto the Whitted material
//!
//! The material is the classic Whitted/NFF one (see [`Material`]). Loaders map:
//!
//! **NFF `f r g b Kd Ks Shine T ior`** (Haines' SPD):
//! `color = (r,g,b)`, `kd = Kd`, `ks = Ks` (Phong highlight weight), `shine = Shine`,
//! `mirror = (Ks, Ks, Ks)` (Ks also weights the reflected ray), `transmittance = T`,
//! `ior = ior`, no emission, no texture. T > 0 makes the surface two-sided and refracting.
//! The SPD files write `ior = 0` for opaque surfaces (T = 0); the loader stores 1 there.
//!
//! **glTF metallic-roughness**, evaluated at every hit ([`Pbr::whitted`]; base =
//! baseColorFactor.rgb times the base colour texture and the vertex colour; m =
//! metallicFactor and ρ = roughnessFactor, each times its channel (blue, green) of the
//! metallicRoughnessTexture when there is one; t = KHR_materials_transmission factor times
//! the red channel of its texture; η = KHR_materials_ior, default 1.5; base, m, ρ and t
//! clamped to [0, 1]; every texture read through its own texCoord set and
//! KHR_texture_transform):
//! - `color = base`;
//! - `transmittance = t·(1 − m)`, tinted (`tinted_transmission`): the refracted ray is also
//!   weighted by the base colour at the hit, texture included, as KHR_materials_transmission
//!   tints transmitted light; `ior = η`;
//! - `kd = (1 − m)·(1 − transmittance)`;
//! - `ks = (1 − ρ)·(0.04 + 0.96·m)` and `shine = clamp(2/α² − 2, 1, 10000)` with α = ρ²
//!   (the usual Blinn-Phong ↔ GGX width correspondence);
//! - `mirror = (1 − ρ)²·F0` with `F0 = mix(0.04, base, m)` for metals (m > 0), else
//!   `F0 = ((η − 1)/(η + 1))²` for transmitting surfaces; a non-metallic opaque surface
//!   (m = 0, t = 0) gets `mirror = 0` and so spawns no reflection ray;
//! - `emission = emissiveFactor · emissive_strength · E` (KHR_materials_emissive_strength),
//!   with E the linear colour of the sRGB emissiveTexture at the hit (1 without one);
//! - `normalTexture` bends the shading normal in the tangent frame of glTF's TANGENT, or of
//!   MikkTSpace's tangents where the primitive has none ([`NormalMap`]);
//! - `alphaMode` MASK: a hit whose alpha (baseColorFactor.a times the texture's alpha) is
//!   below `alphaCutoff` is no hit, for every ray; BLEND: the surface's radiance counts
//!   with its alpha and a pass-through ray carries 1 − alpha on, while shadow rays take it
//!   as a mask at 0.5 ([`Alpha`]);
//! - `doubleSided` is recorded; occlusion textures are ignored (glTF has no ambient light);
//! - KHR_materials_volume: light inside a transmitting body is attenuated by Beer–Lambert
//!   along the refracted path's real length ([`Material::attenuation`]); thicknessFactor only
//!   says whether there is a body (0: thin-walled, no attenuation), as the ray measures the
//!   path itself;
//! - KHR_materials_clearcoat: a Fresnel-weighted mirror layer over the base ([`Clearcoat`]);
//! - KHR_materials_specular: the dielectric reflectance `F0` becomes
//!   `min(F0·specularColor, 1)·specular`, per hit with its textures ([`Pbr::whitted`]).
//!
//! A material without metallic-roughness, emissive or transmission textures has these terms
//! once, as scalars; one with them keeps its factors and textures ([`PbrMaps`]), and its
//! scalars are bounds over the maps (the largest mirror weight, transmittance and
//! emission), which decide the effects a scene calls for. A primitive without a material
//! gets [`Material::default`] (matte white; glTF's own default, metallic 1 and roughness 1,
//! would map to black). glTF has no ambient light or background colour: both are black.
//!
//! **The environment** ([`Environment`], `--env`): an equirectangular radiance map that
//! every ray leaving the scene sees instead of the background, and directional lights that
//! stand in for it in Whitted shading. A glTF scene without lights gets the built-in studio
//! ([`environment::studio`]) instead of a headlight; NFF scenes keep their background and
//! lights unless given one.

use glam::DVec3;
use serde::Serialize;

use crate::error::{Error, Result};

mod camera;
pub mod environment;
mod light;
mod material;
mod origin;
mod pbr;
mod primitive;
mod texture;
mod tonemap;

pub use camera::{Camera, FovSpan, Projection, ViewOverride};
pub use environment::Environment;
pub use light::{Light, LightKind, LightSource};
pub use material::{Alpha, Material};
pub use origin::OriginKey;
pub use pbr::{coat_fresnel, Clearcoat, MapRanges, Pbr, PbrMaps, Shading};
use primitive::{finite3, validate_primitive};
pub use primitive::{Aabb, Cylinder, Primitive, Sphere, Triangle};
pub use texture::{bilinear, srgb_to_linear, NormalMap, Texture, TextureRef, Wrap, TEXCOORD_SETS};
pub use tonemap::{Tonemap, Transfer};

/// Which kinds of primitive a scene holds. Renderers compile intersection and surface code
/// only for the kinds that are `true`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Shapes {
    pub spheres: bool,
    pub triangles: bool,
    pub cylinders: bool,
}

impl Shapes {
    /// Every kind: what code that may meet any scene compiles.
    pub const ALL: Shapes = Shapes { spheres: true, triangles: true, cylinders: true };

    /// Whether every kind `other` holds is one of these.
    pub fn contains(self, other: Shapes) -> bool {
        (self.spheres || !other.spheres)
            && (self.triangles || !other.triangles)
            && (self.cylinders || !other.cylinders)
    }
}

impl Default for Shapes {
    fn default() -> Shapes {
        Shapes::ALL
    }
}

/// Which Whitted effects a scene calls for. Renderers build tables and compile code only
/// for the effects that are `true`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub struct Effects {
    /// At least one light: shadow rays are traced.
    pub shadows: bool,
    /// Some used material has a mirror reflectance or transmits (reflection rays).
    pub reflection: bool,
    /// Some used material transmits (refraction rays).
    pub refraction: bool,
    /// Some used material has a texture.
    pub textures: bool,
    /// Some used material emits light.
    pub emission: bool,
    /// Some triangle carries vertex colours.
    pub vertex_colors: bool,
    /// Some used material varies its Whitted terms per hit (metallic-roughness, emissive or
    /// transmission textures; [`Material::maps`] always has one).
    pub maps: bool,
    /// Some used material has a normal map and its triangles carry tangents.
    pub normal_maps: bool,
    /// Some used material is alpha-masked: every walk tests alpha at its hits.
    pub alpha: bool,
    /// Some used material is blended: its hits spawn pass-through rays, and shadow walks
    /// test alpha at them.
    pub blend: bool,
    /// Rays that leave the scene see an environment map instead of the background colour.
    pub environment: bool,
    /// Some used material attenuates light inside its body (KHR_materials_volume).
    pub volume: bool,
    /// Some used material has a clear coat (KHR_materials_clearcoat).
    pub clearcoat: bool,
}

impl Effects {
    /// Every effect.
    pub const ALL: Effects = Effects {
        shadows: true,
        reflection: true,
        refraction: true,
        textures: true,
        emission: true,
        vertex_colors: true,
        maps: true,
        normal_maps: true,
        alpha: true,
        blend: true,
        environment: true,
        volume: true,
        clearcoat: true,
    };

    /// The names of the effects that are on, in a fixed order.
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        for (on, name) in [
            (self.shadows, "shadows"),
            (self.reflection, "reflection"),
            (self.refraction, "refraction"),
            (self.textures, "textures"),
            (self.emission, "emission"),
            (self.vertex_colors, "vertex_colors"),
            (self.maps, "maps"),
            (self.normal_maps, "normal_maps"),
            (self.alpha, "alpha"),
            (self.blend, "blend"),
            (self.environment, "environment"),
            (self.volume, "volume"),
            (self.clearcoat, "clearcoat"),
        ] {
            if on {
                v.push(name);
            }
        }
        v
    }
}

/// Per-kind primitive counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PrimitiveCounts {
    pub spheres: usize,
    pub triangles: usize,
    pub cylinders: usize,
}

/// A complete scene, ready to render.
#[derive(Clone, Debug)]
pub struct Scene {
    pub camera: Camera,
    /// Lights, in file order. A light with `source == LightSource::Default` was added by
    /// the loader because the file had none (see [`Light::default_for`]).
    pub lights: Vec<Light>,
    /// Ambient light colour (multiplies `kd·color`).
    pub ambient: DVec3,
    pub background: DVec3,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub primitives: Vec<Primitive>,
    /// The image size the file asks for (NFF `resolution`), if any.
    pub resolution: Option<(u32, u32)>,
    /// The world's up direction (unit): glTF +Y, NFF the viewpoint's `up`. An environment
    /// map's top faces it.
    pub up: DVec3,
    /// What rays leaving the scene see, and the lights standing in for it, if anything.
    pub environment: Option<Environment>,
    /// How the file's colours are meant to reach a display, and so how a PNG encodes the
    /// rendered values: NFF colours are display values, glTF's are linear.
    pub transfer: Transfer,
}

impl Scene {
    pub fn counts(&self) -> PrimitiveCounts {
        let mut c = PrimitiveCounts::default();
        for p in &self.primitives {
            match p {
                Primitive::Sphere(_) => c.spheres += 1,
                Primitive::Triangle(_) => c.triangles += 1,
                Primitive::Cylinder(_) => c.cylinders += 1,
            }
        }
        c
    }

    /// Lights that came from the file (not the loader's default or the environment's).
    pub fn file_lights(&self) -> impl Iterator<Item = &Light> {
        self.lights.iter().filter(|l| l.source == LightSource::File)
    }

    /// Surrounds the scene with `env` lit by up to `lights` of its directional lights
    /// ([`Environment::lights`]), or with the background colour again (`None`). The file's
    /// own lights stay; an environment's lights replace the default headlight, which comes
    /// back without one where the file has no light.
    pub fn set_environment(&mut self, env: Option<Environment>, lights: u32) {
        self.lights.retain(|l| l.source == LightSource::File);
        match &env {
            Some(e) => self.lights.extend(e.lights(lights)),
            None if self.lights.is_empty() => self.lights.push(Light::default_for(&self.camera)),
            None => {}
        }
        self.environment = env;
    }

    /// World-space bounds of the geometry (no lights, no camera). Empty for an empty scene.
    pub fn bounds(&self) -> Aabb {
        self.primitives.iter().fold(Aabb::EMPTY, |b, p| b.union(&p.bounds()))
    }

    /// The effects this scene calls for, judged from the materials its primitives use.
    pub fn effects(&self) -> Effects {
        let mut used = vec![false; self.materials.len()];
        let mut has_tangents = vec![false; self.materials.len()];
        let mut e = Effects {
            shadows: !self.lights.is_empty() && !self.primitives.is_empty(),
            environment: self.environment.is_some(),
            ..Effects::default()
        };
        for p in &self.primitives {
            let m = p.material() as usize;
            used[m] = true;
            if let Primitive::Triangle(t) = p {
                has_tangents[m] |= t.tangent.is_some();
                e.vertex_colors |= t.color.is_some();
            }
        }
        for (i, m) in self.materials.iter().enumerate() {
            if !used[i] {
                continue;
            }
            e.reflection |= m.reflects() || m.transmits();
            e.refraction |= m.transmits();
            e.textures |= m.texture_refs().next().is_some();
            e.emission |= m.emits();
            e.maps |= m.maps.is_some();
            let coat_normal = m.clearcoat.as_ref().is_some_and(|c| c.normal_map.is_some());
            e.normal_maps |= (m.normal_map.is_some() || coat_normal) && has_tangents[i];
            e.volume |= m.attenuates();
            e.clearcoat |= m.clearcoat.is_some();
            e.alpha |= matches!(m.alpha, Alpha::Mask { .. });
            e.blend |= m.alpha == Alpha::Blend;
        }
        e
    }

    /// The kinds of primitive the scene holds (those [`Scene::counts`] finds).
    pub fn shapes(&self) -> Shapes {
        let c = self.counts();
        Shapes { spheres: c.spheres > 0, triangles: c.triangles > 0, cylinders: c.cylinders > 0 }
    }

    /// Checks the invariants listed in the module documentation. Loaders call this last;
    /// an error here is a loader bug or an unchecked input, described in words.
    pub fn validate(&self) -> Result<()> {
        self.validate_view()?;
        for (i, l) in self.lights.iter().enumerate() {
            l.validate().map_err(|e| e.within(format_args!("light {i}")))?;
        }
        for (i, m) in self.materials.iter().enumerate() {
            m.validate(self.textures.len()).map_err(|e| e.within(format_args!("material {i}")))?;
        }
        self.validate_textures()?;
        let nmat = self.materials.len();
        for (id, p) in self.primitives.iter().enumerate() {
            validate_primitive(p, nmat).map_err(|e| e.within(format_args!("primitive {id}")))?;
        }
        Ok(())
    }

    /// Ok when the camera, the background, the up vector (a unit vector), the environment
    /// and the ambient light are valid; the error names the first that is not.
    fn validate_view(&self) -> Result<()> {
        self.camera.validate()?;
        finite3(self.background, "background")?;
        if !(self.up.is_finite() && (self.up.length() - 1.0).abs() < 1e-9) {
            return Err(Error::Scene(format!("up {} is not a unit vector", self.up)));
        }
        if let Some(env) = &self.environment {
            env.validate()?;
        }
        finite3(self.ambient, "ambient")
    }

    /// Ok when every texture has a non-empty size and exactly its width × height texels;
    /// the error names the first that does not.
    fn validate_textures(&self) -> Result<()> {
        for (i, t) in self.textures.iter().enumerate() {
            if t.width == 0 || t.height == 0 || t.texels.len() != (t.width as usize) * (t.height as usize) {
                return Err(Error::Scene(format!(
                    "texture {i}: size {}x{} does not match its {} texels",
                    t.width,
                    t.height,
                    t.texels.len()
                )));
            }
        }
        Ok(())
    }
}
