//! The direction bound from an origin sphere to one target (sphere cone, triangle edge
//! functions, capsule arc), its lower distance bound, and its cover test.

use glam::DVec3;

use super::bounds::{
    point_segment_distance, point_triangle_distance, sphere_cone, sphere_inner_cone, ArcBound, TriEdges,
};
use super::cells::{CellCone, Cone};
use super::targets::{Shape, Target};

/// A direction bound from an origin sphere to one target, with its cover test.
pub struct Pair {
    pub dmin: f64,
    pub cone: Option<Cone>,
    pub edges: Option<TriEdges>,
    pub arc: Option<ArcBound>,
    pub inner: Option<(Cone, f64)>,
    pub tri_cover: bool,
}

impl Pair {
    /// `min_cover`: spheres subtending less than this (as r/d) are not tried as covers.
    pub fn new(c: DVec3, r: f64, t: &Target, eps: f64, delta: f64, min_cover: f64) -> Pair {
        let mut p = Pair { dmin: 0.0, cone: None, edges: None, arc: None, inner: None, tri_cover: false };
        match t.shape {
            Shape::Sphere { c: cb, r: rb } => {
                p.cone = sphere_cone(c, r, cb, rb + eps, delta);
                p.dmin = ((cb - c).length() - r - rb - eps).max(0.0);
                // Only spheres wide enough to cover a cell can cut lists off.
                if t.occluder && rb > min_cover * (cb - c).length() {
                    p.inner = sphere_inner_cone(c, r, cb, rb - eps, delta);
                }
            }
            Shape::Triangle { v } => {
                p.cone = sphere_cone(c, r, t.center, t.radius + eps, delta);
                p.edges = TriEdges::new(c, r + eps, &v, 0.0, delta);
                p.dmin = (point_triangle_distance(c, &v) - r - eps).max(0.0);
                p.tri_cover = t.occluder;
            }
            Shape::Capsule { p0, p1, rad } => {
                p.cone = sphere_cone(c, r, t.center, t.radius + eps, delta);
                p.arc = ArcBound::new(c, r, p0, p1, rad + eps, delta);
                p.dmin = (point_segment_distance(c, p0, p1) - r - rad - eps).max(0.0);
            }
        }
        p
    }

    /// [`Pair::new`], but a triangle seen under a cone narrower than `narrow` (radians) is
    /// bounded by its bounding sphere alone (no edge planes, no cover test): nearly as tight
    /// for small triangles, and much cheaper.
    pub fn new_coarse(
        c: DVec3,
        r: f64,
        t: &Target,
        eps: f64,
        delta: f64,
        min_cover: f64,
        narrow: f64,
    ) -> Pair {
        if let Shape::Triangle { .. } = t.shape {
            let cone = sphere_cone(c, r, t.center, t.radius + eps, delta);
            if let Some(k) = cone.filter(|k| k.theta < narrow) {
                let dmin = ((t.center - c).length() - r - t.radius - eps).max(0.0);
                return Pair { dmin, cone: Some(k), edges: None, arc: None, inner: None, tri_cover: false };
            }
        }
        Pair::new(c, r, t, eps, delta, min_cover)
    }

    #[inline]
    pub fn meets(&self, cell: &CellCone) -> bool {
        self.cone.is_none_or(|k| k.meets(cell)) && self.meets_beyond_cone(cell)
    }

    /// [`Pair::meets`] for a cell its cone already meets: the edge or arc tests alone.
    #[inline]
    pub fn meets_beyond_cone(&self, cell: &CellCone) -> bool {
        self.edges.as_ref().is_none_or(|e| e.meets(cell)) && self.arc.as_ref().is_none_or(|a| a.meets(cell))
    }

    /// True when every cell of the block meets the bound (sufficient test).
    #[inline]
    pub fn inside(&self, cell: &CellCone) -> bool {
        if let Some(e) = &self.edges {
            return e.covers(cell).is_some();
        }
        if let Some(a) = &self.arc {
            return a.contains(cell);
        }
        self.cone.is_none_or(|k| k.contains(cell))
    }

    /// Lower bound on the hit distance for directions of this cell.
    #[inline]
    pub fn cell_dmin(&self, cell: &CellCone) -> f64 {
        match &self.edges {
            Some(e) => self.dmin.max(e.plane_dmin(cell)),
            None => self.dmin,
        }
    }

    /// Upper bound on the hit distance when every ray of the cell hits the target.
    #[inline]
    pub fn covers(&self, cell: &CellCone) -> Option<f64> {
        if let Some((k, t_far)) = &self.inner {
            if k.contains(cell) {
                return Some(*t_far);
            }
        }
        if self.tri_cover {
            if let Some(e) = &self.edges {
                return e.covers(cell);
            }
        }
        None
    }
}
