//! The camera and the one function that turns an image position into a primary ray.
//!
//! Image coordinates are continuous: (0, 0) is the top-left corner of the image, x grows
//! to the right and y downwards, and pixel (i, j) has its centre at (i + 0.5, j + 0.5).
//! Screen-right is `forward × up`: right-handed glTF files and the left-handed SPD
//! databases both come out as their reference images show them.

use glam::DVec3;

use crate::error::{Error, Result};

/// How the field of view is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovSpan {
    /// Between the outer edges of the image (glTF `yfov`).
    ImageEdges,
    /// Between the centres of the first and last pixel rows (NFF `angle`).
    EdgePixelCenters,
}

/// The camera the command line asks for instead of the file's, part by part
/// ([`Camera::overridden`]): each `None` keeps the file's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewOverride {
    /// `--look-from`: the eye.
    pub from: Option<DVec3>,
    /// `--look-at`: the point at the image's centre.
    pub at: Option<DVec3>,
    /// `--up`: the up hint (need not be orthogonal to the view).
    pub up: Option<DVec3>,
    /// `--fov`: the vertical field of view in degrees, between the image's outer edges.
    pub fov_degrees: Option<f64>,
}

impl ViewOverride {
    pub fn is_empty(&self) -> bool {
        *self == ViewOverride::default()
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// `fov_y`: full vertical field of view in radians, in (0, π).
    Perspective { fov_y: f64, span: FovSpan },
    /// `half_height`: half the height of the view volume in world units (glTF `ymag`).
    /// The width follows from the image aspect.
    Orthographic { half_height: f64 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    /// Unit viewing direction.
    pub forward: DVec3,
    /// Unit up vector, orthogonal to `forward`.
    pub up: DVec3,
    /// Unit screen-right vector, `forward × up`.
    pub right: DVec3,
    pub projection: Projection,
    /// The point the camera looks at (NFF `at`; for a camera given by its orientation alone,
    /// a point along `forward`): what `--look-at` replaces, and what `info` prints.
    pub target: DVec3,
    /// Near clipping distance from the file (NFF `hither`, glTF `znear`). Recorded only:
    /// a ray tracer has no use for it, and the renderers start rays at the eye.
    pub near: f64,
    /// Width / height the file suggests (glTF `aspectRatio`), used for the default image
    /// size when the file gives no resolution.
    pub aspect_hint: Option<f64>,
}

impl Camera {
    /// A camera at `eye` looking at `at`. `up` need not be orthogonal to the view
    /// direction, only not parallel to it. Returns an error for degenerate input.
    pub fn look_at(eye: DVec3, at: DVec3, up: DVec3, projection: Projection) -> Result<Camera> {
        if !(eye.is_finite() && at.is_finite() && up.is_finite()) {
            return Err(Error::Scene("camera position, target or up vector is not finite".into()));
        }
        let f = at - eye;
        if f.length_squared() == 0.0 {
            return Err(Error::Scene("camera eye and look-at point coincide".into()));
        }
        Ok(Camera { target: at, ..Self::from_basis(eye, f, up, projection)? })
    }

    /// A camera looking along `forward` (any length) with the given `up` hint, its target one
    /// unit ahead.
    pub fn from_basis(eye: DVec3, forward: DVec3, up: DVec3, projection: Projection) -> Result<Camera> {
        let forward = forward.normalize();
        let right = forward.cross(up);
        if right.length() <= 1e-12 * up.length() || !right.is_finite() {
            return Err(Error::Scene("camera up vector is zero or parallel to the viewing direction".into()));
        }
        let right = right.normalize();
        let up = right.cross(forward).normalize();
        let cam = Camera {
            eye,
            forward,
            up,
            right,
            projection,
            target: eye + forward,
            near: 0.0,
            aspect_hint: None,
        };
        cam.validate()?;
        Ok(cam)
    }

    pub fn validate(&self) -> Result<()> {
        for (v, what) in
            [(self.eye, "eye"), (self.forward, "forward"), (self.up, "up"), (self.right, "right")]
        {
            if !v.is_finite() {
                return Err(Error::Scene(format!("camera {what} is not finite")));
            }
        }
        match self.projection {
            Projection::Perspective { fov_y, .. } => {
                if !(fov_y.is_finite() && fov_y > 0.0 && fov_y < std::f64::consts::PI) {
                    return Err(Error::Scene(format!(
                        "camera field of view {} degrees is not in (0, 180)",
                        fov_y.to_degrees()
                    )));
                }
            }
            Projection::Orthographic { half_height } => {
                if !(half_height.is_finite() && half_height > 0.0) {
                    return Err(Error::Scene(format!(
                        "orthographic camera half-height {half_height} is not positive"
                    )));
                }
            }
        }
        Ok(())
    }

    /// Screen-plane offsets (along `right`, along `up`) of image position (x, y) for a
    /// `width`×`height` image, in units where the perspective image plane is at distance 1.
    pub fn screen_offsets(&self, x: f64, y: f64, width: u32, height: u32) -> (f64, f64) {
        let (w, h) = (width as f64, height as f64);
        let (half_extent, half_pixels) = match self.projection {
            Projection::Perspective { fov_y, span } => {
                let t = (fov_y * 0.5).tan();
                match span {
                    FovSpan::EdgePixelCenters if height > 1 => (t, (h - 1.0) * 0.5),
                    _ => (t, h * 0.5),
                }
            }
            Projection::Orthographic { half_height } => (half_height, h * 0.5),
        };
        let scale = half_extent / half_pixels;
        ((x - w * 0.5) * scale, (h * 0.5 - y) * scale)
    }

    /// The primary ray through image position (x, y): origin and unit direction.
    pub fn ray(&self, x: f64, y: f64, width: u32, height: u32) -> (DVec3, DVec3) {
        let (sx, sy) = self.screen_offsets(x, y, width, height);
        match self.projection {
            Projection::Perspective { .. } => {
                (self.eye, (self.forward + self.right * sx + self.up * sy).normalize())
            }
            Projection::Orthographic { .. } => (self.eye + self.right * sx + self.up * sy, self.forward),
        }
    }

    /// This camera with the parts `o` gives replaced (`--look-from`, `--look-at`, `--up`,
    /// `--fov`): a new eye or target looks from the one to the other with `o.up`, else
    /// `world_up`, as the up hint (the camera's own up where neither moves); a field of view
    /// makes it a perspective camera measured between the image's outer edges.
    pub fn overridden(&self, o: &ViewOverride, world_up: DVec3) -> Result<Camera> {
        if o.is_empty() {
            return Ok(self.clone());
        }
        let projection = match o.fov_degrees {
            Some(f) => Projection::Perspective { fov_y: f.to_radians(), span: FovSpan::ImageEdges },
            None => self.projection,
        };
        let moved = o.from.is_some() || o.at.is_some();
        let (eye, target) = (o.from.unwrap_or(self.eye), o.at.unwrap_or(self.target));
        let up = o.up.unwrap_or(if moved { world_up } else { self.up });
        let mut cam = if moved || o.up.is_some() {
            if (target - eye).length_squared() == 0.0 {
                return Err(Error::Options(format!(
                    "the camera looks from {eye} at {target}: the look-from and look-at points coincide"
                )));
            }
            Camera::look_at(eye, target, up, projection).map_err(|e| {
                Error::Options(format!(
                    "the camera from {eye} to {target} with up {up}: {}",
                    e.into_message()
                ))
            })?
        } else {
            Camera { projection, ..self.clone() }
        };
        cam.near = self.near;
        cam.aspect_hint = self.aspect_hint;
        cam.validate().map_err(|e| Error::Options(format!("--fov: {}", e.into_message())))?;
        Ok(cam)
    }

    /// The vertical field of view in degrees between the image's outer edges (what `--fov`
    /// sets) at an image `height` pixels high; `None` for an orthographic camera.
    pub fn fov_edges_degrees(&self, height: u32) -> Option<f64> {
        match self.projection {
            Projection::Perspective { fov_y, span: FovSpan::ImageEdges } => Some(fov_y.to_degrees()),
            Projection::Perspective { fov_y, span: FovSpan::EdgePixelCenters } => {
                let h = height as f64;
                let t = (fov_y * 0.5).tan() * if height > 1 { h / (h - 1.0) } else { 1.0 };
                Some((2.0 * t.atan()).to_degrees())
            }
            Projection::Orthographic { .. } => None,
        }
    }

    /// The image size to use when neither the file nor the user gives one: 512 pixels
    /// high, and wide as the camera's aspect hint says (square without one).
    pub fn default_resolution(&self) -> (u32, u32) {
        let aspect = self.aspect_hint.filter(|a| a.is_finite() && *a > 0.0).unwrap_or(1.0);
        (((512.0 * aspect).round() as u32).clamp(1, 8192), 512)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(span: FovSpan) -> Camera {
        Camera::look_at(
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::Y,
            Projection::Perspective { fov_y: 90f64.to_radians(), span },
        )
        .unwrap()
    }

    #[test]
    fn right_is_forward_cross_up() {
        let c = cam(FovSpan::ImageEdges);
        assert!((c.right - DVec3::X).length() < 1e-15);
        // Right half of the image looks to +x, top half to +y.
        let (_, d) = c.ray(3.0, 1.0, 4, 4);
        assert!(d.x > 0.0 && d.y > 0.0);
    }

    #[test]
    fn fov_spans() {
        // Image edges: the top edge (y = 0) is at 45°.
        let c = cam(FovSpan::ImageEdges);
        let (_, d) = c.ray(2.0, 0.0, 4, 4);
        assert!((d.y / -d.z - 1.0).abs() < 1e-12);
        // Pixel centres: the centre of the top row (y = 0.5) is at 45°.
        let c = cam(FovSpan::EdgePixelCenters);
        let (_, d) = c.ray(2.0, 0.5, 4, 4);
        assert!((d.y / -d.z - 1.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_cameras_are_errors() {
        let p = Projection::Perspective { fov_y: 1.0, span: FovSpan::ImageEdges };
        assert!(Camera::look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y, p).is_err());
        assert!(Camera::look_at(DVec3::ZERO, DVec3::Y, DVec3::Y, p).is_err());
        assert!(Camera::look_at(DVec3::ZERO, DVec3::X, DVec3::NAN, p).is_err());
        let bad = Projection::Perspective { fov_y: 4.0, span: FovSpan::ImageEdges };
        assert!(Camera::look_at(DVec3::ZERO, DVec3::X, DVec3::Y, bad).is_err());
    }
}
