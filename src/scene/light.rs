//! Lights: NFF positional lights and glTF KHR_lights_punctual point, spot and directional
//! lights, plus the default light a loader adds when a file has none.

use glam::DVec3;

use super::Camera;
use crate::error::{Error, Result};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Emits equally in every direction from `position`.
    Point,
    /// glTF spot light: full intensity inside `inner_cone`, none outside `outer_cone`
    /// (half-angles in radians, 0 ≤ inner < outer ≤ π/2), smooth in between as glTF
    /// defines it.
    Spot { inner_cone: f64, outer_cone: f64 },
    /// Parallel light travelling along `direction`; `position` is unused.
    Directional,
}

/// Where a light came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSource {
    File,
    /// Added by the loader because the file has no light (see [`Light::default_for`]).
    Default,
    /// One of the directional lights standing in for the environment
    /// ([`super::Environment::lights`]).
    Environment,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub kind: LightKind,
    pub position: DVec3,
    /// Unit direction the light travels in (spot and directional lights).
    pub direction: DVec3,
    /// Linear RGB colour.
    pub color: DVec3,
    /// Scalar intensity: glTF candela (point, spot) or lux (directional); NFF lights have
    /// the SPD suggestion `sqrt(L)/(2L)` for L lights.
    pub intensity: f64,
    /// True for physically based lights whose irradiance falls off with the inverse
    /// square of the distance (glTF point and spot). NFF lights do not fall off.
    pub inverse_square: bool,
    /// glTF `range`: beyond it the light contributes nothing.
    pub range: Option<f64>,
    pub source: LightSource,
}

impl Light {
    /// The documented default for files without lights: a white point light at the
    /// camera (a "headlight", so that everything the camera sees is lit), intensity 1,
    /// without distance falloff.
    pub fn default_for(camera: &Camera) -> Light {
        Light {
            kind: LightKind::Point,
            position: camera.eye,
            direction: camera.forward,
            color: DVec3::ONE,
            intensity: 1.0,
            inverse_square: false,
            range: None,
            source: LightSource::Default,
        }
    }

    /// A light without falloff at `position` (NFF `l`).
    pub fn point(position: DVec3, color: DVec3, intensity: f64) -> Light {
        Light {
            kind: LightKind::Point,
            position,
            direction: DVec3::NEG_Z,
            color,
            intensity,
            inverse_square: false,
            range: None,
            source: LightSource::File,
        }
    }

    pub fn validate(&self) -> Result<()> {
        if !(self.position.is_finite() && self.direction.is_finite() && self.color.is_finite()) {
            return Err(Error::Scene("position, direction or colour is not finite".into()));
        }
        if (self.direction.length() - 1.0).abs() > 1e-6 {
            return Err(Error::Scene("direction is not a unit vector".into()));
        }
        if !(self.intensity.is_finite() && self.intensity >= 0.0) {
            return Err(Error::Scene(format!("intensity {} is not finite and non-negative", self.intensity)));
        }
        if let Some(r) = self.range {
            if !(r.is_finite() && r > 0.0) {
                return Err(Error::Scene(format!("range {r} is not positive")));
            }
        }
        if let LightKind::Spot { inner_cone, outer_cone } = self.kind {
            if !(0.0 <= inner_cone
                && inner_cone < outer_cone
                && outer_cone <= std::f64::consts::FRAC_PI_2 + 1e-9)
            {
                return Err(Error::Scene(format!("spot cone angles inner {inner_cone} and outer {outer_cone} are not 0 <= inner < outer <= pi/2")));
            }
        }
        Ok(())
    }
}
