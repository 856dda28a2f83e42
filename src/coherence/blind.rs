//! Blind cells of triangle origins: a ray leaving a triangle starts on the side of its plane
//! it goes to (the spawn offset moves it there), so targets wholly behind every member's
//! plane are left out of the cells that point wholly to the front, and vice versa.

use glam::DVec3;

use super::cells::{CellCone, Cone};
use super::context::Ctx;
use super::defs::OriginDef;
use super::flat::OriginKind;
use super::targets::{Shape, Target};

/// The planes of a surface origin whose members are all triangles. A ray leaving a
/// triangle starts on the side of its plane it goes to (the spawn offset moves it there), so
/// while it goes to the front (`d·n > 0`) it never reaches what lies wholly behind the plane,
/// and while it goes to the back, nothing wholly in front. For a target wholly behind (in
/// front of) every member's plane, the cells whose directions all point to the members'
/// fronts (backs) are blind: the target is left out of them.
pub struct Planes {
    /// A point and the unit normal of each member.
    planes: Vec<(DVec3, DVec3)>,
    /// Every member normal lies within `beta` of `axis`.
    axis: DVec3,
    beta: f64,
}

impl Planes {
    /// `None` when a member is not a triangle or the normals spread too widely to leave
    /// any blind cell.
    pub fn of(def: &OriginDef, ctx: &Ctx) -> Option<Planes> {
        if def.kind != OriginKind::Surface || def.members.is_empty() {
            return None;
        }
        let mut planes = Vec::with_capacity(def.members.len());
        let mut sum = DVec3::ZERO;
        for &m in &def.members {
            let Shape::Triangle { v } = ctx.targets[m as usize].shape else { return None };
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            if !n.is_finite() {
                return None;
            }
            sum += n;
            planes.push((v[0], n));
        }
        let axis = sum.normalize();
        if !axis.is_finite() {
            return None;
        }
        let beta = planes.iter().map(|(_, n)| n.dot(axis).clamp(-1.0, 1.0).acos()).fold(0.0, f64::max);
        (beta + 2.0 * ctx.delta < std::f64::consts::FRAC_PI_2 - 1e-3).then_some(Planes { planes, axis, beta })
    }

    /// The cones of blind cells for target `t` (see [`Planes`]).
    pub fn blind(&self, t: &Target, delta: f64) -> [Option<Cone>; 2] {
        // The target's extreme points (repeated to fill three) and how far it reaches past them.
        let (pts, pad) = match t.shape {
            Shape::Triangle { v } => (v, 0.0),
            Shape::Sphere { c, r } => ([c; 3], r),
            Shape::Capsule { p0, p1, rad } => ([p0, p1, p1], rad),
        };
        let (mut behind, mut front) = (true, true);
        for (p, n) in &self.planes {
            // Rounding noise of the signed distances; far below the smallest spawn offset.
            let scale = pts.iter().fold(p.abs().max_element(), |m, x| m.max(x.abs().max_element()));
            let tol = 1e-12 * scale;
            let (lo, hi) = pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                let h = (*x - *p).dot(*n);
                (lo.min(h), hi.max(h))
            });
            behind &= hi + pad <= tol;
            front &= lo - pad >= -tol;
            if !(behind || front) {
                return [None, None];
            }
        }
        let half = std::f64::consts::FRAC_PI_2 - self.beta - 2.0 * delta;
        [behind.then(|| Cone::new(self.axis, half)), front.then(|| Cone::new(-self.axis, half))]
    }
}

pub fn is_blind(blind: &[Option<Cone>; 2], cell: &CellCone) -> bool {
    blind.iter().flatten().any(|k| k.contains(cell))
}

pub fn may_be_blind(blind: &[Option<Cone>; 2], cell: &CellCone) -> bool {
    blind.iter().flatten().any(|k| k.meets(cell))
}
