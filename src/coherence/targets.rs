//! What the tables are built from: targets, every primitive with its bounding shape and its
//! self-listing and occluder flags.
//!
//! Self-listing rules: a primitive lists itself in its own origin's table (in every cell,
//! `d_min = 0`) when a ray leaving it can hit it again: it transmits (refraction rays travel
//! inside), it is an inside-only sphere (NFF negative radius: rays reflect inside it), a
//! cylinder (open, so visible from inside), or a sphere whose inside rays can reach (the eye,
//! a light or another primitive lies inside it: see
//! [`super::hierarchy::mark_enclosing`]). Reflected and shadow
//! rays leaving a sphere or a triangle from its outside cannot hit it again, so these do not
//! list themselves; the other members of a cluster are always listed where they can be seen
//! from it.

use glam::DVec3;

use crate::scene::{Primitive, Scene};

/// A target's shape as the direction bounds see it.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    Sphere {
        c: DVec3,
        r: f64,
    },
    Triangle {
        v: [DVec3; 3],
    },
    /// Every point within `rad` of the segment `p0`–`p1` (bounds a cylinder or cone).
    Capsule {
        p0: DVec3,
        p1: DVec3,
        rad: f64,
    },
}

/// One primitive as a target of the tables.
#[derive(Clone, Copy, Debug)]
pub struct Target {
    pub shape: Shape,
    /// Bounding sphere (not inflated).
    pub center: DVec3,
    pub radius: f64,
    /// Lists itself in its own origin's table.
    pub self_list: bool,
    /// May be used to prove that every ray of a cell hits it (opaque, outside-visible
    /// sphere or triangle).
    pub occluder: bool,
}

impl Target {
    pub fn of(p: &Primitive, scene: &Scene) -> Target {
        let transmits = scene.materials[p.material() as usize].transmits();
        let (center, radius) = p.bounding_sphere();
        match p {
            Primitive::Sphere(s) => Target {
                shape: Shape::Sphere { c: s.center, r: s.radius },
                center,
                radius,
                self_list: transmits || s.inside_only,
                occluder: !(transmits || s.inside_only),
            },
            Primitive::Triangle(t) => Target {
                shape: Shape::Triangle { v: t.p },
                center,
                radius,
                self_list: false,
                occluder: !transmits,
            },
            Primitive::Cylinder(c) => Target {
                shape: Shape::Capsule { p0: c.base, p1: c.apex, rad: c.base_radius.max(c.apex_radius) },
                center,
                radius,
                self_list: true,
                occluder: false,
            },
        }
    }
}
