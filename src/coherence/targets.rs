//! What the tables are built from: targets, every primitive with its bounding shape and
//! whether it may prove that every ray of a cell hits it (an occluder: opaque, and seen from
//! outside).
//!

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
    /// May be used to prove that every ray of a cell hits it (opaque, outside-visible
    /// sphere or triangle).
    pub occluder: bool,
}

impl Target {
    pub fn of(p: &Primitive, scene: &Scene) -> Target {
        // A surface that lets rays through (glass, or alpha holes) never proves a cell covered.
        let m = &scene.materials[p.material() as usize];
        let transmits = m.transmits() || m.cut_out();
        let (center, radius) = p.bounding_sphere();
        match p {
            Primitive::Sphere(s) => Target {
                shape: Shape::Sphere { c: s.center, r: s.radius },
                center,
                radius,
                occluder: !(transmits || s.inside_only),
            },
            Primitive::Triangle(t) => {
                Target { shape: Shape::Triangle { v: t.p }, center, radius, occluder: !transmits }
            }
            Primitive::Cylinder(c) => Target {
                shape: Shape::Capsule { p0: c.base, p1: c.apex, rad: c.base_radius.max(c.apex_radius) },
                center,
                radius,
                occluder: false,
            },
        }
    }
}
