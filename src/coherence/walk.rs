//! The one table walker: a ray finds its list, the cell of its direction in the direction
//! cube of its origin entity (the eye, a light; rays without one walk the fallback origin,
//! every primitive), and walks it merged with the origin's always-test list by increasing
//! `d_min`, stopping as soon as the next `d_min` passes the nearest hit so far (the distance
//! interval optimisation).
//!
//! Line-by-line twin of the walk in `shaders/shared/walk.wgsl` (keep them in sync): the same
//! names (`cell_walk`, `walk_from`, `walk_next`, `walk_done`, `walk_nearest`, `walk_any`) and
//! the same budget, so that a walk may stop after `budget` loop iterations and resume where
//! it stopped, as the GPU's wavefront kernels do ([`WALK_CHUNK`] per pass). The queries
//! over it (`shaders/shared/query.wgsl`: `closest`, `closest_step`, `occluded*`, written
//! once for every accelerator) are the kernels' own: they keep a walk's position in its job
//! between passes and pick the ray a shadow query walks, which the CPU callers do for
//! themselves; [`table_nearest`] and [`table_any`] walk a ray's list to its end. It is
//! generic over the distance type and the hit payload
//! ([`Closest`]): the GPU-side tests walk it with the f32 intersection twins, the CPU
//! reference's `--accel cube` with its own f64 tests. Both look cells up with the f32
//! direction, as the GPU does; the tables are widened for that.

use glam::Vec3;

use super::cube::cube_cell_range;
use super::flat::{FlatTables, GpuEntry, NO_ORIGIN};
use crate::arith::closest::{consider, no_closest, Closest, Dist, TestHit};

/// Loop iterations one kernel pass spends on a walk, at most: lavapipe ends an invocation's
/// loops after 65535 iterations in all (WGSL `WALK_CHUNK`, keep them in sync).
pub const WALK_CHUNK: u32 = 8192;

/// The budget of a walk that runs to its end in one go (WGSL `UNBOUNDED`).
pub const UNBOUNDED: u32 = u32::MAX;

/// The kernels mark the walk of a ray leaving a surface with this `Walk::iend` (WGSL
/// `SURFACE_WALK`): a walk of the BVH (`shaders/shared/bvh.wgsl`: the node whose children it
/// takes in `i`, those children and its primitives left in `j`) or a ray query
/// (`shaders/shared/rayquery.wgsl`); the CPU reference walks its own BVH instead.
pub const SURFACE_WALK: u32 = u32::MAX;

pub use crate::scene::OriginKey;

/// The answer of a bounded any-hit walk (WGSL `ANY_CLEAR`, `ANY_BLOCKED`, `ANY_UNFINISHED`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnyHit {
    /// The walk ended without a hit.
    Clear = 0,
    /// A primitive is hit before `t_max`.
    Blocked = 1,
    /// The budget ran out first: resume the walk.
    Unfinished = 2,
}

/// The counters a walk adds to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkCount {
    /// Intersection tests made (calls of the test closure).
    pub tests: u32,
}

impl FlatTables {
    /// The direction cube a ray from `key` uses, or `None` when it has none (rays leaving
    /// surfaces, a directional light, an empty scene).
    pub fn cube_of(&self, key: OriginKey) -> Option<u32> {
        let o = match key {
            OriginKey::Eye => self.eye_origin,
            OriginKey::Light(i) => *self.light_origin.get(i)?,
            OriginKey::Surface(_) => NO_ORIGIN,
        };
        (o != NO_ORIGIN).then_some(o)
    }

    /// The walk of a ray from `key` along `d` (not zero): its cell of its direction cube, or
    /// the fallback origin (WGSL `walk_from` and, for lights, `cell_walk` of `light_table`).
    pub fn walk_from(&self, key: OriginKey, d: Vec3) -> Walk {
        cell_walk(self, self.cube_of(key).unwrap_or(self.fallback_origin), d)
    }
}

/// A position in the merged walk of a cell's list (`i..iend`) and the always list
/// (`j..jend`) (WGSL `Walk`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Walk {
    pub i: u32,
    pub iend: u32,
    pub j: u32,
    pub jend: u32,
}

/// The walk of direction cube `origin`'s cell for direction `d` (not zero).
pub fn cell_walk(t: &FlatTables, origin: u32, d: Vec3) -> Walk {
    let org = t.origins[origin as usize];
    let range = cube_cell_range(t, origin, d);
    Walk { i: range[0], iend: range[1], j: org.always_start, jend: org.always_start + org.always_count }
}

/// The entry the merged walk visits next; the walk must not be over ([`walk_done`]).
pub fn walk_next(t: &FlatTables, w: &mut Walk) -> GpuEntry {
    let e;
    if w.i < w.iend && (w.j >= w.jend || t.entries[w.i as usize].d_min <= t.entries[w.j as usize].d_min) {
        e = t.entries[w.i as usize];
        w.i += 1;
    } else {
        e = t.entries[w.j as usize];
        w.j += 1;
    }
    e
}

pub fn walk_done(w: &Walk) -> bool {
    w.i >= w.iend && w.j >= w.jend
}

/// Continues the nearest-hit walk `w` for at most `budget` loop iterations (an entry
/// each), keeping the hits with `0 < t < t_max` in `best` by the shared tie rule
/// ([`crate::arith::closest`]); `skip` is never tested. `test(id)` intersects primitive `id`
/// and returns its hit with `t < t_max`, if any. The walk ends once an entry's `d_min` passes
/// the tie window. True when the walk is over (then, with `best.lost`, walk again from
/// [`Closest::again`]).
#[allow(clippy::too_many_arguments)]
pub fn walk_nearest<F: Dist, H>(
    t: &FlatTables,
    w: &mut Walk,
    best: &mut Closest<F, H>,
    t_max: F,
    skip: u32,
    budget: u32,
    count: &mut WalkCount,
    mut test: impl FnMut(u32) -> Option<TestHit<F, H>>,
) -> bool {
    let mut left = budget;
    let mut limit = best.limit(t_max);
    loop {
        if walk_done(w) {
            break;
        }
        if left == 0 {
            return false;
        }
        left -= 1;
        let e = walk_next(t, w);
        if F::from(e.d_min) > limit {
            break;
        }
        if e.id == skip {
            continue;
        }
        count.tests += 1;
        limit = consider(best, e.id, test(e.id), t_max);
    }
    true
}

/// Continues the any-hit walk `w` for at most `budget` loop iterations:
/// [`AnyHit::Blocked`] when some primitive other than `skip` is hit at `0 < t < t_max`
/// (`hits(id)`), [`AnyHit::Clear`] when the walk ended without one, [`AnyHit::Unfinished`]
/// when the budget ran out first.
#[allow(clippy::too_many_arguments)]
pub fn walk_any<F: Dist>(
    t: &FlatTables,
    w: &mut Walk,
    t_max: F,
    skip: u32,
    budget: u32,
    count: &mut WalkCount,
    mut hits: impl FnMut(u32) -> bool,
) -> AnyHit {
    let mut left = budget;
    loop {
        if walk_done(w) {
            break;
        }
        if left == 0 {
            return AnyHit::Unfinished;
        }
        left -= 1;
        let e = walk_next(t, w);
        if F::from(e.d_min) >= t_max {
            break;
        }
        if e.id == skip {
            continue;
        }
        count.tests += 1;
        if hits(e.id) {
            return AnyHit::Blocked;
        }
    }
    AnyHit::Clear
}

/// The nearest hit with `0 < t < t_max` of a ray from `key` along `d`
/// ([`FlatTables::walk_from`]) by the tie rule, walked to its end (twice where the first walk
/// lost its winner); `skip` is never tested. A zero direction hits nothing.
#[allow(clippy::too_many_arguments)]
pub fn table_nearest<F: Dist, H: Default>(
    t: &FlatTables,
    key: OriginKey,
    d: Vec3,
    t_max: F,
    skip: u32,
    count: &mut WalkCount,
    mut test: impl FnMut(u32) -> Option<TestHit<F, H>>,
) -> Closest<F, H> {
    let mut best = no_closest();
    if d.abs().max_element() == 0.0 {
        return best;
    }
    let mut w = t.walk_from(key, d);
    walk_nearest(t, &mut w, &mut best, t_max, skip, UNBOUNDED, count, &mut test);
    if best.lost {
        best = best.again();
        let mut w = t.walk_from(key, d);
        walk_nearest(t, &mut w, &mut best, t_max, skip, UNBOUNDED, count, &mut test);
    }
    best
}

/// True when a ray from `key` along `d` hits some primitive other than `skip` at
/// `0 < t < t_max` (walked to its end).
pub fn table_any<F: Dist>(
    t: &FlatTables,
    key: OriginKey,
    d: Vec3,
    t_max: F,
    skip: u32,
    count: &mut WalkCount,
    hits: impl FnMut(u32) -> bool,
) -> bool {
    if d.abs().max_element() == 0.0 {
        return false;
    }
    let mut w = t.walk_from(key, d);
    walk_any(t, &mut w, t_max, skip, UNBOUNDED, count, hits) == AnyHit::Blocked
}
