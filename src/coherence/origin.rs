//! Building one origin's table: the builder walks the target hierarchy nearest first and,
//! for each target, computes its direction bound ([`Pair`]) and rasterises it into the
//! origin's cells ([`Cells`]) with a per-cell lower bound `d_min`. A target that certainly
//! covers a cell (every ray of the cell hits it before `t_far`) lowers the cell's cut-off;
//! entries whose `d_min` exceeds the final cut-off are dropped, since the walker's distance
//! interval test would never reach them; whole hidden subtrees, and the blocks of cells
//! where a target lies beyond every cut-off, are skipped.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::bounds::sphere_cone;
use super::context::Ctx;
use super::defs::{OriginDef, WIDE_THETA};
use super::flat::{GpuEntry, OriginKind};
use super::lists::{finish, store_dmin, DistKey, OriginTable, Rec};
use super::pair::Pair;
use super::raster::Cells;

fn is_wide(p: &Pair) -> bool {
    p.cone.is_none_or(|k| k.theta > WIDE_THETA)
}

/// Hierarchy nodes whose cone is wider than this are entered without a cull test.
const CULL_THETA: f64 = 0.5;

/// Builds one origin's table.
pub fn build_origin(def: &OriginDef, ctx: &Ctx) -> OriginTable {
    let cells = Cells::new(def);
    let (eps, delta) = (ctx.eps, ctx.delta);
    // The smallest cells (at face corners) subtend about 1/n radian.
    let min_cover = 0.4 / def.n as f64;
    let mut recs: Vec<Rec> = Vec::new();
    let mut wide: Vec<GpuEntry> = Vec::new();
    let (c, r) = (def.center, def.radius);

    let mut heap: BinaryHeap<(Reverse<DistKey>, u32)> = BinaryHeap::new();
    if !ctx.bvh.nodes.is_empty() {
        heap.push((Reverse(DistKey(0.0)), 0));
    }
    while let Some((Reverse(DistKey(node_dmin)), ni)) = heap.pop() {
        // A stop asked for: the build returns `Error::Interrupted` before using this table.
        if crate::interrupt::requested().is_some() {
            break;
        }
        let node = ctx.bvh.nodes[ni as usize];
        // Skip the subtree when every cell its bound meets is already cut off before it
        // (which needs some cut: on meshes of tiny triangles there is often none).
        let cone =
            if cells.any_cut() { sphere_cone(c, r, node.center, node.radius + eps, delta) } else { None };
        if let Some(k) = cone {
            if k.theta < CULL_THETA {
                let hidden = cells.raster(
                    Some(&k),
                    node_dmin,
                    |_| true,
                    |cell| k.contains(cell),
                    |it, _| {
                        for i in it {
                            if cells.cut(i) >= node_dmin {
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
                heap.push((Reverse(DistKey(d)), ch));
            }
            continue;
        }
        for pos in node.first as usize..(node.first + node.count) as usize {
            let (tid, t) = (ctx.bvh.order[pos], &ctx.targets[pos]);
            let p = Pair::new(c, r, t, eps, delta, min_cover);
            if def.kind == OriginKind::Light && is_wide(&p) {
                // Huge objects (ground polygons) around a light: tested for every shadow ray
                // rather than stored in most cells (and left out of the light's window).
                wide.push(GpuEntry { id: tid, d_min: store_dmin(p.dmin, eps) });
                continue;
            }
            cells.raster(
                p.cone.as_ref(),
                p.dmin,
                |cell| p.meets_beyond_cone(cell),
                |cell| p.inside(cell),
                |it, cell| {
                    let dm = p.cell_dmin(cell);
                    let cover = p.covers(cell).map(|t| t * (1.0 + 1e-6) + 2.0 * eps);
                    for i in it {
                        if dm <= cells.cut(i) {
                            recs.push(Rec { cell: i as u32, id: tid, dmin: dm });
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

    recs.retain(|x| x.dmin <= cells.cut(x.cell as usize));
    let mut table = finish(def, &cells, recs, eps);
    table.always.extend(wide);
    table.always.sort_by(|a, b| a.d_min.total_cmp(&b.d_min).then(a.id.cmp(&b.id)));
    table
}
