//! Building the candidate tables: one table per origin, in parallel (rayon), then flattened.
//!
//! For an origin (a sphere: a point inflated by the spawn offset, or a cluster's bounding
//! sphere) the builder walks the target hierarchy nearest first. For each target it computes
//! a direction bound (sphere cone, triangle edge functions, capsule arc) and rasterises it into
//! the origin's cells, with a per-cell lower bound `d_min` on the hit distance. A target that
//! certainly covers a cell (every ray of the cell hits it before `t_far`) lowers the cell's
//! cut-off; entries whose `d_min` exceeds the final cut-off are dropped, since the walker's
//! distance interval test would never reach them, and whole hidden subtrees are skipped. For
//! clusters, targets near the cluster are bounded member by member (the union of the members'
//! bounds, with the smallest member `d_min` per cell), which keeps self and neighbour lists
//! short. Targets meeting most cells of a surface origin go to its always-test list.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::Arc;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::flat::{FlatTables, GpuEntry, GpuFace, GpuOrigin, OriginKind, MAX_BINDING_BYTES};
use super::geom::{
    cell_cone, cell_span, point_segment_distance, point_triangle_distance, region_cone, sphere_cone,
    sphere_inner_cone, ArcBound, CellCone, Cone, TriEdges,
};
use super::groups::{Groups, GROUP_BIT, GROUP_MIN_LIST, GROUP_SIZE};
use super::origins::{
    bounding_sphere, cluster, mark_enclosing, patch_counts, patch_rounding, patch_sphere, Bvh, Shape, Target,
};
use crate::error::{Error, Result};
use crate::scene::{Effects, LightKind, Projection, Scene};

/// Where shadow rays are looked up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShadowMode {
    /// Light-buffer style: each point or spot light has a table; a shadow ray is traced from
    /// the light toward the shaded point with `t_max = |P − L|·(1 − ε)`.
    LightBuffer,
    /// From the hit object's table toward the light: every primitive belongs to a surface
    /// origin.
    HitObject,
}

/// Build parameters. [`BuildParams::default`] is what `cuberay` uses.
#[derive(Clone, Debug)]
pub struct BuildParams {
    /// Total bytes the flattened tables should stay under; the builder picks the surface
    /// resolution and cluster size to fit (default 96 MiB: three quarters of the 128 MiB
    /// target, leaving room for the error of the sampled estimate). Each buffer also stays
    /// under wgpu's 128 MiB binding limit, or the build fails.
    pub budget_bytes: usize,
    /// Angular widening of every bound, radians (default 2e-5): covers the f32 cell lookup.
    pub delta: f64,
    /// Largest distance between a ray origin and the surface point it leaves from (the
    /// spawn offset) plus f32 rounding of the geometry. `None`: computed from the scene for
    /// [`crate::mirror::offset_ray_origin`] after re-centring on the camera.
    pub spawn_offset: Option<f64>,
    /// Cells per face edge for the eye; `None`: about two image pixels per cell.
    pub eye_n: Option<u32>,
    /// Cells per face edge for lights; `None`: from `light_cells`.
    pub light_n: Option<u32>,
    /// Cells per face edge for surface origins; `None`: chosen by the budget.
    pub surface_n: Option<u32>,
    /// Primitives per surface origin cluster; `None`: chosen by the budget.
    pub cluster_size: Option<usize>,
    /// The image size primary rays are made for: the eye table covers only that frustum.
    /// `None`: the scene's resolution, or the camera's default.
    pub image: Option<(u32, u32)>,
    pub shadow_mode: ShadowMode,
    /// A target meeting at least this fraction of a surface origin's cells goes to its
    /// always-test list (default 0.6).
    pub always_fraction: f64,
    /// Image pixels per eye cell, along one axis (default 2).
    pub eye_pixels_per_cell: f64,
    /// Cells a light's table aims for over the directions where objects are (default 2^18).
    pub light_cells: usize,
    /// Limit on surface origins × primitives, which bounds the build time: the cluster size
    /// grows until the product fits (default 3·10^6).
    pub pair_budget: usize,
    /// Surface-origin candidate lists at least this long name primitive groups instead of
    /// their members (default [`GROUP_MIN_LIST`]; `usize::MAX`: never).
    pub group_min_list: usize,
    /// The effects the tables serve (`None`: the scene's): light tables only with shadows,
    /// tables for reflecting and transmitting surfaces only with reflection.
    pub effects: Option<Effects>,
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            budget_bytes: 96 << 20,
            delta: 2e-5,
            spawn_offset: None,
            eye_n: None,
            light_n: None,
            surface_n: None,
            cluster_size: None,
            image: None,
            shadow_mode: ShadowMode::LightBuffer,
            always_fraction: 0.6,
            eye_pixels_per_cell: 2.0,
            light_cells: 1 << 18,
            pair_budget: 3_000_000,
            group_min_list: GROUP_MIN_LIST,
            effects: None,
        }
    }
}

/// One origin before building: its kind, its sphere (already inflated), its members and its
/// resolution and stored windows.
#[derive(Clone, Debug)]
pub struct OriginDef {
    pub kind: OriginKind,
    pub center: DVec3,
    pub radius: f64,
    /// Surface origins: the primitives whose rays use this table.
    pub members: Vec<u32>,
    /// Light origins: the light index.
    pub light: Option<usize>,
    pub n: u32,
    /// Per face, the cells searched: `[iu0, iv0, width, height]`, or `None`.
    pub window: [Option<[u32; 4]>; 6],
    /// Surface patches: `(m, index)` when this origin is patch `index` of the `m×m` patches
    /// of its one member (see [`crate::mirror::triangle_patch`]).
    pub patch: Option<(u32, u32)>,
}

/// One origin's built table, before flattening.
#[derive(Clone, Debug, Default)]
pub struct OriginTable {
    pub kind: Option<OriginKind>,
    pub n: u32,
    /// Per face, the stored window `[iu0, iv0, width, height]` (width 0: nothing stored).
    pub faces: [[u32; 4]; 6],
    /// Local CSR: the list of stored cell `c` is `entries[starts[c]..starts[c+1]]`.
    pub starts: Vec<u32>,
    pub entries: Vec<GpuEntry>,
    pub always: Vec<GpuEntry>,
}

/// Shared, read-only inputs of the per-origin builds.
pub struct Ctx<'a> {
    pub targets: &'a [Target],
    pub bvh: &'a Bvh,
    pub eps: f64,
    pub delta: f64,
    pub always_fraction: f64,
    /// The primitive groups, and the list length from which lists name them.
    pub groups: Groups,
    pub group_min_list: usize,
    cells: std::sync::Mutex<std::collections::HashMap<u32, Arc<Vec<CellCone>>>>,
}

impl<'a> Ctx<'a> {
    pub fn new(targets: &'a [Target], bvh: &'a Bvh, eps: f64, params: &BuildParams) -> Self {
        Ctx {
            targets,
            bvh,
            eps,
            delta: params.delta,
            always_fraction: params.always_fraction,
            groups: Groups::of_bvh(bvh, targets.len(), GROUP_SIZE),
            group_min_list: params.group_min_list,
            cells: Default::default(),
        }
    }

    /// All cells of an `n`-cube, cached when the cube is small.
    fn cube(&self, n: u32) -> Option<Arc<Vec<CellCone>>> {
        if n > 64 {
            return None;
        }
        let mut map = self.cells.lock().unwrap();
        Some(
            map.entry(n)
                .or_insert_with(|| {
                    let mut v = Vec::with_capacity(6 * (n * n) as usize);
                    for f in 0..6 {
                        for iv in 0..n {
                            for iu in 0..n {
                                v.push(cell_cone(f, iu, iv, n));
                            }
                        }
                    }
                    Arc::new(v)
                })
                .clone(),
        )
    }
}

/// The largest coordinate magnitude of the scene re-centred on the camera: its bounds and
/// its positional lights.
pub fn recentred_magnitude(scene: &Scene) -> f64 {
    let eye = scene.camera.eye;
    let b = scene.bounds();
    let mut m: f64 = 0.0;
    if !b.is_empty() {
        m = m.max((b.min - eye).abs().max_element()).max((b.max - eye).abs().max_element());
    }
    for l in &scene.lights {
        if l.kind != LightKind::Directional {
            m = m.max((l.position - eye).abs().max_element());
        }
    }
    m
}

/// The largest spawn offset for a scene re-centred on the camera, plus f32 rounding.
pub fn default_spawn_offset(scene: &Scene) -> f64 {
    let m = recentred_magnitude(scene);
    let off = crate::mirror::max_origin_offset(m as f32) as f64;
    // Plus a few ULPs of the largest coordinate for the geometry's own rounding to f32.
    off + 8.0 * m * f32::EPSILON as f64
}

/// A direction bound from an origin sphere to one target, with its cover test.
struct Pair {
    dmin: f64,
    cone: Option<Cone>,
    edges: Option<TriEdges>,
    arc: Option<ArcBound>,
    inner: Option<(Cone, f64)>,
    tri_cover: bool,
}

impl Pair {
    /// `min_cover`: spheres subtending less than this (as r/d) are not tried as covers.
    fn new(c: DVec3, r: f64, t: &Target, eps: f64, delta: f64, min_cover: f64) -> Pair {
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
                p.edges = TriEdges::new(c, r + eps, &v, 0.0);
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

    #[inline]
    fn meets(&self, cell: &CellCone, delta: f64) -> bool {
        self.cone.is_none_or(|k| k.meets(cell))
            && self.edges.as_ref().is_none_or(|e| e.meets(cell, delta))
            && self.arc.as_ref().is_none_or(|a| a.meets(cell))
    }

    /// True when every cell of the block meets the bound (sufficient test).
    #[inline]
    fn inside(&self, cell: &CellCone, delta: f64) -> bool {
        if let Some(e) = &self.edges {
            return e.covers(cell, delta).is_some();
        }
        if let Some(a) = &self.arc {
            return a.contains(cell);
        }
        self.cone.is_none_or(|k| k.contains(cell))
    }

    /// Lower bound on the hit distance for directions of this cell.
    #[inline]
    fn cell_dmin(&self, cell: &CellCone, delta: f64) -> f64 {
        match &self.edges {
            Some(e) => self.dmin.max(e.plane_dmin(cell, delta)),
            None => self.dmin,
        }
    }

    /// Upper bound on the hit distance when every ray of the cell hits the target.
    #[inline]
    fn covers(&self, cell: &CellCone, delta: f64) -> Option<f64> {
        if let Some((k, t_far)) = &self.inner {
            if k.contains(cell) {
                return Some(*t_far);
            }
        }
        if self.tri_cover {
            if let Some(e) = &self.edges {
                return e.covers(cell, delta);
            }
        }
        None
    }
}

/// The planes of a surface origin whose members are all triangles. A ray leaving a
/// triangle starts on the side of its plane it goes to (the spawn offset moves it there), so
/// while it goes to the front (`d·n > 0`) it never reaches what lies wholly behind the plane,
/// and while it goes to the back, nothing wholly in front. For a target wholly behind (in
/// front of) every member's plane, the cells whose directions all point to the members'
/// fronts (backs) are blind: the target is left out of them.
struct Planes {
    /// A point and the unit normal of each member.
    planes: Vec<(DVec3, DVec3)>,
    /// Every member normal lies within `beta` of `axis`.
    axis: DVec3,
    beta: f64,
}

impl Planes {
    /// `None` when a member is not a triangle or the normals spread too widely to leave
    /// any blind cell.
    fn of(def: &OriginDef, ctx: &Ctx) -> Option<Planes> {
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
    fn blind(&self, t: &Target, delta: f64) -> [Option<Cone>; 2] {
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

fn is_blind(blind: &[Option<Cone>; 2], cell: &CellCone) -> bool {
    blind.iter().flatten().any(|k| k.contains(cell))
}

fn may_be_blind(blind: &[Option<Cone>; 2], cell: &CellCone) -> bool {
    blind.iter().flatten().any(|k| k.meets(cell))
}

/// Cells of an origin's work windows, with cached or computed cell cones.
struct Cells {
    n: u32,
    win: [Option<[u32; 4]>; 6],
    base: [usize; 6],
    total: usize,
    cube: Option<Arc<Vec<CellCone>>>,
}

impl Cells {
    fn new(def: &OriginDef, ctx: &Ctx) -> Cells {
        let mut base = [0; 6];
        let mut total = 0;
        for (b, w) in base.iter_mut().zip(&def.window) {
            *b = total;
            if let Some(w) = w {
                total += (w[2] * w[3]) as usize;
            }
        }
        Cells { n: def.n, win: def.window, base, total, cube: ctx.cube(def.n) }
    }

    #[inline]
    fn cone(&self, f: usize, iu: u32, iv: u32) -> CellCone {
        match &self.cube {
            Some(c) => c[(f * self.n as usize + iv as usize) * self.n as usize + iu as usize],
            None => cell_cone(f, iu, iv, self.n),
        }
    }

    /// The window rectangle `[iu0, iv0, iu1, iv1]` of face `f` inside `cone`'s rectangle (the
    /// whole window for `None`), or `None` when empty.
    fn face_rect(&self, f: usize, cone: Option<&Cone>) -> Option<[u32; 4]> {
        let w = self.win[f]?;
        let (mut u0, mut u1, mut v0, mut v1) = (w[0], w[0] + w[2] - 1, w[1], w[1] + w[3] - 1);
        if let Some(k) = cone {
            let r = k.face_rect(f)?;
            let (a, b) = cell_span(r[0], r[1], self.n);
            let (c, d) = cell_span(r[2], r[3], self.n);
            u0 = u0.max(a);
            u1 = u1.min(b);
            v0 = v0.max(c);
            v1 = v1.min(d);
        }
        (u0 <= u1 && v0 <= v1).then_some([u0, v0, u1, v1])
    }

    #[inline]
    fn index(&self, f: usize, iu: u32, iv: u32) -> usize {
        let w = self.win[f].unwrap();
        self.base[f] + ((iv - w[1]) * w[2] + (iu - w[0])) as usize
    }

    /// Hierarchical rasterisation of a bound into the windows: blocks the bound misses are
    /// dropped, blocks of at most [`BULK`] cells wholly inside it are emitted at once (one
    /// `d_min` and cover test for the block), others are split down to single cells.
    /// `emit(cells, block)` receives the local cell indices of the block; it returns false to
    /// stop the rasterisation (then `raster` returns false).
    fn raster(
        &self,
        cone: Option<&Cone>,
        meets: impl Fn(&CellCone) -> bool,
        inside: impl Fn(&CellCone) -> bool,
        mut emit: impl FnMut(&mut dyn Iterator<Item = usize>, &CellCone) -> bool,
    ) -> bool {
        let mut stack: Vec<[u32; 4]> = Vec::new();
        for f in 0..6 {
            let Some(r) = self.face_rect(f, cone) else { continue };
            if self.cube.is_some() && (r[2] - r[0] + 1) * (r[3] - r[1] + 1) <= 16 {
                // Small rectangles: test the cached cells one by one.
                for iv in r[1]..=r[3] {
                    for iu in r[0]..=r[2] {
                        let cell = self.cone(f, iu, iv);
                        if meets(&cell) && !emit(&mut std::iter::once(self.index(f, iu, iv)), &cell) {
                            return false;
                        }
                    }
                }
                continue;
            }
            stack.push(r);
            while let Some(r) = stack.pop() {
                let (w, h) = (r[2] - r[0] + 1, r[3] - r[1] + 1);
                let single = w == 1 && h == 1;
                let region = if single { self.cone(f, r[0], r[1]) } else { region_cone(f, r, self.n) };
                if !meets(&region) {
                    continue;
                }
                if single || (w * h <= BULK && inside(&region)) {
                    let mut it = (r[1]..=r[3])
                        .flat_map(|iv| (r[0]..=r[2]).map(move |iu| (iu, iv)))
                        .map(|(iu, iv)| self.index(f, iu, iv));
                    if !emit(&mut it, &region) {
                        return false;
                    }
                    continue;
                }
                if w >= h {
                    let m = r[0] + w / 2;
                    stack.push([m, r[1], r[2], r[3]]);
                    stack.push([r[0], r[1], m - 1, r[3]]);
                } else {
                    let m = r[1] + h / 2;
                    stack.push([r[0], m, r[2], r[3]]);
                    stack.push([r[0], r[1], r[2], m - 1]);
                }
            }
        }
        true
    }
}

/// Largest block emitted without splitting.
const BULK: u32 = 16;

#[derive(Clone, Copy)]
struct Rec {
    cell: u32,
    id: u32,
    dmin: f64,
}

#[derive(PartialEq)]
struct Key(f64);
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Key {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// `x` lowered for f32 rounding and stored as the largest f32 not above it.
pub fn store_dmin(x: f64, eps: f64) -> f32 {
    let x = ((x - 2.0 * eps) * (1.0 - 1e-5)).max(0.0);
    let f = x as f32;
    if f as f64 > x {
        f32::from_bits(f.to_bits() - 1)
    } else {
        f
    }
}

/// Budget estimates made while bisecting the surface candidates.
const TRIALS: usize = 6;
/// Surface origins built per estimate.
const SAMPLE: usize = 16;

/// Surface cubes finer than N = 8 are tried only for clusters of at most 4 primitives and
/// while all surface origins together have at most this many cells.
const SURFACE_CELLS: usize = 1 << 20;

/// Light-origin targets whose bound is wider than this go to the always-test list.
const WIDE_THETA: f64 = 0.5;

fn is_wide(p: &Pair) -> bool {
    p.cone.is_none_or(|k| k.theta > WIDE_THETA)
}

/// Targets nearer than this angle from a cluster's bounding sphere are bounded per member.
const NEAR_THETA: f64 = 0.8;
/// Clusters larger than this bound every target with their bounding sphere (the per-member
/// union costs one bound per member).
const NEAR_MEMBERS: usize = 16;
/// Targets seen from a surface origin under a narrower cone than this skip the plane tests
/// of [`Planes`].
const BLIND_THETA: f64 = 0.3;
/// Hierarchy nodes whose cone is wider than this are entered without a cull test.
const CULL_THETA: f64 = 0.5;

/// Builds one origin's table.
pub fn build_origin(def: &OriginDef, ctx: &Ctx) -> OriginTable {
    let cells = Cells::new(def, ctx);
    let (eps, delta) = (ctx.eps, ctx.delta);
    // The smallest cells (at face corners) subtend about 1/n radian.
    let min_cover = 0.4 / def.n as f64;
    let mut cut = vec![f64::INFINITY; cells.total];
    let mut recs: Vec<Rec> = Vec::new();
    let mut scratch = vec![f64::INFINITY; if def.members.len() > 1 { cells.total } else { 0 }];
    let mut touched: Vec<u32> = Vec::new();
    let mut wide: Vec<GpuEntry> = Vec::new();
    let (c, r) = (def.center, def.radius);
    let planes = Planes::of(def, ctx);
    let member_spheres: Vec<(u32, DVec3, f64)> = if def.members.len() > 1 {
        def.members
            .iter()
            .map(|&m| {
                let t = &ctx.targets[m as usize];
                let (mc, mr) = match t.shape {
                    Shape::Triangle { .. } => bounding_sphere(&[m], ctx.targets),
                    _ => (t.center, t.radius),
                };
                (m, mc, mr + eps)
            })
            .collect()
    } else {
        Vec::new()
    };

    let mut heap: BinaryHeap<(Reverse<Key>, u32)> = BinaryHeap::new();
    if !ctx.bvh.nodes.is_empty() {
        heap.push((Reverse(Key(0.0)), 0));
    }
    while let Some((Reverse(Key(node_dmin)), ni)) = heap.pop() {
        let node = ctx.bvh.nodes[ni as usize];
        // Skip the subtree when every cell its bound meets is already cut off before it.
        if let Some(k) = sphere_cone(c, r, node.center, node.radius + eps, delta) {
            if k.theta < CULL_THETA {
                let hidden = cells.raster(
                    Some(&k),
                    |cell| k.meets(cell),
                    |cell| k.contains(cell),
                    |it, _| {
                        for i in it {
                            if cut[i] >= node_dmin {
                                return false;
                            }
                        }
                        true
                    },
                );
                if hidden {
                    continue;
                }
            }
        }
        if node.count == 0 {
            for ch in [node.first, node.first + 1] {
                let n = ctx.bvh.nodes[ch as usize];
                let d = ((n.center - c).length() - r - n.radius - eps).max(0.0);
                heap.push((Reverse(Key(d)), ch));
            }
            continue;
        }
        for &tid in &ctx.bvh.order[node.first as usize..(node.first + node.count) as usize] {
            let t = &ctx.targets[tid as usize];
            let own = def.kind == OriginKind::Surface && def.members.contains(&tid);
            if own && def.members.len() == 1 && !t.self_list {
                continue;
            }
            let p = Pair::new(c, r, t, eps, delta, min_cover);
            // Only targets seen over a wide angle are worth the plane tests.
            let blind = match &planes {
                Some(pl) if p.cone.is_none_or(|k| k.theta > BLIND_THETA) => pl.blind(t, delta),
                _ => [None, None],
            };
            if def.kind == OriginKind::Light && is_wide(&p) {
                // Huge objects (ground polygons) around a light: tested for every shadow ray
                // rather than stored in most cells (and left out of the light's window).
                wide.push(GpuEntry { id: tid, d_min: store_dmin(p.dmin, eps) });
                continue;
            }
            let near = def.members.len() > 1
                && def.members.len() <= NEAR_MEMBERS
                && p.cone.is_none_or(|k| k.theta > NEAR_THETA);
            if !near {
                cells.raster(
                    p.cone.as_ref(),
                    |cell| p.meets(cell, delta) && !is_blind(&blind, cell),
                    |cell| p.inside(cell, delta) && !may_be_blind(&blind, cell),
                    |it, cell| {
                        let dm = p.cell_dmin(cell, delta);
                        let cover = p.covers(cell, delta).map(|t| t * (1.0 + 1e-6) + 2.0 * eps);
                        for i in it {
                            if dm <= cut[i] {
                                recs.push(Rec { cell: i as u32, id: tid, dmin: dm });
                                if let Some(t_far) = cover {
                                    cut[i] = cut[i].min(t_far);
                                }
                            }
                        }
                        true
                    },
                );
                continue;
            }
            // Near a cluster: the union of the members' bounds.
            for &(m, mc, mr) in &member_spheres {
                if m == tid && !t.self_list {
                    continue;
                }
                let pm = Pair::new(mc, mr, t, eps, delta, min_cover);
                cells.raster(
                    pm.cone.as_ref(),
                    |cell| pm.meets(cell, delta) && !is_blind(&blind, cell),
                    |cell| pm.inside(cell, delta) && !may_be_blind(&blind, cell),
                    |it, cell| {
                        let dm = pm.cell_dmin(cell, delta);
                        for i in it {
                            if scratch[i] == f64::INFINITY {
                                touched.push(i as u32);
                            }
                            scratch[i] = scratch[i].min(dm);
                        }
                        true
                    },
                );
            }
            let can_cover = p.tri_cover || p.inner.is_some();
            for &i in &touched {
                let i = i as usize;
                let dm = scratch[i];
                scratch[i] = f64::INFINITY;
                if dm <= cut[i] {
                    recs.push(Rec { cell: i as u32, id: tid, dmin: dm });
                    if can_cover {
                        if let Some(t_far) = p.covers(&cells_cone_at(&cells, i), delta) {
                            cut[i] = cut[i].min(t_far * (1.0 + 1e-6) + 2.0 * eps);
                        }
                    }
                }
            }
            touched.clear();
        }
    }

    recs.retain(|x| x.dmin <= cut[x.cell as usize]);
    let mut table = finish(def, &cells, recs, ctx);
    table.always.extend(wide);
    table.always.sort_by(|a, b| a.d_min.total_cmp(&b.d_min).then(a.id.cmp(&b.id)));
    ctx.groups.group_list(&mut table.always, group_min_list(def, ctx));
    table
}

/// The list length from which `def`'s lists name groups: only surface origins group. Eye
/// lists are short, and light lists are walked by shadow rays that mostly stop at their
/// first blocker (grouping them measured more tests per shadow ray on gears_s4).
fn group_min_list(def: &OriginDef, ctx: &Ctx) -> usize {
    match def.kind {
        OriginKind::Surface => ctx.group_min_list,
        _ => usize::MAX,
    }
}

/// The cell cone of local cell index `i`.
fn cells_cone_at(cells: &Cells, i: usize) -> CellCone {
    let f = (0..6).rev().find(|&f| cells.win[f].is_some() && cells.base[f] <= i).unwrap();
    let w = cells.win[f].unwrap();
    let local = (i - cells.base[f]) as u32;
    cells.cone(f, w[0] + local % w[2], w[1] + local / w[2])
}

/// Sorts the records into lists, moves wide targets to the always list (surface origins)
/// and crops each face's window to its non-empty cells.
fn finish(def: &OriginDef, cells: &Cells, mut recs: Vec<Rec>, ctx: &Ctx) -> OriginTable {
    let eps = ctx.eps;
    let mut always: Vec<GpuEntry> = Vec::new();
    if def.kind == OriginKind::Surface && !recs.is_empty() {
        recs.sort_unstable_by_key(|x| x.id);
        let threshold = (ctx.always_fraction * cells.total as f64).max(4.0);
        let mut keep = Vec::with_capacity(recs.len());
        let mut i = 0;
        while i < recs.len() {
            let mut j = i;
            while j < recs.len() && recs[j].id == recs[i].id {
                j += 1;
            }
            if (j - i) as f64 >= threshold {
                let dmin = recs[i..j].iter().map(|x| x.dmin).fold(f64::INFINITY, f64::min);
                always.push(GpuEntry { id: recs[i].id, d_min: store_dmin(dmin, eps) });
            } else {
                keep.extend_from_slice(&recs[i..j]);
            }
            i = j;
        }
        recs = keep;
        always.sort_by(|a, b| a.d_min.total_cmp(&b.d_min).then(a.id.cmp(&b.id)));
    }
    let mut stored: Vec<(u32, GpuEntry)> =
        recs.iter().map(|x| (x.cell, GpuEntry { id: x.id, d_min: store_dmin(x.dmin, eps) })).collect();
    stored.sort_unstable_by(|a, b| {
        a.0.cmp(&b.0).then(a.1.d_min.total_cmp(&b.1.d_min)).then(a.1.id.cmp(&b.1.id))
    });

    // Crop windows to the bounding box of non-empty cells.
    let mut faces = [[0u32; 4]; 6];
    let mut bbox = [[u32::MAX, u32::MAX, 0, 0]; 6]; // min u, min v, max u, max v
    let face_of = |i: usize| (0..6).rev().find(|&f| cells.win[f].is_some() && cells.base[f] <= i).unwrap();
    let mut locs = Vec::with_capacity(stored.len());
    for (cell, _) in &stored {
        let i = *cell as usize;
        let f = face_of(i);
        let w = cells.win[f].unwrap();
        let local = (i - cells.base[f]) as u32;
        let (iu, iv) = (w[0] + local % w[2], w[1] + local / w[2]);
        let b = &mut bbox[f];
        b[0] = b[0].min(iu);
        b[1] = b[1].min(iv);
        b[2] = b[2].max(iu);
        b[3] = b[3].max(iv);
        locs.push((f, iu, iv));
    }
    let mut base = [0usize; 6];
    let mut total = 0usize;
    for f in 0..6 {
        base[f] = total;
        let b = bbox[f];
        if b[0] != u32::MAX {
            faces[f] = [b[0], b[1], b[2] - b[0] + 1, b[3] - b[1] + 1];
            total += (faces[f][2] * faces[f][3]) as usize;
        }
    }
    let mut counts = vec![0u32; total + 1];
    let mut new_cell = Vec::with_capacity(stored.len());
    for &(f, iu, iv) in &locs {
        let w = faces[f];
        let c = base[f] + ((iv - w[1]) * w[2] + (iu - w[0])) as usize;
        counts[c + 1] += 1;
        new_cell.push(c);
    }
    for i in 0..total {
        counts[i + 1] += counts[i];
    }
    // The cell order of `stored` maps monotonically to the new order within a face, and faces
    // keep their order, so a stable placement by the new index keeps each list sorted.
    let mut entries = vec![GpuEntry::default(); stored.len()];
    let mut fill = counts.clone();
    for (k, (_, e)) in stored.iter().enumerate() {
        let c = new_cell[k];
        entries[fill[c] as usize] = *e;
        fill[c] += 1;
    }
    // Long lists name groups instead of their members.
    let min_list = group_min_list(def, ctx);
    if entries.len() >= min_list {
        let mut grouped = Vec::with_capacity(entries.len());
        let mut list = Vec::new();
        for c in 0..total {
            list.clear();
            list.extend_from_slice(&entries[counts[c] as usize..counts[c + 1] as usize]);
            ctx.groups.group_list(&mut list, min_list);
            counts[c] = grouped.len() as u32;
            grouped.extend_from_slice(&list);
        }
        counts[total] = grouped.len() as u32;
        entries = grouped;
    }
    OriginTable { kind: Some(def.kind), n: def.n, faces, starts: counts, entries, always }
}

/// Flattens built origin tables into the GPU buffers.
pub fn flatten(
    tables: &[OriginTable],
    defs: &[OriginDef],
    primitives: usize,
    lights: usize,
    groups: &Groups,
) -> FlatTables {
    let mut flat = FlatTables {
        prim_origin: vec![u32::MAX; primitives],
        prim_patches: vec![1; primitives],
        light_origin: vec![u32::MAX; lights],
        eye_origin: u32::MAX,
        ..FlatTables::default()
    };
    let cells: usize = tables.iter().map(|t| t.starts.len() - 1).sum();
    let entries: usize = tables.iter().map(|t| t.entries.len() + t.always.len()).sum();
    flat.cell_start.reserve(cells + 1);
    flat.entries.reserve(entries);
    // Cell lists first, all origins in order, so that cell ranges tile the array; the
    // always-test lists follow them.
    for (o, (t, def)) in tables.iter().zip(defs).enumerate() {
        flat.origins.push(GpuOrigin {
            n: t.n,
            always_start: 0,
            always_count: t.always.len() as u32,
            kind: def.kind as u32,
        });
        let base = flat.entries.len() as u32;
        let mut cell_base = flat.cell_start.len() as u32;
        for w in &t.faces {
            flat.faces.push(GpuFace {
                iu0: w[0],
                iv0: w[1],
                width: w[2],
                height: w[3],
                cell_base: if w[2] == 0 { 0 } else { cell_base },
                ..GpuFace::default()
            });
            cell_base += w[2] * w[3];
        }
        flat.cell_start.extend(t.starts[..t.starts.len() - 1].iter().map(|s| base + s));
        flat.entries.extend_from_slice(&t.entries);
        match def.kind {
            OriginKind::Eye => flat.eye_origin = o as u32,
            OriginKind::Light => flat.light_origin[def.light.unwrap()] = o as u32,
            OriginKind::Surface => match def.patch {
                // Patches are consecutive origins; the first is the primitive's base.
                Some((m, 0)) => {
                    flat.prim_origin[def.members[0] as usize] = o as u32;
                    flat.prim_patches[def.members[0] as usize] = m;
                }
                Some(_) => {}
                None => {
                    for &m in &def.members {
                        flat.prim_origin[m as usize] = o as u32;
                    }
                }
            },
        }
    }
    flat.cell_start.push(flat.entries.len() as u32);
    for (o, t) in tables.iter().enumerate() {
        flat.origins[o].always_start = flat.entries.len() as u32;
        flat.entries.extend_from_slice(&t.always);
    }
    // The groups go up only when some list names them; their spheres follow the eye
    // ([`frames`]).
    if flat.entries.iter().any(|e| e.id & GROUP_BIT != 0) {
        flat.group_prims = groups.members.clone();
    }
    flat
}

/// Cell window `[iu0, iv0, width, height]` for a rectangle in face coordinates.
fn to_window(r: [f64; 4], n: u32) -> [u32; 4] {
    let (a, b) = cell_span(r[0], r[1], n);
    let (c, d) = cell_span(r[2], r[3], n);
    [a, c, b - a + 1, d - c + 1]
}

fn union_rect(acc: &mut Option<[f64; 4]>, r: [f64; 4]) {
    *acc = Some(match acc {
        None => r,
        Some(a) => [a[0].min(r[0]), a[1].max(r[1]), a[2].min(r[2]), a[3].max(r[3])],
    });
}

/// The face rectangles of the directions in which some target lies, seen from a point-like
/// origin sphere.
fn object_rects(c: DVec3, r: f64, ctx: &Ctx) -> [Option<[f64; 4]>; 6] {
    let mut rects: [Option<[f64; 4]>; 6] = [None; 6];
    let full = [-1.0, 1.0, -1.0, 1.0];
    let add_cone = |rects: &mut [Option<[f64; 4]>; 6], k: Option<Cone>| match k {
        Some(k) => {
            for (f, rect) in rects.iter_mut().enumerate() {
                if let Some(fr) = k.face_rect(f) {
                    union_rect(rect, fr);
                }
            }
        }
        None => {
            for rect in rects.iter_mut() {
                union_rect(rect, full);
            }
        }
    };
    if ctx.bvh.nodes.is_empty() {
        return rects;
    }
    let mut stack = vec![0u32];
    while let Some(ni) = stack.pop() {
        let node = ctx.bvh.nodes[ni as usize];
        let k = sphere_cone(c, r, node.center, node.radius + ctx.eps, ctx.delta);
        if k.is_some_and(|k| k.theta < 0.15) {
            add_cone(&mut rects, k);
            continue;
        }
        if node.count == 0 {
            stack.push(node.first);
            stack.push(node.first + 1);
            continue;
        }
        for &tid in &ctx.bvh.order[node.first as usize..(node.first + node.count) as usize] {
            let t = &ctx.targets[tid as usize];
            let k = sphere_cone(c, r, t.center, t.radius + ctx.eps, ctx.delta);
            // Wide targets go to the always-test list (see `build_origin`).
            if k.is_some_and(|k| k.theta <= WIDE_THETA) {
                add_cone(&mut rects, k);
            }
        }
    }
    rects
}

/// Face rectangles of the view frustum's directions (the cone over the four image-corner
/// directions, clipped to each face's pyramid), widened by `delta`.
fn frustum_rects(corners: &[DVec3; 4], delta: f64) -> [Option<[f64; 4]>; 6] {
    let mut out = [None; 6];
    for (f, slot) in out.iter_mut().enumerate() {
        let ax = f / 2;
        let s = if f % 2 == 1 { -1.0 } else { 1.0 };
        let (i1, i2) = ((ax + 1) % 3, (ax + 2) % 3);
        let mut poly: Vec<DVec3> = corners.to_vec();
        // Keep s·w[ax] ± w[i] ≥ 0 (Sutherland–Hodgman on the cone's cross-section).
        for (i, sign) in [(i1, 1.0), (i1, -1.0), (i2, 1.0), (i2, -1.0)] {
            let dist = |w: DVec3| s * w[ax] + sign * w[i];
            let mut next = Vec::new();
            for k in 0..poly.len() {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                let (da, db) = (dist(a), dist(b));
                if da >= 0.0 {
                    next.push(a);
                }
                if (da >= 0.0) != (db >= 0.0) {
                    next.push(a + (b - a) * (da / (da - db)));
                }
            }
            poly = next;
            if poly.is_empty() {
                break;
            }
        }
        let mut rect: Option<[f64; 4]> = None;
        for w in &poly {
            let m = s * w[ax];
            if m > 0.0 {
                let (u, v) = (w[i1] / m, w[i2] / m);
                union_rect(&mut rect, [u, u, v, v]);
            }
        }
        // Gnomonic coordinates change at most 2 per radian on a face.
        *slot =
            rect.map(|r| [r[0] - 2.0 * delta, r[1] + 2.0 * delta, r[2] - 2.0 * delta, r[3] + 2.0 * delta]);
    }
    out
}

fn rect_area(rects: &[Option<[f64; 4]>; 6]) -> f64 {
    rects.iter().flatten().map(|r| ((r[1] - r[0]).max(0.0)) * ((r[3] - r[2]).max(0.0))).sum()
}

/// The image size the eye table is built for.
pub fn eye_image(scene: &Scene, params: &BuildParams) -> (u32, u32) {
    params.image.or(scene.resolution).unwrap_or_else(|| scene.camera.default_resolution())
}

fn eye_def(scene: &Scene, params: &BuildParams, eps: f64) -> OriginDef {
    let cam = &scene.camera;
    let (w, h) = eye_image(scene, params);
    let corners = [
        cam.ray(0.0, 0.0, w, h),
        cam.ray(w as f64, 0.0, w, h),
        cam.ray(w as f64, h as f64, w, h),
        cam.ray(0.0, h as f64, w, h),
    ];
    let (radius, rects, pixel_angle) = match cam.projection {
        Projection::Perspective { fov_y, .. } => {
            let dirs = corners.map(|c| c.1);
            (eps, frustum_rects(&dirs, params.delta), fov_y / h as f64)
        }
        Projection::Orthographic { .. } => {
            let half_diag = corners.iter().map(|c| (c.0 - cam.eye).length()).fold(0.0, f64::max);
            let k = Cone::new(cam.forward, params.delta);
            let mut rects = [None; 6];
            for (f, r) in rects.iter_mut().enumerate() {
                *r = k.face_rect(f);
            }
            (half_diag + eps, rects, f64::INFINITY)
        }
    };
    let n = params.eye_n.unwrap_or_else(|| {
        if pixel_angle.is_finite() {
            (2.0 / (pixel_angle * params.eye_pixels_per_cell)).ceil().clamp(16.0, 8192.0) as u32
        } else {
            64
        }
    });
    OriginDef {
        kind: OriginKind::Eye,
        center: cam.eye,
        radius,
        members: Vec::new(),
        light: None,
        n,
        window: rects.map(|r| r.map(|r| to_window(r, n))),
        patch: None,
    }
}

fn light_def(i: usize, pos: DVec3, params: &BuildParams, eps: f64, ctx: &Ctx) -> OriginDef {
    let rects = object_rects(pos, eps, ctx);
    let area = rect_area(&rects).max(1e-12);
    let n = params
        .light_n
        .unwrap_or_else(|| (4.0 * params.light_cells as f64 / area).sqrt().clamp(8.0, 16384.0) as u32);
    OriginDef {
        kind: OriginKind::Light,
        center: pos,
        radius: eps,
        members: Vec::new(),
        light: Some(i),
        n,
        window: rects.map(|r| r.map(|r| to_window(r, n))),
        patch: None,
    }
}

fn surface_defs(ids: &[u32], k: usize, n: u32, ctx: &Ctx, patches: &[u32]) -> Vec<OriginDef> {
    let centers: Vec<DVec3> = ctx.targets.iter().map(|t| t.center).collect();
    let (whole, patched): (Vec<u32>, Vec<u32>) = ids.iter().partition(|&&i| patches[i as usize] <= 1);
    let mut defs: Vec<OriginDef> = cluster(&whole, &centers, k)
        .into_iter()
        .map(|members| {
            let (c, r) = bounding_sphere(&members, ctx.targets);
            OriginDef {
                kind: OriginKind::Surface,
                center: c,
                radius: r + ctx.eps,
                members,
                light: None,
                n,
                window: [Some([0, 0, n, n]); 6],
                patch: None,
            }
        })
        .collect();
    for id in patched {
        let Shape::Triangle { v } = ctx.targets[id as usize].shape else { continue };
        let m = patches[id as usize];
        for index in 0..m * m {
            let (i, j) = (index % m, index / m);
            // Patches past the hypotenuse are never looked up: no cells.
            let used = i + j < m;
            let (c, r) = patch_sphere(&v, m, i, j);
            let window = if used { [Some([0, 0, n, n]); 6] } else { [None; 6] };
            defs.push(OriginDef {
                kind: OriginKind::Surface,
                center: c,
                radius: r + ctx.eps + patch_rounding(&v),
                members: vec![id],
                light: None,
                n,
                window,
                patch: Some((m, index)),
            });
        }
    }
    defs
}

/// Bytes an origin table adds to the flattened buffers.
fn table_bytes(t: &OriginTable) -> usize {
    std::mem::size_of::<GpuOrigin>()
        + 6 * std::mem::size_of::<GpuFace>()
        + 4 * (t.starts.len() - 1)
        + 8 * (t.entries.len() + t.always.len())
}

/// The candidate tables of a scene, flattened, with what was built and how long it took.
#[derive(Clone, Debug)]
pub struct Tables {
    pub flat: FlatTables,
    /// The origins as built (kind, sphere, members, resolution).
    pub defs: Vec<OriginDef>,
    /// Wall-clock build time in seconds.
    pub build_s: f64,
    /// Spawn offset (origin inflation) used.
    pub eps: f64,
    /// Surface resolution and cluster size chosen (0 when there are no surface origins).
    pub surface_n: u32,
    pub cluster_size: usize,
    pub shadow_mode: ShadowMode,
    /// The image size the eye table covers.
    pub eye_image: (u32, u32),
    /// The per-origin tables `flat` was flattened from (kept so that the eye's table alone
    /// can be replaced, [`Tables::rebuild_eye`]).
    pub built: Vec<OriginTable>,
    /// The spheres the eye is inside (they list themselves in their own tables).
    pub eye_inside: Vec<u32>,
}

/// A full rebuild for a moved eye inflates the origins by this much more than needed.
const EYE_SLACK: f64 = 1.5;

/// The spheres whose inside holds `p` (as [`mark_enclosing`] decides it).
fn spheres_around(p: DVec3, targets: &[Target]) -> Vec<u32> {
    (0..targets.len() as u32)
        .filter(|&i| match targets[i as usize].shape {
            Shape::Sphere { c, r } => (p - c).length() < r * (1.0 - 1e-6),
            _ => false,
        })
        .collect()
}

/// The eye-relative f32 data of the flat tables: the vertices of the triangles split into
/// patches and the groups' spheres.
fn frames(flat: &mut FlatTables, targets: &[Target], groups: &Groups, eye: DVec3) {
    flat.groups = if flat.group_prims.is_empty() { Vec::new() } else { groups.gpu(eye) };
    flat.patch_tris.clear();
    for (id, _) in flat.prim_patches.iter().enumerate().filter(|(_, m)| **m > 1) {
        if let Shape::Triangle { v } = targets[id].shape {
            flat.patch_tris.insert(id as u32, v.map(|p| (p - eye).as_vec3()));
        }
    }
}

impl Tables {
    /// Replaces the eye's table after `scene.camera` moved, keeping the light and surface
    /// tables (the interactive preview). Those depend on the eye only through the spawn
    /// offset (which grows with the distance from the eye to the scene) and through the
    /// spheres the eye is inside; when either changed, everything is rebuilt. Returns
    /// whether the eye table alone was rebuilt.
    pub fn rebuild_eye(&mut self, scene: &Scene, params: &BuildParams) -> Result<bool> {
        let start = Instant::now();
        let eps = params.spawn_offset.unwrap_or_else(|| default_spawn_offset(scene));
        let targets: Vec<Target> = scene.primitives.iter().map(|p| Target::of(p, scene)).collect();
        let eye = scene.camera.eye;
        let has_eye = self.defs.first().is_some_and(|d| d.kind == OriginKind::Eye);
        if eps > self.eps || !has_eye || spheres_around(eye, &targets) != self.eye_inside {
            // With room for the eye to move farther before the next full rebuild.
            let p = BuildParams { spawn_offset: Some(eps * EYE_SLACK), ..params.clone() };
            *self = build(scene, &p)?;
            return Ok(false);
        }
        let mut targets = targets;
        let bvh = Bvh::build(&targets);
        let mut points = vec![eye];
        points.extend(scene.lights.iter().filter(|l| l.kind != LightKind::Directional).map(|l| l.position));
        mark_enclosing(&mut targets, &bvh, &points);
        let ctx = Ctx::new(&targets, &bvh, self.eps, params);
        let def = eye_def(scene, params, self.eps);
        self.built[0] = build_origin(&def, &ctx);
        self.defs[0] = def;
        let mut flat = flatten(&self.built, &self.defs, targets.len(), scene.lights.len(), &ctx.groups);
        frames(&mut flat, &targets, &ctx.groups, eye);
        if flat.largest_buffer_bytes() > MAX_BINDING_BYTES {
            return Err(Error::TablesTooLarge {
                bytes: flat.largest_buffer_bytes(),
                limit: MAX_BINDING_BYTES,
            });
        }
        self.flat = flat;
        self.eye_image = eye_image(scene, params);
        self.build_s = start.elapsed().as_secs_f64();
        Ok(true)
    }
}

/// Builds the candidate tables a scene calls for.
pub fn build(scene: &Scene, params: &BuildParams) -> Result<Tables> {
    let start = Instant::now();
    let eps = params.spawn_offset.unwrap_or_else(|| default_spawn_offset(scene));
    let mut targets: Vec<Target> = scene.primitives.iter().map(|p| Target::of(p, scene)).collect();
    let bvh = Bvh::build(&targets);
    let mut points = vec![scene.camera.eye];
    points.extend(scene.lights.iter().filter(|l| l.kind != LightKind::Directional).map(|l| l.position));
    mark_enclosing(&mut targets, &bvh, &points);
    let ctx = Ctx::new(&targets, &bvh, eps, params);
    let effects = params.effects.unwrap_or_else(|| scene.effects());

    let mut defs: Vec<OriginDef> = Vec::new();
    if !targets.is_empty() {
        defs.push(eye_def(scene, params, eps));
    }
    let directional = scene.lights.iter().any(|l| l.kind == LightKind::Directional);
    if effects.shadows && params.shadow_mode == ShadowMode::LightBuffer {
        for (i, l) in scene.lights.iter().enumerate() {
            if l.kind != LightKind::Directional {
                defs.push(light_def(i, l.position, params, eps, &ctx));
            }
        }
    }
    let mut fixed: Vec<OriginTable> = defs.par_iter().map(|d| build_origin(d, &ctx)).collect();
    let fixed_bytes: usize =
        fixed.iter().map(table_bytes).sum::<usize>() + 4 * (targets.len() + scene.lights.len() + 1);

    // Surface origins: primitives that spawn secondary rays.
    let all_surfaces = effects.shadows && (params.shadow_mode == ShadowMode::HitObject || directional);
    let surface_ids: Vec<u32> = scene
        .primitives
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            let m = &scene.materials[p.material() as usize];
            all_surfaces || (effects.reflection && (m.reflects() || m.transmits()))
        })
        .map(|(i, _)| i as u32)
        .collect();
    let mut patches = patch_counts(&surface_ids, &targets);
    let (mut surface_n, mut cluster_size) = (0, 0);
    let mut surface: Vec<OriginTable> = Vec::new();
    let mut surface_defs_built: Vec<OriginDef> = Vec::new();
    if !surface_ids.is_empty() {
        let candidates: Vec<(usize, u32)> = match (params.cluster_size, params.surface_n) {
            (Some(k), Some(n)) => vec![(k, n)],
            (k, n) => {
                let ks = [1usize, 2, 4, 8, 16, 32, 64, 128, 256];
                let fits = |kk: usize| surface_ids.len().div_ceil(kk) * targets.len() <= params.pair_budget;
                let kmin = ks.iter().copied().find(|&kk| fits(kk)).unwrap_or(256);
                let mut v = Vec::new();
                for &kk in ks.iter().filter(|x| k.map_or(**x >= kmin, |k| k == **x)) {
                    // Finer cubes first, but never more than `SURFACE_CELLS` cells in all.
                    let origins = surface_ids.len().div_ceil(kk);
                    for nn in [64u32, 32, 16, 8, 6, 4, 3, 2] {
                        let allowed =
                            nn <= 8 || (kk <= 4 && origins * 6 * (nn * nn) as usize <= SURFACE_CELLS);
                        if allowed && n.is_none_or(|n| n == nn) {
                            v.push((kk, nn));
                        }
                    }
                }
                if v.is_empty() {
                    v.push((k.unwrap_or(1), n.unwrap_or(4)));
                }
                v
            }
        };
        let remaining = params.budget_bytes.saturating_sub(fixed_bytes);
        // A sample that was the whole set, kept to avoid building it twice.
        let mut sampled: Option<(usize, Vec<OriginTable>)> = None;
        // Candidates run from fine to coarse and their bytes shrink roughly along the list:
        // bisect for the finest one whose sampled estimate fits, with at most `TRIALS`
        // estimates (each builds a sample of origins spread over the scene).
        let (mut lo, mut hi) = (0, candidates.len() - 1);
        for _ in 0..TRIALS {
            if lo >= hi {
                break;
            }
            let mid = (lo + hi) / 2;
            let (k, n) = candidates[mid];
            let ds = surface_defs(&surface_ids, k, n, &ctx, &patches);
            let step = (ds.len() / SAMPLE).max(1);
            let sample: Vec<&OriginDef> = ds.iter().step_by(step).collect();
            let built: Vec<OriginTable> = sample.par_iter().map(|d| build_origin(d, &ctx)).collect();
            let bytes: usize = built.iter().map(table_bytes).sum();
            let estimate = bytes as f64 / sample.len() as f64 * ds.len() as f64;
            if estimate <= remaining as f64 * 0.9 {
                hi = mid;
                if step == 1 {
                    sampled = Some((mid, built));
                }
            } else {
                lo = mid + 1;
            }
        }
        let mut ci = hi;
        // Build; should the estimate have been wrong and a buffer overflow wgpu's binding
        // limit, fall back to the next coarser candidate.
        let fixed_entries: usize = fixed.iter().map(|t| t.entries.len() + t.always.len()).sum();
        let fixed_cells: usize = fixed.iter().map(|t| t.starts.len() - 1).sum();
        loop {
            let (k, n) = candidates[ci];
            let ds = surface_defs(&surface_ids, k, n, &ctx, &patches);
            let built: Vec<OriginTable> = match sampled.take() {
                Some((i, b)) if i == ci => b,
                _ => ds.par_iter().map(|d| build_origin(d, &ctx)).collect(),
            };
            let entries =
                fixed_entries + built.iter().map(|t| t.entries.len() + t.always.len()).sum::<usize>();
            let cells = fixed_cells + built.iter().map(|t| t.starts.len() - 1).sum::<usize>();
            let too_big = entries * std::mem::size_of::<GpuEntry>() > MAX_BINDING_BYTES
                || (cells + 1) * 4 > MAX_BINDING_BYTES;
            if too_big && ci + 1 < candidates.len() {
                ci += 1;
                continue;
            }
            if too_big && patches.iter().any(|&m| m > 1) {
                // Even the coarsest tables overflow: coarsen the surface patches too.
                patches.iter_mut().for_each(|m| *m = (*m / 2).max(1));
                continue;
            }
            surface_n = n;
            cluster_size = k;
            surface = built;
            surface_defs_built = ds;
            break;
        }
    }
    defs.extend(surface_defs_built);
    fixed.extend(surface);
    let mut flat = flatten(&fixed, &defs, targets.len(), scene.lights.len(), &ctx.groups);
    frames(&mut flat, &targets, &ctx.groups, scene.camera.eye);
    if flat.largest_buffer_bytes() > MAX_BINDING_BYTES {
        return Err(Error::TablesTooLarge { bytes: flat.largest_buffer_bytes(), limit: MAX_BINDING_BYTES });
    }
    Ok(Tables {
        flat,
        defs,
        build_s: start.elapsed().as_secs_f64(),
        eps,
        surface_n,
        cluster_size,
        shadow_mode: params.shadow_mode,
        eye_image: eye_image(scene, params),
        built: fixed,
        eye_inside: spheres_around(scene.camera.eye, &targets),
    })
}
