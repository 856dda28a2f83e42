//! The bounding-sphere hierarchy over targets (median splits) that the builder walks to
//! cull hidden targets and splits into subtrees for its threads, built in parallel below
//! its top.

use glam::DVec3;
use rayon::prelude::*;

use super::targets::{Shape, Target};

/// Bounding sphere of a set of targets: centre of their boxes, radius to the farthest
/// point (vertices for triangles).
pub fn bounding_sphere(ids: &[u32], targets: &[Target]) -> (DVec3, f64) {
    let (lo, hi) = ids.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
        let t = &targets[i as usize];
        (lo.min(t.center - DVec3::splat(t.radius)), hi.max(t.center + DVec3::splat(t.radius)))
    });
    let c = (lo + hi) * 0.5;
    let r = ids
        .iter()
        .map(|&i| {
            let t = &targets[i as usize];
            match t.shape {
                Shape::Triangle { v } => v.iter().map(|p| (*p - c).length()).fold(0.0, f64::max),
                _ => (t.center - c).length() + t.radius,
            }
        })
        .fold(0.0, f64::max);
    (c, r)
}

/// A node of the bounding-sphere hierarchy over targets.
#[derive(Clone, Copy, Debug)]
pub struct Node {
    pub center: DVec3,
    pub radius: f64,
    /// Leaf: `first..first+count` of [`SphereTree::order`]; inner: `count == 0`, children at
    /// `first` and `first + 1`.
    pub first: u32,
    pub count: u32,
}

/// Bounding-sphere hierarchy (median splits, leaves of at most 4 targets).
#[derive(Clone, Debug)]
pub struct SphereTree {
    pub nodes: Vec<Node>,
    pub order: Vec<u32>,
    /// Per node, over the occluders of its subtree (those that may prove a cell covered):
    /// `[reach, largest]`, a bound on `|target centre − node centre| + target radius` and the
    /// largest target radius; `[−∞, −∞]` when it holds none.
    pub occluders: Vec<[f64; 2]>,
}

/// Targets per leaf, at most.
const LEAF: usize = 4;

impl SphereTree {
    /// Splits at the median of the widest axis of the targets' centres, down to leaves of
    /// [`LEAF`]. The top of the tree is built serially; below it, subtrees of at most a
    /// grain of targets are built in parallel and appended: the nodes are those of a serial
    /// build (each sphere and split is computed from its own targets alone), in another
    /// layout.
    pub fn build(targets: &[Target]) -> SphereTree {
        SphereTree::build_with(targets, (targets.len() / (16 * rayon::current_num_threads())).max(1 << 12))
    }

    /// [`SphereTree::build`] with subtrees of at most `grain` targets built in parallel.
    fn build_with(targets: &[Target], grain: usize) -> SphereTree {
        let mut order: Vec<u32> = (0..targets.len() as u32).collect();
        if targets.is_empty() {
            return SphereTree { nodes: Vec::new(), order, occluders: Vec::new() };
        }
        let mut nodes = vec![Node { center: DVec3::ZERO, radius: 0.0, first: 0, count: 0 }];
        let mut pending = Vec::new();
        grow(&mut nodes, &mut order, targets, 0, 0, grain, &mut pending);
        pending.sort_by_key(|p| p.1);
        // Disjoint slices of `order`, one per pending range; the top's own leaves may lie
        // between them.
        let mut slices = Vec::with_capacity(pending.len());
        let (mut rest, mut at) = (&mut order[..], 0);
        for &(_, a, b) in &pending {
            let (_, tail) = std::mem::take(&mut rest).split_at_mut(a - at);
            let (s, tail) = tail.split_at_mut(b - a);
            slices.push((s, a));
            (rest, at) = (tail, b);
        }
        let subtrees: Vec<Vec<Node>> = slices
            .into_par_iter()
            .map(|(s, a)| {
                let mut local = vec![Node { center: DVec3::ZERO, radius: 0.0, first: 0, count: 0 }];
                grow(&mut local, s, targets, a, 0, 0, &mut Vec::new());
                local
            })
            .collect();
        for (&(ni, _, _), local) in pending.iter().zip(subtrees) {
            // Local index i ≥ 1 goes to offset + i − 1; the local root to node `ni`.
            let offset = nodes.len() as u32;
            let fix = |n: Node| if n.count == 0 { Node { first: offset + n.first - 1, ..n } } else { n };
            nodes[ni] = fix(local[0]);
            nodes.extend(local[1..].iter().map(|&n| fix(n)));
        }
        let occluders = occluder_bounds(&nodes, &order, targets);
        SphereTree { nodes, order, occluders }
    }
}

/// Builds the subtree of node `root` over `order` (the targets at positions `base..` of the
/// tree's order), pushing new nodes onto `nodes`. Ranges of more than [`LEAF`] and at most
/// `grain` targets are left to the caller: `(node, start, end)` in `pending` (none for a
/// `grain` of 0).
fn grow(
    nodes: &mut Vec<Node>,
    order: &mut [u32],
    targets: &[Target],
    base: usize,
    root: usize,
    grain: usize,
    pending: &mut Vec<(usize, usize, usize)>,
) {
    // (node index, range start, range end), within `order`
    let mut stack = vec![(root, 0usize, order.len())];
    while let Some((ni, a, b)) = stack.pop() {
        if b - a > LEAF && b - a <= grain {
            pending.push((ni, base + a, base + b));
            continue;
        }
        let (c, r) = bounding_sphere(&order[a..b], targets);
        if b - a <= LEAF {
            nodes[ni] = Node { center: c, radius: r, first: (base + a) as u32, count: (b - a) as u32 };
            continue;
        }
        let (lo, hi) = order[a..b].iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
            (lo.min(targets[i as usize].center), hi.max(targets[i as usize].center))
        });
        let ext = hi - lo;
        let ax = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = (b - a) / 2;
        order[a..b].select_nth_unstable_by(mid, |x, y| {
            targets[*x as usize].center[ax].total_cmp(&targets[*y as usize].center[ax])
        });
        let left = nodes.len();
        nodes.push(Node { center: DVec3::ZERO, radius: 0.0, first: 0, count: 0 });
        nodes.push(Node { center: DVec3::ZERO, radius: 0.0, first: 0, count: 0 });
        nodes[ni] = Node { center: c, radius: r, first: left as u32, count: 0 };
        stack.push((left, a, a + mid));
        stack.push((left + 1, a + mid, b));
    }
}

/// [`SphereTree::occluders`], leaves first (children come after their parent in `nodes`).
fn occluder_bounds(nodes: &[Node], order: &[u32], targets: &[Target]) -> Vec<[f64; 2]> {
    let none = [f64::NEG_INFINITY; 2];
    let mut out = vec![none; nodes.len()];
    for ni in (0..nodes.len()).rev() {
        let n = nodes[ni];
        let mut b = none;
        if n.count == 0 {
            for ch in [n.first as usize, n.first as usize + 1] {
                let [reach, largest] = out[ch];
                // Through the child's centre: a bound, not the exact reach.
                b = [b[0].max(reach + (nodes[ch].center - n.center).length()), b[1].max(largest)];
            }
        } else {
            for &i in &order[n.first as usize..(n.first + n.count) as usize] {
                let t = &targets[i as usize];
                if t.occluder {
                    b = [b[0].max((t.center - n.center).length() + t.radius), b[1].max(t.radius)];
                }
            }
        }
        out[ni] = b;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Subtrees built in parallel give the serial build's order, and the same tree: the
    /// same spheres, leaves and occluder bounds at the same places, walked from the root.
    #[test]
    fn parallel_subtrees_are_the_serial_tree() {
        let mut s = 0xabcdefu64;
        let targets: Vec<Target> = (0..5000)
            .map(|i| {
                let c = crate::coherence::testutil::unit(&mut s) * (i % 97) as f64;
                let r = 0.05 + 0.1 * crate::coherence::testutil::rng(&mut s);
                Target { shape: Shape::Sphere { c, r }, center: c, radius: r, occluder: i % 3 > 0 }
            })
            .collect();
        let serial = SphereTree::build_with(&targets, 0);
        assert!(serial.nodes.len() > 2000);
        for grain in [5, 6, 9, 64, 1000, 4999, 5000, usize::MAX] {
            let par = SphereTree::build_with(&targets, grain);
            assert_eq!(par.order, serial.order, "grain {grain}");
            assert_eq!(par.nodes.len(), serial.nodes.len(), "grain {grain}");
            // Walk both trees together from their roots.
            let mut stack = vec![(0usize, 0usize)];
            let mut seen = 0;
            while let Some((i, j)) = stack.pop() {
                seen += 1;
                let (m, n) = (serial.nodes[i], par.nodes[j]);
                assert_eq!(m.center.to_array().map(f64::to_bits), n.center.to_array().map(f64::to_bits));
                assert_eq!(m.radius.to_bits(), n.radius.to_bits());
                assert_eq!(m.count, n.count);
                assert_eq!(serial.occluders[i].map(f64::to_bits), par.occluders[j].map(f64::to_bits));
                if m.count > 0 {
                    assert_eq!(m.first, n.first);
                } else {
                    assert!(n.first as usize > j, "children after their parent");
                    stack.push((m.first as usize, n.first as usize));
                    stack.push((m.first as usize + 1, n.first as usize + 1));
                }
            }
            assert_eq!(seen, par.nodes.len(), "grain {grain}");
        }
    }

    #[test]
    fn bvh_spheres_contain_their_targets() {
        let targets: Vec<Target> = (0..57)
            .map(|i| {
                let c = DVec3::new((i * 13 % 17) as f64, (i * 7 % 5) as f64, (i % 3) as f64);
                Target { shape: Shape::Sphere { c, r: 0.5 }, center: c, radius: 0.5, occluder: true }
            })
            .collect();
        let bvh = SphereTree::build(&targets);
        // Every target of a subtree lies inside the subtree's root sphere.
        fn subtree(bvh: &SphereTree, n: usize, out: &mut Vec<u32>) {
            let node = bvh.nodes[n];
            if node.count == 0 {
                subtree(bvh, node.first as usize, out);
                subtree(bvh, node.first as usize + 1, out);
            } else {
                out.extend_from_slice(&bvh.order[node.first as usize..(node.first + node.count) as usize]);
            }
        }
        let mut seen = vec![false; targets.len()];
        for n in 0..bvh.nodes.len() {
            let mut ids = Vec::new();
            subtree(&bvh, n, &mut ids);
            let node = bvh.nodes[n];
            for i in ids {
                let t = &targets[i as usize];
                assert!((t.center - node.center).length() + t.radius <= node.radius + 1e-9);
                seen[i as usize] = true;
            }
        }
        assert!(seen.iter().all(|s| *s));
    }
}
