//! Building one origin's table: the builder walks the target hierarchy nearest first and,
//! for each target, computes its direction bound ([`Pair`]) and rasterises it into the
//! origin's cells ([`Cells`]) with a per-cell lower bound `d_min`. A target that certainly
//! covers a cell (every ray of the cell hits it before `t_far`) lowers the cell's cut-off;
//! entries whose `d_min` exceeds the final cut-off are dropped, since the walker's distance
//! interval test would never reach them, and whole hidden subtrees are skipped. Targets near
//! a cluster are bounded member by member (the union of the members' bounds, with the
//! smallest member `d_min` per cell), which keeps self and neighbour lists short.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;

use super::blind::{is_blind, may_be_blind, Planes};
use super::bounds::sphere_cone;
use super::context::Ctx;
use super::defs::{OriginDef, WIDE_THETA};
use super::flat::{GpuEntry, OriginKind};
use super::hierarchy::bounding_sphere;
use super::lists::{finish, group_min_list, store_dmin, OriginTable, Rec};
use super::pair::Pair;
use super::raster::Cells;
use super::targets::Shape;

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
        // A stop asked for: the build returns `Error::Interrupted` before using this table.
        if crate::interrupt::requested().is_some() {
            break;
        }
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
                        if let Some(t_far) = p.covers(&cells.cone_at(i), delta) {
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
