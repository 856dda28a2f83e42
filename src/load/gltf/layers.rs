//! The glTF material inputs beyond the core metallic-roughness ones, read and checked: the
//! factors of KHR_materials_ior, _transmission, _emissive_strength, _specular and _unlit
//! as one [`Pbr`], KHR_materials_volume's attenuation, and KHR_materials_clearcoat (which
//! the gltf crate does not parse) from its JSON. How each maps onto the Whitted model is in
//! [`crate::scene`]; the textures they read are slots of `materials`.

use glam::DVec3;

use super::Ctx;
use crate::error::Error;
use crate::scene::Pbr;

/// The metallic-roughness inputs of material `m` (`materials[i]`) as factors, checked.
pub(super) fn factors(ctx: &Ctx, m: &gltf::Material, i: usize) -> Result<Pbr, Error> {
    let loc = format!("materials[{i}]");
    let pbr = m.pbr_metallic_roughness();
    let f3 = |v: [f32; 3]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
    let bc = pbr.base_color_factor();
    let base = f3([bc[0], bc[1], bc[2]]);
    let factors = match m.unlit() {
        // KHR_materials_unlit: no diffuse, specular, mirror or transmission (metallic 1 at
        // roughness 1 has none, whatever the maps), the base colour emitted.
        true => Pbr::new(base, 1.0, 1.0, 0.0, 1.5, base),
        false => Pbr {
            specular: m.specular().map_or(1.0, |s| s.specular_factor() as f64),
            specular_color: m.specular().map_or(DVec3::ONE, |s| f3(s.specular_color_factor())),
            ..Pbr::new(
                base,
                pbr.metallic_factor() as f64,
                pbr.roughness_factor() as f64,
                m.transmission().map_or(0.0, |t| t.transmission_factor() as f64),
                m.ior().map_or(1.5, f64::from),
                f3(m.emissive_factor()) * m.emissive_strength().map_or(1.0, f64::from),
            )
        },
    };
    if factors.ior.is_nan() || factors.ior < 1.0 {
        return Err(ctx.err(loc, format!("KHR_materials_ior: ior {} is not at least 1", factors.ior)));
    }
    if !(factors.base.is_finite() && factors.emission.is_finite()) {
        return Err(ctx.err(loc, "baseColorFactor and emissiveFactor must be finite"));
    }
    let spec_ok = (0.0..=1.0).contains(&factors.specular)
        && factors.specular_color.is_finite()
        && factors.specular_color.min_element() >= 0.0;
    if !spec_ok {
        return Err(ctx.err(
            format!("{loc}.extensions.KHR_materials_specular"),
            "specularFactor must be in [0, 1] and specularColorFactor finite and non-negative",
        ));
    }
    Ok(factors)
}

/// The Beer–Lambert coefficient of material `m`'s (`materials[i]`) KHR_materials_volume:
/// `−ln(attenuationColor)/attenuationDistance` per channel, zero for a thin wall (thickness
/// 0) or an infinite distance. A colour channel of 0 (all absorbed) is taken as 1e−6, so
/// that the coefficient stays finite.
pub(super) fn volume_attenuation(ctx: &Ctx, m: &gltf::Material, i: usize) -> Result<DVec3, Error> {
    let Some(v) = m.volume() else { return Ok(DVec3::ZERO) };
    let loc = format!("materials[{i}].extensions.KHR_materials_volume");
    let thickness = v.thickness_factor() as f64;
    let distance = v.attenuation_distance() as f64;
    let c = v.attenuation_color();
    let color = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
    if thickness.is_nan() || thickness < 0.0 {
        return Err(
            ctx.err(format!("{loc}.thicknessFactor"), format!("{thickness} is not a non-negative number"))
        );
    }
    if distance.is_nan() || distance <= 0.0 {
        return Err(
            ctx.err(format!("{loc}.attenuationDistance"), format!("{distance} is not a positive number"))
        );
    }
    if !(color.is_finite() && color.min_element() >= 0.0 && color.max_element() <= 1.0) {
        return Err(ctx.err(format!("{loc}.attenuationColor"), "must be three numbers in [0, 1]"));
    }
    if thickness == 0.0 || distance.is_infinite() {
        return Ok(DVec3::ZERO);
    }
    let ln = |x: f64| x.max(1e-6).ln();
    Ok(-DVec3::new(ln(color.x), ln(color.y), ln(color.z)) / distance)
}

/// KHR_materials_clearcoat's factors, checked.
#[derive(Clone, Copy)]
pub(super) struct CoatFactors {
    pub factor: f64,
    pub roughness: f64,
    pub normal_scale: f64,
}

/// KHR_materials_clearcoat as written (the gltf crate does not parse it): its factors, and
/// its JSON, which the texture slots are read from.
pub(super) struct CoatJson<'m> {
    pub factors: CoatFactors,
    pub raw: &'m serde_json::Map<String, serde_json::Value>,
}

/// Material `m`'s (`materials[i]`) clear coat, if it has one.
pub(super) fn coat_json<'m>(
    ctx: &Ctx,
    m: &'m gltf::Material,
    i: usize,
) -> Result<Option<CoatJson<'m>>, Error> {
    let Some(v) = m.extension_value("KHR_materials_clearcoat") else { return Ok(None) };
    let loc = format!("materials[{i}].extensions.KHR_materials_clearcoat");
    let raw = v.as_object().ok_or_else(|| ctx.err(&loc, "is not an object"))?;
    let number = |key: &str, default: f64, range: std::ops::RangeInclusive<f64>| -> Result<f64, Error> {
        match raw.get(key) {
            None => Ok(default),
            Some(v) => match v.as_f64() {
                Some(x) if range.contains(&x) => Ok(x),
                _ => Err(ctx.err(
                    format!("{loc}.{key}"),
                    format!("{v} is not a number in [{}, {}]", range.start(), range.end()),
                )),
            },
        }
    };
    let factor = number("clearcoatFactor", 0.0, 0.0..=1.0)?;
    let roughness = number("clearcoatRoughnessFactor", 0.0, 0.0..=1.0)?;
    let normal_scale = match raw.get("clearcoatNormalTexture").and_then(|t| t.get("scale")) {
        None => 1.0,
        Some(v) => v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
            ctx.err(format!("{loc}.clearcoatNormalTexture.scale"), format!("{v} is not a finite number"))
        })?,
    };
    Ok(Some(CoatJson { factors: CoatFactors { factor, roughness, normal_scale }, raw }))
}
