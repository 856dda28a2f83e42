//! The primitives a scene is made of (spheres, cylinders and cones, triangles), their
//! bounding boxes, and the checks a loader's primitives pass.

use glam::{DVec2, DVec3, DVec4};

use crate::error::{Error, Result};

/// A sphere. `inside_only` means only the inside surface is visible (NFF negative radius).
#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    pub center: DVec3,
    /// Strictly positive.
    pub radius: f64,
    pub inside_only: bool,
    pub material: u32,
}

/// A cylinder or truncated cone without end caps (NFF `c`).
#[derive(Clone, Debug, PartialEq)]
pub struct Cylinder {
    pub base: DVec3,
    /// Non-negative; at most one of the two radii is zero (a cone ending in a point).
    pub base_radius: f64,
    pub apex: DVec3,
    /// Non-negative; equal to `base_radius` for a cylinder.
    pub apex_radius: f64,
    pub inside_only: bool,
    pub material: u32,
}

/// A triangle with optional per-vertex shading normals and texture coordinates.
///
/// The geometric normal is `(p1 − p0) × (p2 − p0)`; the winding is counter-clockwise seen
/// from the front. Renderers intersect both sides.
#[derive(Clone, Debug, PartialEq)]
pub struct Triangle {
    pub p: [DVec3; 3],
    /// Unit shading normals (NFF `pp`, glTF NORMAL).
    pub n: Option<[DVec3; 3]>,
    /// Texture coordinates, set 0 (glTF TEXCOORD_0).
    pub uv: Option<[DVec2; 3]>,
    /// Texture coordinates, set 1 (glTF TEXCOORD_1); boxed, as few scenes have a second set.
    pub uv1: Option<Box<[DVec2; 3]>>,
    /// Unit tangents (xyz) and the bitangent's sign (w, ±1) of a normal-mapped triangle (glTF
    /// TANGENT, or MikkTSpace's): the bitangent is `w·(n × t)`.
    pub tangent: Option<Box<[DVec4; 3]>>,
    /// Linear RGB vertex colours that multiply the base colour (glTF COLOR_0); boxed, as
    /// few scenes have them and every triangle would carry their room.
    pub color: Option<Box<[DVec3; 3]>>,
    pub material: u32,
}

impl Triangle {
    /// A triangle with no attributes.
    pub fn new(p: [DVec3; 3], material: u32) -> Triangle {
        Triangle { p, n: None, uv: None, uv1: None, tangent: None, color: None, material }
    }

    /// Its texture coordinate sets (`None` where absent), interpolated at barycentrics
    /// (`b1`, `b2`).
    pub fn uvs_at(&self, b1: f64, b2: f64) -> [Option<DVec2>; 2] {
        let b0 = 1.0 - b1 - b2;
        let at = |uv: &[DVec2; 3]| uv[0] * b0 + uv[1] * b1 + uv[2] * b2;
        [self.uv.as_ref().map(at), self.uv1.as_deref().map(at)]
    }
    /// Unnormalised geometric normal.
    pub fn cross(&self) -> DVec3 {
        (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0])
    }

    /// True when the triangle has (numerically) no area relative to its size, or a
    /// non-finite coordinate. Such triangles can never be hit reliably and are dropped.
    pub fn is_degenerate(&self) -> bool {
        if !self.p.iter().all(|p| p.is_finite()) {
            return true;
        }
        let e0 = (self.p[1] - self.p[0]).length_squared();
        let e1 = (self.p[2] - self.p[1]).length_squared();
        let e2 = (self.p[0] - self.p[2]).length_squared();
        let longest = e0.max(e1).max(e2);
        let area2 = self.cross().length_squared();
        // |cross|² = (2·area)²; compare with the squared longest edge to be scale free:
        // the triangle's height over its longest edge is below ~1e-12 of that edge.
        longest == 0.0 || area2 <= longest * longest * 1e-24
    }
}

/// One renderable primitive. Its object id is its index in [`Scene::primitives`].
#[derive(Clone, Debug, PartialEq)]
pub enum Primitive {
    Sphere(Sphere),
    Triangle(Triangle),
    Cylinder(Cylinder),
}

impl Primitive {
    pub fn material(&self) -> u32 {
        match self {
            Primitive::Sphere(s) => s.material,
            Primitive::Triangle(t) => t.material,
            Primitive::Cylinder(c) => c.material,
        }
    }

    /// Axis-aligned bounds of the primitive.
    pub fn bounds(&self) -> Aabb {
        match self {
            Primitive::Sphere(s) => {
                Aabb { min: s.center - DVec3::splat(s.radius), max: s.center + DVec3::splat(s.radius) }
            }
            Primitive::Triangle(t) => {
                let mut b = Aabb::EMPTY;
                for p in t.p {
                    b.grow(p);
                }
                b
            }
            Primitive::Cylinder(c) => {
                // Each end is a disc; a disc of radius r with unit normal a spans
                // r·sqrt(1 − a_i²) along axis i.
                let axis = (c.apex - c.base).normalize();
                let ext = (DVec3::ONE - axis * axis).max(DVec3::ZERO).map(f64::sqrt);
                let mut b = Aabb::EMPTY;
                b.grow(c.base - ext * c.base_radius);
                b.grow(c.base + ext * c.base_radius);
                b.grow(c.apex - ext * c.apex_radius);
                b.grow(c.apex + ext * c.apex_radius);
                b
            }
        }
    }

    /// A bounding sphere (centre, radius) of the primitive.
    pub fn bounding_sphere(&self) -> (DVec3, f64) {
        match self {
            Primitive::Sphere(s) => (s.center, s.radius),
            _ => {
                let b = self.bounds();
                let c = b.center();
                let r = match self {
                    Primitive::Triangle(t) => t.p.iter().map(|p| (*p - c).length()).fold(0.0, f64::max),
                    _ => (b.max - b.min).length() * 0.5,
                };
                (c, r)
            }
        }
    }
}

/// An axis-aligned box. `EMPTY` has min = +∞ and max = −∞ so that growing it works.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: DVec3::INFINITY, max: DVec3::NEG_INFINITY };

    pub fn grow(&mut self, p: DVec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    pub fn diagonal(&self) -> f64 {
        if self.is_empty() {
            0.0
        } else {
            (self.max - self.min).length()
        }
    }
}

/// Ok when `v` is finite; the error names it as `what`.
pub(super) fn finite3(v: DVec3, what: &str) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::Scene(format!("{what} is not finite: {v}")))
    }
}

/// Ok when `p` uses one of the `nmat` materials and its shape is valid; the error says
/// what is wrong, without naming the primitive.
pub(super) fn validate_primitive(p: &Primitive, nmat: usize) -> Result<()> {
    if p.material() as usize >= nmat {
        return Err(Error::Scene(format!(
            "material index {} out of range ({} materials)",
            p.material(),
            nmat
        )));
    }
    match p {
        Primitive::Sphere(s) => validate_sphere(s),
        Primitive::Cylinder(c) => validate_cylinder(c),
        Primitive::Triangle(t) => validate_triangle(t),
    }
}

/// Ok when the sphere's centre is finite and its radius positive and finite.
fn validate_sphere(s: &Sphere) -> Result<()> {
    finite3(s.center, "sphere centre")?;
    if !(s.radius.is_finite() && s.radius > 0.0) {
        return Err(Error::Scene(format!("sphere radius {} is not positive and finite", s.radius)));
    }
    Ok(())
}

/// Ok when the cylinder's ends are finite and distinct and its radii non-negative, finite
/// and not both zero; the error names the first fault.
fn validate_cylinder(c: &Cylinder) -> Result<()> {
    finite3(c.base, "cylinder base")?;
    finite3(c.apex, "cylinder apex")?;
    for r in [c.base_radius, c.apex_radius] {
        if !(r.is_finite() && r >= 0.0) {
            return Err(Error::Scene(format!("cylinder radius {r} is not non-negative and finite")));
        }
    }
    if c.base_radius == 0.0 && c.apex_radius == 0.0 {
        return Err(Error::Scene("cylinder radii are both zero".into()));
    }
    if c.base == c.apex {
        return Err(Error::Scene("cylinder base and apex coincide".into()));
    }
    Ok(())
}

/// Ok when the triangle is not degenerate and its optional vertex data are valid: shading
/// normals finite unit vectors, both sets of texture coordinates finite, tangents finite
/// unit vectors with sign ±1 and colours finite and non-negative; the error names the
/// first fault.
fn validate_triangle(t: &Triangle) -> Result<()> {
    let bad = |m: String| Err(Error::Scene(m));
    if t.is_degenerate() {
        return bad("degenerate or non-finite triangle".into());
    }
    if let Some(n) = &t.n {
        for v in n {
            if !v.is_finite() || (v.length() - 1.0).abs() > 1e-6 {
                return bad(format!("shading normal {v} is not a finite unit vector"));
            }
        }
    }
    if let Some(uv) = &t.uv {
        if !uv.iter().all(|u| u.is_finite()) {
            return bad("texture coordinate is not finite".into());
        }
    }
    if let Some(uv) = &t.uv1 {
        if !uv.iter().all(|u| u.is_finite()) {
            return bad("texture coordinate (set 1) is not finite".into());
        }
    }
    if let Some(tg) = &t.tangent {
        for v in tg.iter() {
            let unit = (v.truncate().length() - 1.0).abs() <= 1e-6;
            if !v.is_finite() || !unit || v.w.abs() != 1.0 {
                return bad(format!("tangent {v} is not a finite unit vector with sign ±1"));
            }
        }
    }
    if let Some(c) = &t.color {
        if !c.iter().all(|c| c.is_finite() && c.min_element() >= 0.0) {
            return bad("vertex colour is negative or not finite".into());
        }
    }
    Ok(())
}
