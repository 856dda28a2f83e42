//! The preview's camera controls as plain geometry, without a window: orbit around a
//! pivot, pan, zoom and fly, starting from (and reset to) the scene's camera.
//!
//! The pivot is the point the camera looks at, at the distance of the scene's centre
//! along the view. Orbiting turns about the initial camera's up vector (yaw) and the
//! camera's right vector (pitch, stopped short of looking straight up or down). Pan and
//! fly move the eye and the pivot together; zoom moves the eye towards the pivot (an
//! orthographic camera scales its view volume instead).

use glam::{DQuat, DVec3};

use crate::scene::{Camera, Projection, Scene};

/// Radians per pixel dragged.
const ORBIT_RATE: f64 = 0.005;
/// Distance factor per wheel line.
const ZOOM_STEP: f64 = 0.9;
/// The closest angle between the view direction and the up vector (radians).
const MIN_POLE_ANGLE: f64 = 0.02;

/// A camera being moved by the user.
#[derive(Clone, Debug)]
pub struct Controller {
    initial: Camera,
    initial_pivot: f64,
    camera: Camera,
    /// Distance from the eye to the pivot along the view.
    pivot_distance: f64,
    /// Fly speed (scene units per second) and the smallest pivot distance.
    scale: f64,
    world_up: DVec3,
}

impl Controller {
    pub fn new(scene: &Scene) -> Controller {
        let cam = scene.camera.clone();
        let bounds = scene.bounds();
        let (center, size) = if bounds.is_empty() {
            (cam.eye + cam.forward, 1.0)
        } else {
            (bounds.center(), bounds.diagonal().max(1e-9))
        };
        let along = (center - cam.eye).dot(cam.forward);
        let pivot_distance =
            if along > size * 1e-3 { along } else { (center - cam.eye).length().max(size * 0.5) };
        Controller {
            initial_pivot: pivot_distance,
            world_up: cam.up,
            camera: cam.clone(),
            initial: cam,
            pivot_distance,
            scale: size,
        }
    }

    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Back to the scene's camera.
    pub fn reset(&mut self) {
        self.camera = self.initial.clone();
        self.pivot_distance = self.initial_pivot;
    }

    fn pivot(&self) -> DVec3 {
        self.camera.eye + self.camera.forward * self.pivot_distance
    }

    /// Rebuilds the camera from an eye and a view direction; keeps the old one when they
    /// are degenerate.
    fn look(&mut self, eye: DVec3, forward: DVec3) {
        if let Ok(mut c) = Camera::from_basis(eye, forward, self.world_up, self.camera.projection) {
            c.near = self.camera.near;
            c.aspect_hint = self.camera.aspect_hint;
            self.camera = c;
        }
    }

    /// Orbits about the pivot by a mouse drag of (dx, dy) pixels.
    pub fn orbit(&mut self, dx: f64, dy: f64) {
        let pivot = self.pivot();
        let offset = self.camera.eye - pivot;
        let yaw = DQuat::from_axis_angle(self.world_up, -dx * ORBIT_RATE);
        let mut offset = yaw * offset;
        let right = (yaw * self.camera.right).normalize();
        let pitched = DQuat::from_axis_angle(right, -dy * ORBIT_RATE) * offset;
        // Keep the view direction away from the up vector's poles.
        let cos = (-pitched).normalize().dot(self.world_up);
        if cos.abs() < MIN_POLE_ANGLE.cos() {
            offset = pitched;
        }
        self.look(pivot + offset, -offset);
    }

    /// Orbits about the pivot by `degrees` sideways, as a left drag of that angle would
    /// (`--orbit`).
    pub fn orbit_degrees(&mut self, degrees: f64) {
        self.orbit(degrees.to_radians() / ORBIT_RATE, 0.0);
    }

    /// Pans by a mouse drag of (dx, dy) pixels in a `height`-pixel-high view: the point
    /// under the cursor at the pivot's depth follows the cursor.
    pub fn pan(&mut self, dx: f64, dy: f64, height: u32) {
        let per_pixel = match self.camera.projection {
            Projection::Perspective { fov_y, .. } => 2.0 * (fov_y * 0.5).tan() * self.pivot_distance,
            Projection::Orthographic { half_height } => 2.0 * half_height,
        } / height.max(1) as f64;
        let shift = (-self.camera.right * dx + self.camera.up * dy) * per_pixel;
        self.camera.eye += shift;
    }

    /// Zooms by `lines` wheel lines (positive: closer).
    pub fn zoom(&mut self, lines: f64) {
        let f = ZOOM_STEP.powf(lines);
        match &mut self.camera.projection {
            Projection::Orthographic { half_height } => *half_height *= f,
            Projection::Perspective { .. } => {
                let pivot = self.pivot();
                let d = (self.pivot_distance * f).max(self.scale * 1e-4);
                self.camera.eye = pivot - self.camera.forward * d;
                self.pivot_distance = d;
            }
        }
    }

    /// Flies for `seconds` along (right, up, forward) components of `dir` (each in
    /// -1..=1), at a speed set by the scene's size.
    pub fn fly(&mut self, dir: DVec3, seconds: f64) {
        let c = &self.camera;
        let v = c.right * dir.x + self.world_up * dir.y + c.forward * dir.z;
        self.camera.eye += v * (0.25 * self.scale * seconds);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::FovSpan;

    fn scene() -> Scene {
        let mut s = crate::load::showcase().unwrap().scene;
        s.camera = Camera::look_at(
            DVec3::new(0.0, 0.0, 10.0),
            DVec3::ZERO,
            DVec3::Y,
            Projection::Perspective { fov_y: 0.8, span: FovSpan::ImageEdges },
        )
        .unwrap();
        s
    }

    #[test]
    fn orbit_keeps_the_pivot_in_view_and_its_distance() {
        let mut c = Controller::new(&scene());
        let pivot = c.pivot();
        c.orbit(200.0, -80.0);
        let cam = c.camera();
        assert!((cam.eye - pivot).length() - c.pivot_distance < 1e-9);
        assert!((cam.eye + cam.forward * c.pivot_distance - pivot).length() < 1e-9);
        assert!((cam.eye - DVec3::new(0.0, 0.0, 10.0)).length() > 0.1, "the eye moved");
        c.reset();
        assert_eq!(c.camera().eye, DVec3::new(0.0, 0.0, 10.0));
    }

    #[test]
    fn orbit_stops_short_of_the_pole() {
        let mut c = Controller::new(&scene());
        c.orbit(0.0, 10_000.0);
        assert!(c.camera().forward.dot(DVec3::Y).abs() < MIN_POLE_ANGLE.cos() + 1e-12);
        assert!(c.camera().validate().is_ok());
    }

    #[test]
    fn zoom_pan_and_fly_move_the_eye() {
        let mut c = Controller::new(&scene());
        let d0 = c.pivot_distance;
        c.zoom(3.0);
        assert!(c.pivot_distance < d0);
        let e = c.camera().eye;
        c.pan(10.0, 0.0, 100);
        assert!(c.camera().eye.x < e.x, "dragging right moves the view left");
        let e = c.camera().eye;
        c.fly(DVec3::new(0.0, 0.0, 1.0), 1.0);
        assert!(c.camera().eye.z < e.z, "forward is -z here");
    }
}
