//! Cameras (glTF perspective and orthographic, or one framing the scene when the file
//! has none) and KHR_lights_punctual lights, placed by their nodes' world transforms.

use glam::{DMat3, DMat4, DVec3};
use gltf::json::camera::Type as CameraType;
use gltf::khr_lights_punctual::Kind;
use gltf::Document;

use super::geometry::Placed;
use super::Ctx;
use crate::error::Error;
use crate::scene::{Aabb, Camera, FovSpan, Light, LightKind, LightSource, Projection};

/// Direction from the scene's centre towards the automatic camera (before normalising).
pub const AUTO_CAMERA_DIRECTION: DVec3 = DVec3::new(1.0, 0.6, 1.4);
/// Vertical field of view of the automatic camera, in degrees.
pub const AUTO_CAMERA_FOV_DEGREES: f64 = 45.0;

/// The unit direction a node's −Z axis points to in world space, if it has one.
fn node_forward(world: &DMat4) -> Option<DVec3> {
    let d = DMat3::from_mat4(*world) * DVec3::NEG_Z;
    let len = d.length();
    (len > 0.0 && len.is_finite()).then(|| d / len)
}

/// The camera of `placed` (a camera node): it looks down the node's −Z with +Y up; any
/// scale in the node's transform is removed.
pub fn camera(ctx: &Ctx, doc: &Document, placed: &Placed) -> Result<Camera, Error> {
    let loc = format!("nodes[{}] (cameras[{}])", placed.node, placed.item);
    let json = &doc.as_json().cameras[placed.item];
    let (projection, near, aspect_hint) = match (json.type_, &json.perspective, &json.orthographic) {
        (gltf::json::validation::Checked::Valid(CameraType::Perspective), Some(p), _) => {
            let aspect = p.aspect_ratio.map(f64::from);
            if aspect.is_some_and(|a| !(a.is_finite() && a > 0.0)) {
                return Err(
                    ctx.err(loc, format!("aspectRatio {} is not positive", aspect.unwrap_or_default()))
                );
            }
            (
                Projection::Perspective { fov_y: p.yfov as f64, span: FovSpan::ImageEdges },
                p.znear as f64,
                aspect,
            )
        }
        (gltf::json::validation::Checked::Valid(CameraType::Orthographic), _, Some(o)) => {
            let (xmag, ymag) = (o.xmag.abs() as f64, o.ymag.abs() as f64);
            if !(ymag > 0.0 && ymag.is_finite() && xmag > 0.0 && xmag.is_finite()) {
                return Err(ctx
                    .err(loc, format!("orthographic xmag {} and ymag {} must be non-zero", o.xmag, o.ymag)));
            }
            (Projection::Orthographic { half_height: ymag }, o.znear as f64, Some(xmag / ymag))
        }
        _ => return Err(ctx.err(loc, "the camera's type does not match its perspective/orthographic object")),
    };
    let world = &placed.world;
    let eye = world.transform_point3(DVec3::ZERO);
    let forward = node_forward(world).ok_or_else(|| ctx.err(&loc, "the node's transform has no −Z axis"))?;
    let up = DMat3::from_mat4(*world) * DVec3::Y;
    let mut cam =
        Camera::from_basis(eye, forward, up, projection).map_err(|e| ctx.err(&loc, e.into_message()))?;
    cam.near = if near.is_finite() { near } else { 0.0 };
    cam.aspect_hint = aspect_hint;
    Ok(cam)
}

/// A perspective camera that shows all of `bounds`: it looks at the centre from
/// [`AUTO_CAMERA_DIRECTION`], far enough that the bounding sphere fits the
/// [`AUTO_CAMERA_FOV_DEGREES`] field of view.
pub fn framing_camera(bounds: &Aabb) -> Result<Camera, Error> {
    let center = bounds.center();
    let radius = (bounds.diagonal() * 0.5).max(f64::MIN_POSITIVE);
    let fov = AUTO_CAMERA_FOV_DEGREES.to_radians();
    let distance = radius / (fov * 0.5).sin();
    let eye = center + AUTO_CAMERA_DIRECTION.normalize() * distance;
    let mut cam = Camera::look_at(
        eye,
        center,
        DVec3::Y,
        Projection::Perspective { fov_y: fov, span: FovSpan::ImageEdges },
    )?;
    cam.near = distance - radius;
    Ok(cam)
}

/// The KHR_lights_punctual light of `placed` (a light node): at the node's origin,
/// shining down its −Z axis.
pub fn light(ctx: &Ctx, doc: &Document, placed: &Placed) -> Result<Light, Error> {
    let loc = format!("nodes[{}] (KHR_lights_punctual.lights[{}])", placed.node, placed.item);
    let Some(l) = doc.lights().and_then(|mut ls| ls.nth(placed.item)) else {
        return Err(ctx.err(loc, "the light does not exist"));
    };
    let kind = match l.kind() {
        Kind::Point => LightKind::Point,
        Kind::Directional => LightKind::Directional,
        Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            LightKind::Spot { inner_cone: inner_cone_angle as f64, outer_cone: outer_cone_angle as f64 }
        }
    };
    let direction = match (kind, node_forward(&placed.world)) {
        (_, Some(d)) => d,
        (LightKind::Point, None) => DVec3::NEG_Z,
        (_, None) => return Err(ctx.err(loc, "the node's transform has no −Z axis to shine along")),
    };
    let [r, g, b] = l.color();
    let light = Light {
        kind,
        position: placed.world.transform_point3(DVec3::ZERO),
        direction,
        color: DVec3::new(r as f64, g as f64, b as f64),
        intensity: l.intensity() as f64,
        inverse_square: kind != LightKind::Directional,
        // glTF: range does not apply to directional lights.
        range: if kind == LightKind::Directional { None } else { l.range().map(f64::from) },
        source: LightSource::File,
    };
    light.validate().map_err(|e| ctx.err(loc, e.into_message()))?;
    Ok(light)
}
