//! Texture sampling: sRGB texels decoded to linear (colour textures; data textures as
//! stored), wrap modes, bilinear or nearest; and what a material's textures give at a point:
//! the base colour's alpha, the per-hit Whitted terms, the normal-mapped normal.
//!
//! Texture coordinates follow glTF: (0, 0) is the top-left corner of the image, u grows
//! to the right and v downwards; texel (i, j) has its centre at ((i + 0.5)/W, (j + 0.5)/H).

use glam::{DVec2, DVec3, DVec4};

use super::geometry::{SurfacePoint, TangentFrame};
use crate::scene::{
    bilinear, coat_fresnel, srgb_to_linear, Material, NormalMap, Pbr, Scene, Shading, Texture, TextureRef,
    Wrap,
};

fn wrap(i: i64, n: u32, mode: Wrap) -> usize {
    let n = n as i64;
    let j = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m >= n {
                2 * n - 1 - m
            } else {
                m
            }
        }
    };
    j as usize
}

fn texel(t: &Texture, i: i64, j: i64) -> DVec4 {
    let x = wrap(i, t.width, t.wrap_s);
    let y = wrap(j, t.height, t.wrap_t);
    let c = t.texels[y * t.width as usize + x];
    let a = c[3] as f64 / 255.0;
    if t.srgb {
        DVec4::new(srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2]), a)
    } else {
        DVec4::new(c[0] as f64 / 255.0, c[1] as f64 / 255.0, c[2] as f64 / 255.0, a)
    }
}

/// The linear RGB colour of texture `t` at `uv`.
pub fn sample(t: &Texture, uv: DVec2) -> DVec3 {
    sample4(t, uv).truncate()
}

/// The RGBA value of texture `t` at `uv` (colour decoded to linear for an sRGB texture).
pub fn sample4(t: &Texture, uv: DVec2) -> DVec4 {
    // Keep coordinates in a range where the integer conversion is exact; every wrap mode
    // is periodic or constant far away, so this changes nothing visible.
    let x = (uv.x * t.width as f64).clamp(-1e12, 1e12);
    let y = (uv.y * t.height as f64).clamp(-1e12, 1e12);
    if !t.linear {
        return texel(t, x.floor() as i64, y.floor() as i64);
    }
    bilinear(x, y, |i, j| texel(t, i, j))
}

/// Texture `r` of `scene` at a point with UV sets `uv`; `None` where its set is absent.
fn read(scene: &Scene, r: Option<TextureRef>, uv: [Option<DVec2>; 2]) -> Option<DVec4> {
    let r = r?;
    Some(sample4(&scene.textures[r.texture as usize], r.uv(uv)?))
}

/// The alpha of material `m` at a point with UV sets `uv`: its opacity times the base colour
/// texture's alpha.
pub fn alpha(scene: &Scene, m: &Material, uv: [Option<DVec2>; 2]) -> f64 {
    m.opacity * read(scene, m.base_color_texture, uv).map_or(1.0, |c| c.w)
}

/// The base colour at surface point `s`: the material's, times its texture and the vertex
/// colour where there are.
pub fn base_color(scene: &Scene, m: &Material, s: &SurfacePoint) -> DVec3 {
    m.color * read(scene, m.base_color_texture, s.uv).map_or(DVec3::ONE, DVec4::truncate) * s.color
}

/// The Whitted terms of material `m` at surface point `s`: its maps evaluated there through
/// [`Pbr::whitted`], or its scalars. A map whose UV set the triangle lacks counts as 1.
pub fn shading(scene: &Scene, m: &Material, s: &SurfacePoint) -> Shading {
    let base = base_color(scene, m, s);
    let Some(maps) = m.maps.as_deref() else { return m.shading(base) };
    let mr = read(scene, maps.metallic_roughness, s.uv).unwrap_or(DVec4::ONE);
    let e = read(scene, maps.emissive, s.uv).map_or(DVec3::ONE, DVec4::truncate);
    let t = read(scene, maps.transmission_texture, s.uv).map_or(1.0, |c| c.x);
    let spec = read(scene, maps.specular_texture, s.uv).map_or(1.0, |c| c.w);
    let spec_color = read(scene, maps.specular_color_texture, s.uv).map_or(DVec3::ONE, DVec4::truncate);
    Pbr {
        base,
        metallic: maps.metallic * mr.z,
        roughness: maps.roughness * mr.y,
        transmission: maps.transmission * t,
        ior: m.ior,
        emission: maps.emission * e,
        specular: maps.specular * spec,
        specular_color: maps.specular_color * spec_color,
    }
    .whitted()
}

/// The clear coat of material `m` at surface point `s` (its interpolated normal, before any
/// normal map), for a ray arriving along `d` (unit): the coat's share of the light `k`
/// (strength × Fresnel), its mirror weight and its normal facing the ray; `None` without one.
pub fn clearcoat(scene: &Scene, m: &Material, s: &SurfacePoint, d: DVec3) -> Option<Coat> {
    let c = m.clearcoat.as_deref()?;
    let strength = read(scene, c.texture, s.uv).map_or(1.0, |t| t.x);
    let rough = read(scene, c.roughness_texture, s.uv).map_or(1.0, |t| t.y);
    let (strength, smooth) = c.at(strength, rough);
    let normal = c.normal_map.map_or(s.ns, |map| mapped(scene, map, s));
    let normal = if d.dot(s.ng) < 0.0 { normal } else { -normal };
    let k = strength * coat_fresnel(normal.dot(-d));
    Some(Coat { k, mirror: k * smooth, normal })
}

/// A clear coat at one hit ([`clearcoat`]).
pub struct Coat {
    /// The share of the light the coat reflects: what the base sends is weighted by 1 − k.
    pub k: f64,
    /// The weight of the coat's mirror ray.
    pub mirror: f64,
    /// The coat's normal, facing the viewer.
    pub normal: DVec3,
}

/// The shading normal of material `m` at `s`, through its normal map where it has one and
/// the triangle carries a tangent frame, on the side of the geometric normal.
pub fn normal(scene: &Scene, m: &Material, s: &SurfacePoint) -> DVec3 {
    m.normal_map.map_or(s.ns, |map| mapped(scene, map, s))
}

/// The normal of `s` through normal map `map` where the triangle carries a tangent frame,
/// on the side of the geometric normal (the interpolated one elsewhere).
fn mapped(scene: &Scene, map: NormalMap, s: &SurfacePoint) -> DVec3 {
    let Some(TangentFrame { n, t, sign }) = s.frame else { return s.ns };
    let Some(c) = read(scene, Some(map.texture), s.uv) else { return s.ns };
    let x = (c.x * 2.0 - 1.0) * map.scale;
    let y = (c.y * 2.0 - 1.0) * map.scale;
    let z = c.z * 2.0 - 1.0;
    let b = n.cross(t) * sign;
    let v = t * x + b * y + n * z;
    let len = v.length();
    // Too short to normalise (or NaN): keep the interpolated normal.
    if len.is_nan() || len <= 1e-12 {
        return s.ns;
    }
    let v = v / len;
    if v.dot(s.ng) < 0.0 {
        -v
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(wrap: Wrap, linear: bool) -> Texture {
        Texture {
            name: None,
            width: 2,
            height: 1,
            texels: vec![[0, 0, 0, 255], [255, 255, 255, 255]],
            wrap_s: wrap,
            wrap_t: wrap,
            linear,
            srgb: true,
        }
    }

    #[test]
    fn srgb_decoding() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        assert!((srgb_to_linear(188) - 0.5).abs() < 0.01);
    }

    #[test]
    fn nearest_and_wrap_modes() {
        let t = checker(Wrap::Repeat, false);
        assert_eq!(sample(&t, DVec2::new(0.25, 0.5)).x, 0.0);
        assert_eq!(sample(&t, DVec2::new(0.75, 0.5)).x, 1.0);
        assert_eq!(sample(&t, DVec2::new(1.25, 0.5)).x, 0.0);
        assert_eq!(sample(&t, DVec2::new(-0.25, 0.5)).x, 1.0);
        let t = checker(Wrap::ClampToEdge, false);
        assert_eq!(sample(&t, DVec2::new(5.0, 0.5)).x, 1.0);
        assert_eq!(sample(&t, DVec2::new(-5.0, 0.5)).x, 0.0);
        let t = checker(Wrap::MirroredRepeat, false);
        // [0,1) is black|white, [1,2) mirrored is white|black.
        assert_eq!(sample(&t, DVec2::new(1.25, 0.5)).x, 1.0);
        assert_eq!(sample(&t, DVec2::new(1.75, 0.5)).x, 0.0);
    }

    #[test]
    fn bilinear_interpolates_in_linear_space() {
        let t = checker(Wrap::ClampToEdge, true);
        // Halfway between the two texel centres.
        assert!((sample(&t, DVec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-12);
        assert_eq!(sample(&t, DVec2::new(0.25, 0.5)).x, 0.0);
    }
}
