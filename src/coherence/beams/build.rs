//! Growing the beam tree: an origin tree over the spawning primitives, a direction cube at
//! each of its leaves, then splits where the pilot's rays test too many candidates.
//!
//! **Origins.** The box of all spawning primitives is split at the middle of its longest
//! side, breadth first, until a node holds at most [`Builder::cluster_size`] spawning
//! primitives (and, among the first [`MIN_CLUSTERS`], is no larger than [`CLUSTER_SIZE`]
//! median target radii: a large mirror is cut into pieces), or cannot separate them, or
//! clusters × targets reaches a pair budget, which bounds the build.
//!
//! **Beam roots.** Each leaf of the origin tree splits by face into six beams, whose lists
//! are culled from the whole scene: the bounding-sphere hierarchy walked nearest first,
//! subtrees the beam misses or that lie beyond a target covering the whole beam skipped.
//! Every beam therefore has a list: none walks every primitive.
//!
//! **Bounds.** A beam's origins lie in its *occupied box* (the node's box, widened by the
//! spawn-offset bound, clipped to the widened boxes of the spawning primitives that meet
//! it), so the sphere around that box is an origin sphere, and its directions are a block of
//! cells, so its cone is a [`crate::coherence::cells::CellCone`]: the origin–target bounds
//! of the direction-cube tables ([`Pair`]) apply. Entries beyond a target that covers the
//! whole beam are dropped, as in the cube tables. A child's list is its parent's filtered by
//! the child's bounds (a subset of rays can hit only a subset of targets), its `d_min` the
//! larger of the two bounds.
//!
//! **Refinement.** A split halves the occupied box along one axis (at an f32 plane of the
//! kernels' frame) or the block of cells along `u` or `v`. Among the candidate splits, the
//! one that leaves the node's pilot rays the fewest candidates to test (those before each
//! ray's nearest hit) is taken; a run of [`MAX_STALL`] splits that gain less than
//! [`MIN_GAIN`] ends it, as do the cost target, [`BEAM_DEPTH`] and the memory budget. Each
//! round splits every leaf that needs it at once (rayon), so the tree grows level by level
//! and the same rays always give the same tree.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::Arc;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::{BeamNode, BeamStats, BeamTree};
use crate::bvh::{f32_down, f32_up};
use crate::coherence::cells::{region_cone, CellCone};
use crate::coherence::context::Ctx;
use crate::coherence::cube::cube_face_cell;
use crate::coherence::flat::{GpuBeamNode, GpuEntry, BEAM_CELLS, BEAM_DEPTH};
use crate::coherence::lists::{store_dmin, DistKey};
use crate::coherence::pair::Pair;

/// A split gains when it leaves the rays at most this fraction of the candidates they tested.
pub const MIN_GAIN: f64 = 0.95;

/// Splits without gain allowed in a row: the origin box may have to shrink several times
/// before it stops overlapping its neighbours (whose candidates are then in every direction).
pub const MAX_STALL: u32 = 4;

/// The origin tree splits a cluster larger than this many median target radii across.
pub const CLUSTER_SIZE: f64 = 8.0;

/// Clusters × targets stays under this (but [`MIN_CLUSTERS`] are allowed), which bounds
/// the roots' culling.
pub const PAIR_BUDGET: usize = 3_000_000;
/// Clusters are split for their size alone only while there are fewer than this.
pub const MIN_CLUSTERS: usize = 64;

/// Lists at least this long are filtered group by group first.
const GROUP_FILTER: usize = 64;

/// Triangles seen under a narrower cone than this (radians) are bounded by their sphere.
const NARROW: f64 = 0.05;

/// A node splits only for at least this many pilot rays: finer splits than the pilot's
/// sampling leave the render's rays between the pilot's in siblings no pilot ray refined.
pub const MIN_RAYS: usize = 2;

/// One candidate of a beam: a target and the lower bound of its hit distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cand {
    pub id: u32,
    pub dmin: f64,
}

/// A ray the refinement follows: origin and unit direction in the kernels' f32 frame, and
/// how far its walk goes (its nearest hit, the end of a shadow ray, or `FAR` while unknown).
#[derive(Clone, Copy, Debug)]
pub struct PilotRay {
    pub o: Vec3,
    pub d: Vec3,
    pub t: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Leaf,
    /// `o[axis] >= split` (f32, the build's frame) goes to `left + 1`.
    Origin {
        axis: usize,
        split: f32,
        left: u32,
    },
    /// The direction's cell coordinate `axis` (0: iu, 1: iv) `>= split` goes to `left + 1`.
    Dir {
        axis: usize,
        split: u32,
        left: u32,
    },
    /// The direction's face `f` goes to `first + f`.
    Face {
        first: u32,
    },
}

/// A node while the tree grows; leaves keep their list and the spawning primitives they meet.
struct Node {
    face: u32,
    /// The node's box in the build's f32 frame.
    lo: [f32; 3],
    hi: [f32; 3],
    /// The block of cells `[iu0, iv0, iu1, iv1]` (inclusive) of a `BEAM_CELLS`-cube.
    rect: [u32; 4],
    depth: u32,
    /// Splits without gain above this node, in a row.
    stall: u32,
    kind: Kind,
    /// Sorted by `d_min`.
    list: Vec<Cand>,
    /// The entries `list` takes once long lists name groups ([`Builder::stored_len`]).
    stored: usize,
    spawners: Arc<Vec<u32>>,
}

/// A ray with its direction's face and cell.
struct Classified {
    ray: PilotRay,
    fc: [u32; 3],
}

/// The number of candidates of `list` (sorted by `dmin`) a walk to `t` tests at most.
fn cost(list: &[Cand], t: f32) -> usize {
    list.partition_point(|c| c.dmin <= t as f64)
}

/// Whether the bounding sphere `(cb, rb)` of a target may be seen from the origin sphere
/// `(c, r)` through `cell`: Test A of the cube tables for the sphere's cone, widened by
/// `delta` (conservative; a cheap filter before the exact [`Pair`]).
fn may_meet(c: DVec3, r: f64, cb: DVec3, rb: f64, cell: &CellCone, delta: f64) -> bool {
    let v = cb - c;
    let d = v.length();
    let s = (r + rb) / d;
    if !(d > 0.0 && s < 1.0 - 1e-9) {
        return true;
    }
    let reach = s.asin() + delta + cell.beta();
    reach >= std::f64::consts::PI || v.dot(cell.m) >= d * reach.cos()
}

fn to_f64(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// The beam tree while it grows.
pub struct Builder<'a> {
    ctx: &'a Ctx<'a>,
    /// The kernels' frame: world coordinates minus the eye.
    eye: DVec3,
    /// Per primitive: its box widened by the spawn-offset bound (world).
    boxes: Vec<(DVec3, DVec3)>,
    spawner: Vec<bool>,
    /// The most spawning primitives in a cluster.
    pub cluster_size: usize,
    /// Clusters larger than this are split (world units).
    cluster_extent: f64,
    /// The diameter of the scene's bounding sphere: the distance that stands for an
    /// escaping ray's.
    scene_size: f64,
    nodes: Vec<Node>,
    /// The box of all origins (f32 frame).
    lo: [f32; 3],
    hi: [f32; 3],
    entries: usize,
    budget_bytes: usize,
    pub stats: BeamStats,
}

impl<'a> Builder<'a> {
    /// The origin tree over `spawners` (primitive `i`'s box `boxes[i]`) and its beam roots,
    /// within `budget_bytes` for the whole tree.
    pub fn new(
        ctx: &'a Ctx<'a>,
        eye: DVec3,
        boxes: &[(DVec3, DVec3)],
        spawners: &[u32],
        budget_bytes: usize,
    ) -> Builder<'a> {
        let eps = DVec3::splat(ctx.eps);
        let boxes: Vec<(DVec3, DVec3)> = boxes.iter().map(|(a, b)| (*a - eps, *b + eps)).collect();
        let mut spawner = vec![false; boxes.len()];
        let (mut wlo, mut whi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &s in spawners {
            spawner[s as usize] = true;
            wlo = wlo.min(boxes[s as usize].0);
            whi = whi.max(boxes[s as usize].1);
        }
        let mut radii: Vec<f64> = ctx.targets.iter().map(|t| t.radius).collect();
        let median = if radii.is_empty() {
            0.0
        } else {
            let mid = radii.len() / 2;
            *radii.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        let mut b = Builder {
            ctx,
            eye,
            boxes,
            spawner,
            cluster_size: (spawners.len() * ctx.targets.len()).div_ceil(PAIR_BUDGET).max(1),
            cluster_extent: CLUSTER_SIZE * median,
            scene_size: ctx.bvh.nodes.first().map_or(0.0, |n| 2.0 * n.radius),
            nodes: Vec::new(),
            lo: [0.0; 3],
            hi: [0.0; 3],
            entries: 0,
            budget_bytes,
            stats: BeamStats::default(),
        };
        if spawners.is_empty() {
            return b;
        }
        let (lo, hi) = (wlo - eye, whi - eye);
        b.lo = [f32_down(lo.x), f32_down(lo.y), f32_down(lo.z)];
        b.hi = [f32_up(hi.x), f32_up(hi.y), f32_up(hi.z)];
        b.origin_tree(Arc::new(spawners.to_vec()));
        b
    }

    /// Builds the origin tree and the roots of its clusters' beams; should the roots not
    /// fit the budget, with half as many clusters, down to one.
    fn origin_tree(&mut self, spawners: Arc<Vec<u32>>) {
        let mut max_clusters = (PAIR_BUDGET / self.ctx.targets.len().max(1)).max(MIN_CLUSTERS);
        loop {
            self.nodes.clear();
            self.entries = 0;
            self.grow_origin_tree(spawners.clone(), max_clusters);
            if self.bytes() <= self.budget_bytes || max_clusters == 1 {
                return;
            }
            max_clusters = (max_clusters / 2).min(self.stats.clusters.div_ceil(2)).max(1);
        }
    }

    /// The origin tree with at most `max_clusters` clusters, and the roots of their beams.
    fn grow_origin_tree(&mut self, spawners: Arc<Vec<u32>>, max_clusters: usize) {
        let full = [0, 0, BEAM_CELLS - 1, BEAM_CELLS - 1];
        let node = |lo, hi, spawners, depth| Node {
            face: 0,
            lo,
            hi,
            rect: full,
            depth,
            stall: 0,
            kind: Kind::Leaf,
            list: Vec::new(),
            stored: 0,
            spawners,
        };
        self.nodes.push(node(self.lo, self.hi, spawners, 0));
        let mut clusters = Vec::new();
        // Breadth first, so that the cap on clusters stops the largest ones last.
        let mut queue = std::collections::VecDeque::from([0usize]);
        while let Some(n) = queue.pop_front() {
            let open = clusters.len() + queue.len() + 1;
            let split = if open < max_clusters { self.cluster_split(n, open < MIN_CLUSTERS) } else { None };
            let Some((axis, at, kids)) = split else {
                clusters.push(n);
                continue;
            };
            let left = self.nodes.len() as u32;
            let depth = self.nodes[n].depth + 1;
            self.nodes[n].kind = Kind::Origin { axis, split: at, left };
            for (lo, hi, sp) in kids {
                queue.push_back(self.nodes.len());
                self.nodes.push(node(lo, hi, Arc::new(sp), depth));
            }
        }
        // Each cluster splits by face into six beam roots, culled from the whole scene.
        let mut roots = Vec::with_capacity(6 * clusters.len());
        for &c in &clusters {
            let first = self.nodes.len() as u32 + roots.len() as u32;
            self.nodes[c].kind = Kind::Face { first };
            let (lo, hi, depth) = (self.nodes[c].lo, self.nodes[c].hi, self.nodes[c].depth + 1);
            for face in 0..6 {
                let mut r = node(lo, hi, self.nodes[c].spawners.clone(), depth);
                r.face = face;
                roots.push(r);
            }
        }
        let lists: Vec<Vec<Cand>> = roots
            .par_iter()
            .map(|r| self.cull(self.origin_sphere(r.lo, r.hi, &r.spawners), r.face, r.rect))
            .collect();
        for (r, list) in roots.iter_mut().zip(lists) {
            r.stored = self.stored_len(&list);
            self.entries += r.stored;
            r.list = list;
        }
        self.nodes.extend(roots);
        self.stats.clusters = clusters.len();
    }

    /// How origin-tree node `n` splits: at the middle of its occupied box's longest side
    /// that separates its spawning primitives, while it holds more than the cluster size or
    /// is larger than the cluster extent; `None` for a cluster.
    #[allow(clippy::type_complexity)]
    fn cluster_split(
        &self,
        n: usize,
        by_size: bool,
    ) -> Option<(usize, f32, [([f32; 3], [f32; 3], Vec<u32>); 2])> {
        let node = &self.nodes[n];
        let (olo, ohi) = self.occupied(node.lo, node.hi, &node.spawners)?;
        let ext = ohi - olo;
        let count = node.spawners.len();
        let large = by_size && ext.max_element() > self.cluster_extent;
        if (count <= self.cluster_size && !large) || node.depth >= BEAM_DEPTH / 2 {
            return None;
        }
        let mut axes = [0usize, 1, 2];
        axes.sort_by(|&a, &b| ext[b].total_cmp(&ext[a]).then(a.cmp(&b)));
        for axis in axes {
            let at = (0.5 * (olo[axis] + ohi[axis]) - self.eye[axis]) as f32;
            if !(node.lo[axis] < at && at < node.hi[axis]) {
                continue;
            }
            let (mut lhi, mut rlo) = (node.hi, node.lo);
            lhi[axis] = at;
            rlo[axis] = at;
            let l = self.spawners_in(node.lo, lhi, &node.spawners);
            let r = self.spawners_in(rlo, node.hi, &node.spawners);
            // A split must separate something, or shrink a cluster that is too large.
            if (l.len() < count || r.len() < count) || (by_size && ext[axis] > self.cluster_extent) {
                return Some((axis, at, [(node.lo, lhi, l), (rlo, node.hi, r)]));
            }
        }
        None
    }

    /// Whether a ray from `o` (f32 frame) is classified: inside the box of all origins.
    pub fn inside(&self, o: Vec3) -> bool {
        !self.nodes.is_empty() && (0..3).all(|k| o[k] >= self.lo[k] && o[k] <= self.hi[k])
    }

    /// The leaf holding the ray from `o` along a direction of face and cell `fc` (inside
    /// the box), as the kernels find it.
    pub fn leaf_of(&self, o: Vec3, fc: [u32; 3]) -> usize {
        let mut k = 0;
        loop {
            match self.nodes[k].kind {
                Kind::Leaf => return k,
                Kind::Origin { axis, split, left } => k = (left + (o[axis] >= split) as u32) as usize,
                Kind::Dir { axis, split, left } => k = (left + (fc[1 + axis] >= split) as u32) as usize,
                Kind::Face { first } => k = (first + fc[0]) as usize,
            }
        }
    }

    /// The candidates of leaf `leaf`, sorted by `d_min`.
    pub fn list(&self, leaf: usize) -> &[Cand] {
        &self.nodes[leaf].list
    }

    /// The occupied part of the box `lo..hi` (f32 frame), in the world: the box widened by
    /// the spawn-offset bound (which also covers moving a split to another eye's frame),
    /// clipped to the boxes of `spawners` it meets; `None` when it meets none.
    fn occupied(&self, lo: [f32; 3], hi: [f32; 3], spawners: &[u32]) -> Option<(DVec3, DVec3)> {
        let (nlo, nhi) = self.widened(lo, hi);
        let (mut olo, mut ohi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &s in spawners {
            let (a, b) = self.boxes[s as usize];
            let (cl, ch) = (a.max(nlo), b.min(nhi));
            if cl.cmple(ch).all() {
                olo = olo.min(cl);
                ohi = ohi.max(ch);
            }
        }
        olo.cmple(ohi).all().then_some((olo, ohi))
    }

    /// The box `lo..hi` (f32 frame) in the world, widened by the spawn-offset bound.
    fn widened(&self, lo: [f32; 3], hi: [f32; 3]) -> (DVec3, DVec3) {
        let eps = DVec3::splat(self.ctx.eps);
        (to_f64(lo) + self.eye - eps, to_f64(hi) + self.eye + eps)
    }

    /// The sphere around the occupied part of the box `lo..hi` ([`Builder::occupied`]).
    fn origin_sphere(&self, lo: [f32; 3], hi: [f32; 3], spawners: &[u32]) -> Option<(DVec3, f64)> {
        self.occupied(lo, hi, spawners).map(|(a, b)| ((a + b) * 0.5, (b - a).length() * 0.5))
    }

    /// The spawners of `spawners` whose widened box meets `lo..hi` (f32 frame).
    fn spawners_in(&self, lo: [f32; 3], hi: [f32; 3], spawners: &[u32]) -> Vec<u32> {
        let (nlo, nhi) = self.widened(lo, hi);
        spawners
            .iter()
            .copied()
            .filter(|&s| {
                let (a, b) = self.boxes[s as usize];
                a.max(nlo).cmple(b.min(nhi)).all()
            })
            .collect()
    }

    /// The entries `list` takes in the tables: a list of at least the group threshold names
    /// each primitive group it holds once.
    fn stored_len(&self, list: &[Cand]) -> usize {
        if list.len() < self.ctx.group_min_list || self.ctx.groups.spans.is_empty() {
            return list.len();
        }
        let mut g: Vec<u32> = list.iter().map(|c| self.ctx.groups.of[c.id as usize]).collect();
        g.sort_unstable();
        g.dedup();
        g.len()
    }

    /// The candidates of the beam from `sphere` over cells `rect` of `face`, among `parent`'s.
    fn filter(&self, sphere: Option<(DVec3, f64)>, face: u32, rect: [u32; 4], parent: &[Cand]) -> Vec<Cand> {
        let Some((c, r)) = sphere else { return Vec::new() };
        let cell = region_cone(face as usize, rect, BEAM_CELLS);
        let (eps, delta) = (self.ctx.eps, self.ctx.delta);
        // Spheres narrower than the block cannot cover it.
        let min_cover = 0.5 * cell.sin_b;
        let mut cut = f64::INFINITY;
        let mut list = Vec::with_capacity(parent.len());
        // A long list is first filtered by group: one sphere test for up to 16 members
        // (0: not tested yet, 1: may meet, 2: misses).
        let groups = &self.ctx.groups;
        let mut verdict =
            if parent.len() >= GROUP_FILTER { vec![0u8; groups.spans.len()] } else { Vec::new() };
        for p in parent {
            if p.dmin > cut {
                break;
            }
            if !verdict.is_empty() {
                let g = groups.of[p.id as usize] as usize;
                if verdict[g] == 0 {
                    let (gc, gr) = groups.spheres[g];
                    verdict[g] = if may_meet(c, r, gc, gr + eps, &cell, delta) { 1 } else { 2 };
                }
                if verdict[g] == 2 {
                    continue;
                }
            }
            let t = &self.ctx.targets[p.id as usize];
            if !may_meet(c, r, t.center, t.radius + eps, &cell, delta) {
                continue;
            }
            let pair = Pair::new_coarse(c, r, t, eps, delta, min_cover, NARROW);
            if !pair.meets(&cell) {
                continue;
            }
            if let Some(t) = pair.covers(&cell) {
                cut = cut.min(t * (1.0 + 1e-6) + 2.0 * eps);
            }
            list.push(Cand { id: p.id, dmin: pair.cell_dmin(&cell).max(p.dmin) });
        }
        list.retain(|c| c.dmin <= cut);
        list.sort_by(|a, b| a.dmin.total_cmp(&b.dmin).then(a.id.cmp(&b.id)));
        list
    }

    /// The candidates of the beam from `sphere` over cells `rect` of `face`, from the whole
    /// scene: the bounding-sphere hierarchy walked nearest first, subtrees the beam misses or
    /// that lie beyond a covering target skipped.
    fn cull(&self, sphere: Option<(DVec3, f64)>, face: u32, rect: [u32; 4]) -> Vec<Cand> {
        let Some((c, r)) = sphere else { return Vec::new() };
        let bvh = self.ctx.bvh;
        if bvh.nodes.is_empty() {
            return Vec::new();
        }
        let cell = region_cone(face as usize, rect, BEAM_CELLS);
        let (eps, delta) = (self.ctx.eps, self.ctx.delta);
        let min_cover = 0.5 * cell.sin_b;
        let mut cut = f64::INFINITY;
        let mut list = Vec::new();
        let mut heap: BinaryHeap<(Reverse<DistKey>, u32)> = BinaryHeap::new();
        heap.push((Reverse(DistKey(0.0)), 0));
        while let Some((Reverse(DistKey(d)), ni)) = heap.pop() {
            if d > cut {
                break;
            }
            let node = bvh.nodes[ni as usize];
            if !may_meet(c, r, node.center, node.radius + eps, &cell, delta) {
                continue;
            }
            if node.count == 0 {
                for ch in [node.first, node.first + 1] {
                    let n = bvh.nodes[ch as usize];
                    heap.push((
                        Reverse(DistKey(((n.center - c).length() - r - n.radius - eps).max(0.0))),
                        ch,
                    ));
                }
                continue;
            }
            for &id in &bvh.order[node.first as usize..(node.first + node.count) as usize] {
                let t = &self.ctx.targets[id as usize];
                if !may_meet(c, r, t.center, t.radius + eps, &cell, delta) {
                    continue;
                }
                let pair = Pair::new_coarse(c, r, t, eps, delta, min_cover, NARROW);
                if !pair.meets(&cell) {
                    continue;
                }
                let dmin = pair.cell_dmin(&cell);
                if dmin > cut {
                    continue;
                }
                if let Some(t) = pair.covers(&cell) {
                    cut = cut.min(t * (1.0 + 1e-6) + 2.0 * eps);
                }
                list.push(Cand { id, dmin });
            }
        }
        list.retain(|c| c.dmin <= cut);
        list.sort_by(|a, b| a.dmin.total_cmp(&b.dmin).then(a.id.cmp(&b.id)));
        list
    }

    /// The two children of leaf `n` split by the origin along `axis` at `split` (an f32's
    /// bits), or by the direction along `axis` (`dir`).
    fn children(&self, n: usize, dir: bool, axis: usize, split: u32) -> [Node; 2] {
        let node = &self.nodes[n];
        let child = |side: usize| {
            let (mut lo, mut hi, mut rect) = (node.lo, node.hi, node.rect);
            let spawners = if dir {
                if side == 0 {
                    rect[2 + axis] = split - 1;
                } else {
                    rect[axis] = split;
                }
                node.spawners.clone()
            } else {
                if side == 0 {
                    hi[axis] = f32::from_bits(split);
                } else {
                    lo[axis] = f32::from_bits(split);
                }
                Arc::new(self.spawners_in(lo, hi, &node.spawners))
            };
            let sphere = self.origin_sphere(lo, hi, &spawners);
            let list = self.filter(sphere, node.face, rect, &node.list);
            Node {
                face: node.face,
                lo,
                hi,
                rect,
                depth: node.depth + 1,
                stall: node.stall,
                kind: Kind::Leaf,
                stored: self.stored_len(&list),
                list,
                spawners,
            }
        };
        [child(0), child(1)]
    }

    /// The splits worth trying for leaf `n`, in order of preference: the origin axis of the
    /// occupied box's longest extent (shrinking the box is what separates a beam from the
    /// neighbours it overlaps), the cell axes with two or more cells (the wider first), then
    /// the other origin axes. An origin split is at the occupied box's middle, an f32
    /// strictly inside the node.
    fn candidates(&self, n: usize) -> Vec<(bool, usize, u32)> {
        let node = &self.nodes[n];
        let mut origin: Vec<(f64, usize, f32)> = Vec::new();
        if let Some((olo, ohi)) = self.occupied(node.lo, node.hi, &node.spawners) {
            for axis in 0..3 {
                let mid = (0.5 * (olo[axis] + ohi[axis]) - self.eye[axis]) as f32;
                if node.lo[axis] < mid && mid < node.hi[axis] {
                    origin.push((ohi[axis] - olo[axis], axis, mid));
                }
            }
            origin.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        }
        let mut out: Vec<(bool, usize, u32)> =
            origin.iter().map(|&(_, axis, mid)| (false, axis, mid.to_bits())).collect();
        let rest = out.split_off(out.len().min(1));
        let r = node.rect;
        let mut dirs: Vec<(u32, usize)> =
            (0..2).filter(|&a| r[2 + a] > r[a]).map(|a| (r[2 + a] - r[a], a)).collect();
        dirs.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
        out.extend(dirs.into_iter().map(|(_, a)| (true, a, (r[a] + r[2 + a]).div_ceil(2))));
        out.extend(rest);
        out
    }

    /// The best split of leaf `n` for `rays` (indices into `all`), with its children, or
    /// `None` when the node cannot split or has stalled [`MAX_STALL`] times. The beam's
    /// width at its rays' typical distance `t` comes from its origins (the occupied box's
    /// longest side) or its directions (the block's angle × `t`): the larger is split
    /// first, and another candidate (of [`Builder::candidates`]) is tried only while none
    /// gains.
    fn best_split(&self, n: usize, rays: &[u32], all: &[Classified]) -> Option<(Kind, [Node; 2])> {
        let node = &self.nodes[n];
        let now: usize = rays.iter().map(|&r| cost(&node.list, all[r as usize].ray.t)).sum();
        let gains = |total: usize| (total as f64) < MIN_GAIN * now as f64;
        let mut candidates = self.candidates(n);
        let mut ts: Vec<f64> =
            rays.iter().map(|&r| (all[r as usize].ray.t as f64).min(self.scene_size)).collect();
        let t = *ts.select_nth_unstable_by(rays.len() / 2, f64::total_cmp).1;
        let across = 2.0 * region_cone(node.face as usize, node.rect, BEAM_CELLS).beta() * t;
        let origin =
            self.occupied(node.lo, node.hi, &node.spawners).map_or(0.0, |(a, b)| (b - a).max_element());
        if across > origin {
            if let Some(k) = candidates.iter().position(|c| c.0) {
                let c = candidates.remove(k);
                candidates.insert(0, c);
            }
        }
        let mut best: Option<(usize, Kind, [Node; 2])> = None;
        for (dir, axis, split) in candidates {
            if best.as_ref().is_some_and(|b| gains(b.0)) {
                break;
            }
            let kids = self.children(n, dir, axis, split);
            let total: usize = rays
                .iter()
                .map(|&r| {
                    let c = &all[r as usize];
                    let right =
                        if dir { c.fc[1 + axis] >= split } else { c.ray.o[axis] >= f32::from_bits(split) };
                    cost(&kids[right as usize].list, c.ray.t)
                })
                .sum();
            if best.as_ref().is_none_or(|b| total < b.0) {
                let kind = if dir {
                    Kind::Dir { axis, split, left: 0 }
                } else {
                    Kind::Origin { axis, split: f32::from_bits(split), left: 0 }
                };
                best = Some((total, kind, kids));
            }
        }
        let (total, kind, mut kids) = best?;
        let stall = if gains(total) { 0 } else { node.stall + 1 };
        if stall > MAX_STALL {
            return None;
        }
        for k in &mut kids {
            k.stall = stall;
        }
        Some((kind, kids))
    }

    fn bytes(&self) -> usize {
        self.entries * std::mem::size_of::<GpuEntry>() + self.nodes.len() * std::mem::size_of::<GpuBeamNode>()
    }

    /// Splits, level by level, the leaves whose rays of `rays` test more than `target`
    /// candidates on average.
    pub fn refine(&mut self, rays: &[PilotRay], target: f64) {
        let start = std::time::Instant::now();
        let all: Vec<Classified> = rays
            .iter()
            .filter(|r| self.inside(r.o) && r.d.abs().max_element() > 0.0)
            .map(|&ray| Classified { ray, fc: cube_face_cell(ray.d, BEAM_CELLS) })
            .collect();
        let mut by_leaf: std::collections::BTreeMap<usize, Vec<u32>> = Default::default();
        for (i, c) in all.iter().enumerate() {
            by_leaf.entry(self.leaf_of(c.ray.o, c.fc)).or_default().push(i as u32);
        }
        let mut work: Vec<(usize, Vec<u32>)> = by_leaf.into_iter().collect();
        while !work.is_empty() && !self.stats.over_budget && crate::interrupt::requested().is_none() {
            work.retain(|(n, rs)| {
                let node = &self.nodes[*n];
                let total: usize = rs.iter().map(|&r| cost(&node.list, all[r as usize].ray.t)).sum();
                node.depth < BEAM_DEPTH && rs.len() >= MIN_RAYS && total as f64 > target * rs.len() as f64
            });
            let splits: Vec<Option<(Kind, [Node; 2])>> =
                work.par_iter().map(|(n, rs)| self.best_split(*n, rs, &all)).collect();
            let mut next = Vec::new();
            for ((n, rs), split) in work.into_iter().zip(splits) {
                let Some((kind, kids)) = split else { continue };
                let (added, freed) = (kids[0].stored + kids[1].stored, self.nodes[n].stored);
                let grown = (added + 4).saturating_sub(freed) * std::mem::size_of::<GpuEntry>();
                if self.bytes() + grown > self.budget_bytes {
                    self.stats.over_budget = true;
                    break;
                }
                let left = self.nodes.len() as u32;
                self.entries = self.entries + added - freed;
                let node = &mut self.nodes[n];
                node.list = Vec::new();
                node.stored = 0;
                node.spawners = Arc::new(Vec::new());
                node.kind = match kind {
                    Kind::Dir { axis, split, .. } => Kind::Dir { axis, split, left },
                    Kind::Origin { axis, split, .. } => Kind::Origin { axis, split, left },
                    _ => unreachable!("a split is by origin or direction"),
                };
                let mut sides = [Vec::new(), Vec::new()];
                for r in rs {
                    let c = &all[r as usize];
                    let right = match kind {
                        Kind::Dir { axis, split, .. } => c.fc[1 + axis] >= split,
                        Kind::Origin { axis, split, .. } => c.ray.o[axis] >= split,
                        _ => unreachable!("a split is by origin or direction"),
                    };
                    sides[right as usize].push(r);
                }
                self.nodes.extend(kids);
                for (k, side) in sides.into_iter().enumerate() {
                    if !side.is_empty() {
                        next.push((left as usize + k, side));
                    }
                }
            }
            work = next;
        }
        self.stats.split_s += start.elapsed().as_secs_f64();
    }

    /// The mean number of candidates `rays` test (before their `t`).
    pub fn mean_cost(&self, rays: &[PilotRay]) -> f64 {
        let mut n = 0usize;
        let mut sum = 0usize;
        for r in rays {
            if self.inside(r.o) && r.d.abs().max_element() > 0.0 {
                let leaf = self.leaf_of(r.o, cube_face_cell(r.d, BEAM_CELLS));
                sum += cost(&self.nodes[leaf].list, r.t);
                n += 1;
            }
        }
        if n == 0 {
            0.0
        } else {
            sum as f64 / n as f64
        }
    }

    /// The finished tree: lists stored as the walker reads them (lowered `d_min`, sorted,
    /// long lists naming groups), origin splits in the world frame.
    pub fn finish(self) -> BeamTree {
        let ctx = self.ctx;
        let eye = self.eye;
        let mut stats = self.stats;
        let mut lists = Vec::new();
        let mut nodes = Vec::with_capacity(self.nodes.len());
        for n in &self.nodes {
            stats.depth = stats.depth.max(n.depth);
            nodes.push(match n.kind {
                Kind::Leaf => {
                    let mut list: Vec<GpuEntry> = n
                        .list
                        .iter()
                        .map(|c| GpuEntry { id: c.id, d_min: store_dmin(c.dmin, ctx.eps) })
                        .collect();
                    list.sort_by(|a, b| a.d_min.total_cmp(&b.d_min).then(a.id.cmp(&b.id)));
                    ctx.groups.group_list(&mut list, ctx.group_min_list);
                    stats.entries += list.len();
                    stats.max_list = stats.max_list.max(list.len());
                    lists.push(list);
                    BeamNode::Leaf { list: lists.len() as u32 - 1 }
                }
                Kind::Origin { axis, split, left } => {
                    BeamNode::Origin { axis: axis as u8, split: split as f64 + eye[axis], left }
                }
                Kind::Dir { axis, split, left } => BeamNode::Dir { axis: axis as u8, split, left },
                Kind::Face { first } => BeamNode::Face { first },
            });
        }
        stats.leaves = lists.len();
        BeamTree {
            nodes,
            lists,
            lo: to_f64(self.lo) + eye,
            hi: to_f64(self.hi) + eye,
            spawners: self.spawner,
            stats,
        }
    }
}
