//! The bounding-sphere hierarchy over targets (median splits) that the builder walks nearest
//! first to cull hidden targets, and whose small subtrees are the primitive groups.

use glam::DVec3;

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

impl SphereTree {
    pub fn build(targets: &[Target]) -> SphereTree {
        const LEAF: usize = 4;
        let mut order: Vec<u32> = (0..targets.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * targets.len() / LEAF + 1);
        if targets.is_empty() {
            return SphereTree { nodes, order, occluders: Vec::new() };
        }
        nodes.push(Node { center: DVec3::ZERO, radius: 0.0, first: 0, count: 0 });
        // (node index, range start, range end)
        let mut stack = vec![(0usize, 0usize, targets.len())];
        while let Some((ni, a, b)) = stack.pop() {
            let (c, r) = bounding_sphere(&order[a..b], targets);
            if b - a <= LEAF {
                nodes[ni] = Node { center: c, radius: r, first: a as u32, count: (b - a) as u32 };
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
        let occluders = occluder_bounds(&nodes, &order, targets);
        SphereTree { nodes, order, occluders }
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
