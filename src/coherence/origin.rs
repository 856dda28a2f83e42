//! Building one origin's table: for each target, its direction bound ([`Pair`]) is
//! rasterised into the origin's cells ([`Cells`]) with a per-cell lower bound `d_min`. A
//! target that certainly covers a cell (every ray of the cell hits it before `t_far`) lowers
//! the cell's cut-off; entries whose `d_min` exceeds the final cut-off are dropped, since the
//! walker's distance interval test would never reach them; whole hidden subtrees, and the
//! blocks of cells where a target lies beyond every cut-off, are skipped.
//!
//! # In parallel, and independent of the order
//! The table does not depend on the order targets are taken in: a cell's final cut is the
//! least `t_far` of the targets covering it, and its list is every target the raster
//! reaches there with `d_min` within that cut (a target skipped as hidden lies beyond every
//! cut it meets, so its entries would be dropped and it lowers no cut; the `d_min` and cover
//! of a block depend only on the target and the block). So the builder splits the sphere
//! tree into subtrees that rayon takes in any order, in two passes:
//! 1. the targets that may cover a cell (opaque, and seen at least as large as the smallest
//!    cell, [`Builder::may_cover`]) lower the shared cuts, nearest first within a subtree,
//!    and keep their entries;
//! 2. the block maxima are settled, and every other target (on meshes, nearly all: they are
//!    smaller than a cell) is rasterised against the final cuts, which hide the most.
//!
//! The entries within the final cuts are the same whatever the threads did, and
//! [`finish`] sorts each list by `(d_min, id)`: the tables are byte-identical for any
//! number of threads.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

use rayon::prelude::*;

use super::bounds::sphere_cone;
use super::cells::face_dir;
use super::context::Ctx;
use super::defs::{OriginDef, WIDE_THETA};
use super::flat::{GpuEntry, OriginKind};
use super::lists::{finish, store_dmin, DistKey, OriginTable, Rec};
use super::pair::Pair;
use super::raster::Cells;
use super::targets::{Shape, Target};

fn is_wide(p: &Pair) -> bool {
    p.cone.is_none_or(|k| k.theta > WIDE_THETA)
}

/// Hierarchy nodes whose cone is wider than this are entered without a cull test.
const CULL_THETA: f64 = 0.5;

/// Subtrees per thread the hierarchy is split into.
const TASKS_PER_THREAD: usize = 8;

/// The two passes over the targets.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Pass {
    /// Targets that may cover a cell: they lower the cuts.
    Covers,
    /// The others, against the final cuts.
    Rest,
}

/// What one thread gathered: records, and the light's always-test entries.
#[derive(Default)]
struct Part {
    recs: Vec<Rec>,
    wide: Vec<GpuEntry>,
}

/// One origin's build: its cells and what every target's bound needs.
struct Builder<'a> {
    def: &'a OriginDef,
    ctx: &'a Ctx<'a>,
    cells: Cells,
    /// Spheres subtending less than this (as r/d) are not tried as covers.
    min_cover: f64,
    /// A triangle whose bound's sine (`(r + radius + eps) / d`) is below this is seen
    /// smaller than every cell and covers none.
    cover_sin: f64,
}

/// Builds one origin's table.
pub fn build_origin(def: &OriginDef, ctx: &Ctx) -> OriginTable {
    let b = Builder::new(def, ctx);
    let tasks = b.tasks();
    let mut parts = b.pass(&tasks, Pass::Covers);
    b.cells.cuts.settle();
    parts.extend(b.pass(&tasks, Pass::Rest));

    let (recs, wide): (Vec<_>, Vec<_>) = parts.into_iter().map(|p| (p.recs, p.wide)).unzip();
    let mut table = finish(def, &b.cells, &recs, ctx.eps);
    drop(recs);
    table.always.extend(wide.into_iter().flatten());
    table.always.sort_by(|a, b| a.d_min.total_cmp(&b.d_min).then(a.id.cmp(&b.id)));
    table
}

/// Half the smallest angle across a cell of an `n`-cube (the short diagonal of the cells at
/// the faces' corners), less a margin: a cone narrower than this holds no cell.
fn smallest_cell_half_angle(n: u32) -> f64 {
    let k = 1.0 - 2.0 / n as f64;
    0.45 * face_dir(0, k, k).angle_between(face_dir(0, 1.0, 1.0))
}

impl<'a> Builder<'a> {
    fn new(def: &'a OriginDef, ctx: &'a Ctx<'a>) -> Builder<'a> {
        let half = (smallest_cell_half_angle(def.n) - ctx.delta).max(0.0);
        Builder { def, ctx, cells: Cells::new(def), min_cover: 0.4 / def.n as f64, cover_sin: half.sin() }
    }

    /// Whether target `t` may prove some cell covered: the cover tests of [`Pair`] can pass
    /// only for an opaque sphere [`Pair::new`] gives an inner cone, or an opaque triangle
    /// whose bounding cone is large enough to hold a cell (all four corners of a covered
    /// cell lie inside the triangle, seen from the origin).
    fn may_cover(&self, t: &Target) -> bool {
        let (c, r, eps) = (self.def.center, self.def.radius, self.ctx.eps);
        t.occluder
            && match t.shape {
                Shape::Sphere { c: cb, r: rb } => rb > self.min_cover * (cb - c).length(),
                // Not "less" (NaN included): a NaN keeps the target, which is conservative.
                Shape::Triangle { .. } => {
                    (r + t.radius + eps).partial_cmp(&(self.cover_sin * (t.center - c).length()))
                        != Some(std::cmp::Ordering::Less)
                }
                Shape::Capsule { .. } => false,
            }
    }

    /// Whether hierarchy node `ni`'s subtree may hold a target that [`Builder::may_cover`]:
    /// its occluders lie within `reach` of the node's centre, none larger than `largest`, so
    /// each lies at least `D + radius` from the origin's centre (`D = |node − origin| −
    /// reach`), and its bound's sine is at most `(r + largest + eps) / (D + largest)`.
    fn may_hold_covers(&self, ni: u32) -> bool {
        let [reach, largest] = self.ctx.bvh.occluders[ni as usize];
        if largest == f64::NEG_INFINITY {
            return false;
        }
        let node = self.ctx.bvh.nodes[ni as usize];
        let d = (node.center - self.def.center).length() - reach;
        let s = self.cover_sin.min(self.min_cover);
        // Not "less" (NaN included): a NaN enters the subtree, which is conservative.
        ((self.def.radius + largest + self.ctx.eps) * (1.0 + 1e-9)).partial_cmp(&(s * (d + largest)))
            != Some(std::cmp::Ordering::Less)
    }

    /// The distance from the origin sphere to hierarchy node `ni`'s sphere.
    fn node_dmin(&self, ni: u32) -> f64 {
        let n = self.ctx.bvh.nodes[ni as usize];
        ((n.center - self.def.center).length() - self.def.radius - n.radius - self.ctx.eps).max(0.0)
    }

    /// Subtrees of the hierarchy, about [`TASKS_PER_THREAD`] per thread, nearest first.
    fn tasks(&self) -> Vec<u32> {
        let nodes = &self.ctx.bvh.nodes;
        if nodes.is_empty() {
            return Vec::new();
        }
        let want = TASKS_PER_THREAD * rayon::current_num_threads();
        let mut tasks = vec![0u32];
        while tasks.len() < want && tasks.iter().any(|&i| nodes[i as usize].count == 0) {
            tasks = tasks
                .iter()
                .flat_map(|&i| {
                    let n = nodes[i as usize];
                    if n.count == 0 {
                        vec![n.first, n.first + 1]
                    } else {
                        vec![i]
                    }
                })
                .collect();
        }
        let mut keyed: Vec<(f64, u32)> = tasks.into_iter().map(|i| (self.node_dmin(i), i)).collect();
        keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        keyed.into_iter().map(|(_, i)| i).collect()
    }

    /// Runs `pass` over the subtrees `tasks`, taken in order by whichever thread is free.
    fn pass(&self, tasks: &[u32], pass: Pass) -> Vec<Part> {
        let next = AtomicUsize::new(0);
        let workers = rayon::current_num_threads().clamp(1, tasks.len().max(1));
        (0..workers)
            .into_par_iter()
            .map(|_| {
                let mut part = Part::default();
                loop {
                    let i = next.fetch_add(1, Relaxed);
                    if i >= tasks.len() {
                        break;
                    }
                    self.walk(tasks[i], pass, &mut part);
                }
                part
            })
            .collect()
    }

    /// Whether every cell hierarchy node `ni`'s bound meets is cut off before it. Leaves are
    /// not tested: their few targets' own rasters skip cut-off blocks as cheaply.
    ///
    /// The node's sphere is widened by far more than rounding, so that no target inside it
    /// has a nearer `d_min` or a cone reaching a cell the node's misses: a subtree is then
    /// skipped only where its entries would all be dropped by the final cuts, and which
    /// subtrees the threads skip never changes the table.
    fn hidden(&self, ni: u32) -> bool {
        let node = self.ctx.bvh.nodes[ni as usize];
        if node.count > 0 || !self.cells.any_cut() {
            return false;
        }
        let (c, r) = (self.def.center, self.def.radius);
        let dist = (node.center - c).length();
        let rad = node.radius + self.ctx.eps + 1e-9 * (dist + node.radius + r);
        let node_dmin = (dist - r - rad).max(0.0);
        let Some(k) = sphere_cone(c, r, node.center, rad, self.ctx.delta) else {
            return false;
        };
        k.theta < CULL_THETA
            && self.cells.raster(
                Some(&k),
                node_dmin,
                |_| true,
                |cell| k.contains(cell),
                |it, _| {
                    for i in it {
                        if self.cells.cut(i) >= node_dmin {
                            return false;
                        }
                    }
                    true
                },
            )
    }

    /// Walks the subtree at `root`, building the targets of `pass`: nearest first for the
    /// covers (the near ones cut off the far ones), in any order for the rest.
    fn walk(&self, root: u32, pass: Pass, part: &mut Part) {
        // A stop asked for: the build returns `Error::Interrupted` before using this table.
        let stop = || crate::interrupt::requested().is_some();
        match pass {
            Pass::Covers => {
                let mut heap: BinaryHeap<(Reverse<DistKey>, u32)> = BinaryHeap::new();
                heap.push((Reverse(DistKey(self.node_dmin(root))), root));
                while let Some((_, ni)) = heap.pop() {
                    for ch in self.visit(ni, pass, part).into_iter().flatten() {
                        heap.push((Reverse(DistKey(self.node_dmin(ch))), ch));
                    }
                    if stop() {
                        return;
                    }
                }
            }
            Pass::Rest => {
                let mut stack = vec![root];
                while let Some(ni) = stack.pop() {
                    stack.extend(self.visit(ni, pass, part).into_iter().flatten());
                    if stop() {
                        return;
                    }
                }
            }
        }
    }

    /// Builds the targets of `pass` in leaf `ni`, or returns the children of inner node
    /// `ni` to walk, unless the subtree has nothing to build.
    fn visit(&self, ni: u32, pass: Pass, part: &mut Part) -> Option<[u32; 2]> {
        // Skip the subtree when it holds no target of the pass, or when every cell its bound
        // meets is already cut off before it.
        if (pass == Pass::Covers && !self.may_hold_covers(ni)) || self.hidden(ni) {
            return None;
        }
        let bvh = self.ctx.bvh;
        let node = bvh.nodes[ni as usize];
        if node.count == 0 {
            return Some([node.first, node.first + 1]);
        }
        for pos in node.first as usize..(node.first + node.count) as usize {
            let t = &self.ctx.targets[pos];
            if self.may_cover(t) == (pass == Pass::Covers) {
                self.target(bvh.order[pos], t, pass, part);
            }
        }
        None
    }

    /// Rasterises target `t` (primitive `tid`) into the cells.
    fn target(&self, tid: u32, t: &Target, pass: Pass, part: &mut Part) {
        let (c, r, eps) = (self.def.center, self.def.radius, self.ctx.eps);
        let p = Pair::new(c, r, t, eps, self.ctx.delta, self.min_cover);
        if self.def.kind == OriginKind::Light && is_wide(&p) {
            // Huge objects (ground polygons) around a light: tested for every shadow ray
            // rather than stored in most cells (and left out of the light's window).
            part.wide.push(GpuEntry { id: tid, d_min: store_dmin(p.dmin, eps) });
            return;
        }
        let cells = &self.cells;
        cells.raster(
            p.cone.as_ref(),
            p.dmin,
            |cell| p.meets_beyond_cone(cell),
            |cell| p.inside(cell),
            |it, cell| {
                let dm = p.cell_dmin(cell);
                let cover = match pass {
                    Pass::Covers => p.covers(cell).map(|t| t * (1.0 + 1e-6) + 2.0 * eps),
                    Pass::Rest => None,
                };
                for i in it {
                    if dm <= cells.cut(i) {
                        part.recs.push(Rec { cell: i as u32, id: tid, dmin: dm });
                        if let Some(t_far) = cover {
                            cells.lower_cut(i, t_far);
                        }
                    }
                }
                true
            },
        );
    }
}

#[cfg(test)]
mod tests {

    use super::*;
    use crate::coherence::cells::cell_cone;
    use crate::coherence::hierarchy::SphereTree;
    use crate::coherence::params::BuildParams;
    use crate::coherence::testutil::{rng, unit};

    /// Every subtree holding a target that may cover a cell, seen from random origins, is
    /// entered by the cover pass.
    #[test]
    fn cover_pass_enters_every_subtree_with_a_cover() {
        let mut s = 0x1234_5678u64;
        let targets: Vec<Target> = (0..600)
            .map(|i| {
                let c = unit(&mut s) * (1.0 + 6.0 * rng(&mut s));
                let size = 10f64.powf(-3.0 * rng(&mut s));
                let occluder = i % 5 != 0;
                if i % 2 == 0 {
                    Target { shape: Shape::Sphere { c, r: size }, center: c, radius: size, occluder }
                } else {
                    let v = [c, c + unit(&mut s) * size, c + unit(&mut s) * size];
                    let center = (v[0].min(v[1]).min(v[2]) + v[0].max(v[1]).max(v[2])) * 0.5;
                    let radius = v.iter().map(|p| (*p - center).length()).fold(0.0, f64::max);
                    Target { shape: Shape::Triangle { v }, center, radius, occluder }
                }
            })
            .collect();
        let bvh = SphereTree::build(&targets);
        let ordered: Vec<Target> = bvh.order.iter().map(|&i| targets[i as usize]).collect();
        let ctx = Ctx::new(&ordered, &bvh, 1e-4, &BuildParams::default());
        let (mut entered, mut skipped) = (0, 0);
        for round in 0..40 {
            let n = [16, 64, 339][round % 3];
            let def = OriginDef {
                kind: OriginKind::Light,
                center: unit(&mut s) * 3.0 * rng(&mut s),
                radius: 1e-3 * rng(&mut s),
                light: None,
                n,
                window: [Some([0, 0, 1, 1]); 6],
            };
            let b = Builder::new(&def, &ctx);
            for (ni, node) in bvh.nodes.iter().enumerate() {
                let mut stack = vec![*node];
                let mut any = false;
                while let Some(m) = stack.pop() {
                    if m.count == 0 {
                        stack.extend([bvh.nodes[m.first as usize], bvh.nodes[m.first as usize + 1]]);
                    } else {
                        any |= (m.first..m.first + m.count).any(|p| b.may_cover(&ordered[p as usize]));
                    }
                }
                let hold = b.may_hold_covers(ni as u32);
                assert!(hold || !any, "node {ni} holds a cover but was skipped");
                (entered, skipped) = (entered + hold as u32, skipped + !hold as u32);
            }
        }
        assert!(entered > 0 && skipped > 0, "{entered} entered, {skipped} skipped");
    }

    /// No cell of an `n`-cube fits in a cone narrower than the bound the cover pass uses:
    /// both diagonals of every cell are longer than twice it.
    #[test]
    fn no_cell_is_smaller_than_the_cover_bound() {
        for n in [8, 13, 64, 339] {
            let half = smallest_cell_half_angle(n);
            for face in [0, 3] {
                for iv in 0..n {
                    for iu in 0..n {
                        let c = cell_cone(face, iu, iv, n).corners.map(|c| c.normalize());
                        let d = c[0].angle_between(c[2]).min(c[1].angle_between(c[3]));
                        assert!(d > 2.0 * half, "n {n} cell ({iu}, {iv}): {d} vs {half}");
                    }
                }
            }
        }
    }
}
