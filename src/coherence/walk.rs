//! The CPU table walker: traces a ray through the flattened tables with exactly the
//! algorithm of the WGSL (see [`crate::mirror::cube_walk_nearest`]), generic over the
//! intersection routine and its float type, so that the f64 reference renderer
//! (`--accel cube`) and the f32 tests share it.
//!
//! The walker looks the cell up with the f32 direction (the same function as the GPU), then
//! merges the cell's list and the origin's always list by increasing `d_min`, stopping when the
//! next `d_min` exceeds the nearest hit so far. An f64 caller converts its unit direction to
//! f32 for the lookup only; the tables are widened for that.

use glam::Vec3;

use super::flat::{FlatTables, GpuEntry};
use super::groups::{group_hit, GROUP_BIT};

/// A ray's origin entity: what its table is keyed by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OriginKey {
    /// Primary rays from the camera.
    Eye,
    /// Shadow rays traced from light `i` (index into `Scene::lights`) toward a point.
    Light(usize),
    /// Secondary rays leaving primitive `id` (reflection, refraction, and shadow rays in
    /// [`super::ShadowMode::HitObject`]) from point `at` (the ray's origin, relative to the
    /// camera's eye as on the GPU): a large triangle's table is split into surface patches,
    /// and the point picks the patch.
    Surface(u32, Vec3),
}

/// A hit distance type: f32 on the GPU and in the tests, f64 in the reference renderer.
pub trait Dist: Copy + PartialOrd + From<f32> {
    /// The least f32 not below `self` (the far end of a group test).
    fn far_f32(self) -> f32;
}
impl Dist for f32 {
    fn far_f32(self) -> f32 {
        self
    }
}
impl Dist for f64 {
    fn far_f32(self) -> f32 {
        let f = self as f32;
        if (f as f64) >= self {
            f
        } else if f >= 0.0 {
            f32::from_bits(f.to_bits() + 1)
        } else {
            f32::from_bits(f.to_bits() - 1)
        }
    }
}

/// The counters a walk reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkCount {
    /// Intersection tests made (calls of the test closure).
    pub tests: u32,
    /// Group sphere tests made.
    pub bounds: u32,
}

impl FlatTables {
    /// The table a ray from `key` uses, or `None` when the tables have none for it (a
    /// primitive that is no surface origin, a directional light, an empty scene).
    pub fn origin(&self, key: OriginKey) -> Option<u32> {
        let o = match key {
            OriginKey::Eye => self.eye_origin,
            OriginKey::Light(i) => *self.light_origin.get(i)?,
            OriginKey::Surface(id, at) => {
                let base = *self.prim_origin.get(id as usize)?;
                match self.patch_tris.get(&id) {
                    Some(v) if base != u32::MAX => {
                        base + crate::mirror::triangle_patch(v, self.prim_patches[id as usize], at)
                    }
                    _ => base,
                }
            }
        };
        (o != u32::MAX).then_some(o)
    }

    /// Whether rays leaving primitive `id` have a table.
    pub fn has_surface(&self, id: u32) -> bool {
        self.prim_origin.get(id as usize).is_some_and(|&o| o != u32::MAX)
    }

    /// The next entry of the merged (cell, always) lists.
    #[inline]
    fn next_entry(&self, i: &mut u32, iend: u32, j: &mut u32, jend: u32) -> Option<GpuEntry> {
        let e = &self.entries;
        if *i < iend && (*j >= jend || e[*i as usize].d_min <= e[*j as usize].d_min) {
            *i += 1;
            Some(e[*i as usize - 1])
        } else if *j < jend {
            *j += 1;
            Some(e[*j as usize - 1])
        } else {
            None
        }
    }

    /// Nearest hit along `dir` (f32, non-zero; need not be unit length for the lookup, but
    /// `d_min` assumes the caller's distances are along a unit direction) from origin `o`;
    /// `at` is the ray's origin relative to the camera's eye in f32 (for the group tests).
    ///
    /// `test(id, t_best)` intersects primitive `id` and returns its hit distance, or `None`;
    /// it may drop hits farther than `t_best` but must return a hit at exactly `t_best`.
    /// Hits at `t ≥ t_max` do not count. Equal distances go to the lowest id. `skip` is never
    /// tested (`u32::MAX` for none). A group entry tests every member (bar `skip`) when the
    /// ray meets the group's sphere before the nearest hit so far.
    pub fn walk_nearest<F: Dist>(
        &self,
        o: u32,
        at: Vec3,
        dir: Vec3,
        t_max: F,
        skip: u32,
        mut test: impl FnMut(u32, F) -> Option<F>,
    ) -> (Option<(u32, F)>, WalkCount) {
        let mut count = WalkCount::default();
        let mut best: Option<(u32, F)> = None;
        if dir.abs().max_element() == 0.0 {
            return (None, count);
        }
        let unit = dir.normalize();
        let org = self.origins[o as usize];
        let [mut i, iend] = self.cell_range(o, dir);
        let mut j = org.always_start;
        let jend = org.always_start + org.always_count;
        let mut consider = |id: u32, best: &mut Option<(u32, F)>, count: &mut WalkCount| {
            if id == skip {
                return;
            }
            let t_best = best.map_or(t_max, |b| b.1);
            count.tests += 1;
            if let Some(t) = test(id, t_best) {
                let better = match *best {
                    None => t < t_max,
                    Some((bid, tb)) => t < tb || (t == tb && id < bid),
                };
                if better {
                    *best = Some((id, t));
                }
            }
        };
        while let Some(e) = self.next_entry(&mut i, iend, &mut j, jend) {
            let t_best = best.map_or(t_max, |b| b.1);
            if F::from(e.d_min) > t_best {
                break;
            }
            if e.id & GROUP_BIT != 0 {
                let g = &self.groups[(e.id & !GROUP_BIT) as usize];
                count.bounds += 1;
                if group_hit(g, at, unit, t_best.far_f32()) {
                    for &m in &self.group_prims[g.first as usize..(g.first + g.count) as usize] {
                        consider(m, &mut best, &mut count);
                    }
                }
                continue;
            }
            consider(e.id, &mut best, &mut count);
        }
        (best, count)
    }

    /// Any hit at `t < t_max` along `dir` from origin `o` (shadow rays), the ray leaving
    /// `at`. `test(id, t_max)` as for [`FlatTables::walk_nearest`].
    pub fn walk_any<F: Dist>(
        &self,
        o: u32,
        at: Vec3,
        dir: Vec3,
        t_max: F,
        skip: u32,
        mut test: impl FnMut(u32, F) -> Option<F>,
    ) -> (bool, WalkCount) {
        let mut count = WalkCount::default();
        if dir.abs().max_element() == 0.0 {
            return (false, count);
        }
        let unit = dir.normalize();
        let org = self.origins[o as usize];
        let [mut i, iend] = self.cell_range(o, dir);
        let mut j = org.always_start;
        let jend = org.always_start + org.always_count;
        let mut hits = |id: u32, count: &mut WalkCount| {
            if id == skip {
                return false;
            }
            count.tests += 1;
            test(id, t_max).is_some_and(|t| t < t_max)
        };
        while let Some(e) = self.next_entry(&mut i, iend, &mut j, jend) {
            if F::from(e.d_min) >= t_max {
                break;
            }
            if e.id & GROUP_BIT != 0 {
                let g = &self.groups[(e.id & !GROUP_BIT) as usize];
                count.bounds += 1;
                if group_hit(g, at, unit, t_max.far_f32()) {
                    for &m in &self.group_prims[g.first as usize..(g.first + g.count) as usize] {
                        if hits(m, &mut count) {
                            return (true, count);
                        }
                    }
                }
                continue;
            }
            if hits(e.id, &mut count) {
                return (true, count);
            }
        }
        (false, count)
    }

    /// The entries of the cell `dir` falls in, merged with the always list, in walk order
    /// (for tests and debugging; group entries as stored).
    pub fn candidates(&self, o: u32, dir: Vec3) -> Vec<GpuEntry> {
        let org = self.origins[o as usize];
        let [mut i, iend] = self.cell_range(o, dir);
        let mut j = org.always_start;
        let jend = org.always_start + org.always_count;
        let mut out = Vec::new();
        while let Some(e) = self.next_entry(&mut i, iend, &mut j, jend) {
            out.push(e);
        }
        out
    }
}
