//! What the tables are built from: targets (every primitive with its bounding shape and its
//! self-listing and occluder flags), origins (the eye, point lights and clusters of surface
//! primitives that spawn secondary rays), spatial clustering and the bounding-sphere
//! hierarchy the builder walks to cull hidden targets.
//!
//! Self-listing rules: a primitive lists itself in its own origin's table (in every cell,
//! `d_min = 0`) when a ray leaving it can hit it again: it transmits (refraction rays travel
//! inside), it is an inside-only sphere (NFF negative radius: rays reflect inside it), a
//! cylinder (open, so visible from inside), or a sphere whose inside rays can reach (the eye,
//! a light or another primitive lies inside it: see [`mark_enclosing`]). Reflected and shadow
//! rays leaving a sphere or a triangle from its outside cannot hit it again, so these do not
//! list themselves; the other members of a cluster are always listed where they can be seen
//! from it.

use glam::DVec3;

use crate::scene::{Primitive, Scene};

/// A target's shape as the direction bounds see it.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    Sphere {
        c: DVec3,
        r: f64,
    },
    Triangle {
        v: [DVec3; 3],
    },
    /// Every point within `rad` of the segment `p0`–`p1` (bounds a cylinder or cone).
    Capsule {
        p0: DVec3,
        p1: DVec3,
        rad: f64,
    },
}

/// One primitive as a target of the tables.
#[derive(Clone, Copy, Debug)]
pub struct Target {
    pub shape: Shape,
    /// Bounding sphere (not inflated).
    pub center: DVec3,
    pub radius: f64,
    /// Lists itself in its own origin's table.
    pub self_list: bool,
    /// May be used to prove that every ray of a cell hits it (opaque, outside-visible
    /// sphere or triangle).
    pub occluder: bool,
}

impl Target {
    pub fn of(p: &Primitive, scene: &Scene) -> Target {
        let transmits = scene.materials[p.material() as usize].transmits();
        let (center, radius) = p.bounding_sphere();
        match p {
            Primitive::Sphere(s) => Target {
                shape: Shape::Sphere { c: s.center, r: s.radius },
                center,
                radius,
                self_list: transmits || s.inside_only,
                occluder: !(transmits || s.inside_only),
            },
            Primitive::Triangle(t) => Target {
                shape: Shape::Triangle { v: t.p },
                center,
                radius,
                self_list: false,
                occluder: !transmits,
            },
            Primitive::Cylinder(c) => Target {
                shape: Shape::Capsule { p0: c.base, p1: c.apex, rad: c.base_radius.max(c.apex_radius) },
                center,
                radius,
                self_list: true,
                occluder: false,
            },
        }
    }
}

/// Makes spheres self-listing when a ray can start inside them: `points`
/// (the eye, lights) or another primitive lie strictly inside. Tangent neighbours do not count.
pub fn mark_enclosing(targets: &mut [Target], bvh: &Bvh, points: &[DVec3]) {
    use super::geom::{point_segment_distance, point_triangle_distance};
    let inside: Vec<bool> = (0..targets.len())
        .map(|i| {
            let Shape::Sphere { c, r } = targets[i].shape else { return false };
            if targets[i].self_list {
                return false;
            }
            let strictly = r * (1.0 - 1e-6);
            if points.iter().any(|p| (*p - c).length() < strictly) {
                return true;
            }
            let mut stack = vec![0usize];
            while let Some(n) = stack.pop() {
                let node = bvh.nodes[n];
                if (node.center - c).length() >= strictly + node.radius {
                    continue;
                }
                if node.count == 0 {
                    stack.push(node.first as usize);
                    stack.push(node.first as usize + 1);
                    continue;
                }
                for &j in &bvh.order[node.first as usize..(node.first + node.count) as usize] {
                    if j as usize == i {
                        continue;
                    }
                    let d = match targets[j as usize].shape {
                        Shape::Sphere { c: cj, r: rj } => (cj - c).length() - rj,
                        Shape::Triangle { v } => point_triangle_distance(c, &v),
                        Shape::Capsule { p0, p1, rad } => point_segment_distance(c, p0, p1) - rad,
                    };
                    if d < strictly {
                        return true;
                    }
                }
            }
            false
        })
        .collect();
    for (t, inside) in targets.iter_mut().zip(inside) {
        t.self_list |= inside;
    }
}

/// Splits `ids` into spatially coherent groups of at most `k` (median split along the
/// longest axis of the centres).
pub fn cluster(ids: &[u32], centers: &[DVec3], k: usize) -> Vec<Vec<u32>> {
    let mut out = Vec::new();
    let mut stack = vec![ids.to_vec()];
    while let Some(mut g) = stack.pop() {
        if g.len() <= k.max(1) {
            if !g.is_empty() {
                out.push(g);
            }
            continue;
        }
        let (lo, hi) = g.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
            (lo.min(centers[i as usize]), hi.max(centers[i as usize]))
        });
        let ext = hi - lo;
        let ax = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        // Split at a multiple of k so that clusters come out full.
        let half = g.len().div_ceil(2).div_ceil(k) * k;
        let half = half.min(g.len() - 1).max(1);
        g.select_nth_unstable_by(half, |a, b| centers[*a as usize][ax].total_cmp(&centers[*b as usize][ax]));
        let right = g.split_off(half);
        stack.push(right);
        stack.push(g);
    }
    out
}

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
    /// Leaf: `first..first+count` of [`Bvh::order`]; inner: `count == 0`, children at
    /// `first` and `first + 1`.
    pub first: u32,
    pub count: u32,
}

/// Bounding-sphere hierarchy (median splits, leaves of at most 4 targets).
#[derive(Clone, Debug)]
pub struct Bvh {
    pub nodes: Vec<Node>,
    pub order: Vec<u32>,
}

impl Bvh {
    pub fn build(targets: &[Target]) -> Bvh {
        const LEAF: usize = 4;
        let mut order: Vec<u32> = (0..targets.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * targets.len() / LEAF + 1);
        if targets.is_empty() {
            return Bvh { nodes, order };
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
        Bvh { nodes, order }
    }
}

/// A surface patch is about this many times the median target radius across.
const PATCH_SCALE: f64 = 4.0;
/// At most `m×m` patches per triangle.
const MAX_PATCH_SIDE: u32 = 16;
/// At most this many patch origins in a scene.
const MAX_PATCHES: u32 = 1024;

/// How many patches per side each primitive's origin is split into (1: not split).
///
/// A large reflecting or transmitting triangle (an SPD ground polygon under a mirror finish)
/// is a poor origin: its bounding sphere holds the objects standing on it, so they would be
/// candidates with `d_min = 0` in every cell. Such a triangle is split by a barycentric grid
/// into patches about [`PATCH_SCALE`] median target radii across, each an origin of its own.
pub fn patch_counts(surface_ids: &[u32], targets: &[Target]) -> Vec<u32> {
    let mut m = vec![1u32; targets.len()];
    if targets.is_empty() {
        return m;
    }
    let mut radii: Vec<f64> = targets.iter().map(|t| t.radius).collect();
    let mid = radii.len() / 2;
    let (_, median, _) = radii.select_nth_unstable_by(mid, f64::total_cmp);
    let unit = PATCH_SCALE * *median;
    if unit.is_nan() || unit <= 0.0 {
        return m;
    }
    let mut total = 0u64;
    for &id in surface_ids {
        let t = &targets[id as usize];
        let Shape::Triangle { v } = t.shape else { continue };
        // Well-shaped triangles only (no angle under 30° at v[0], the corner the barycentric
        // grid spans): a sliver's patches would be slivers too.
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let (l1, l2) = (e1.length_squared(), e2.length_squared());
        let den = l1 * l2 - e1.dot(e2).powi(2);
        if den.is_nan() || den < 0.25 * l1 * l2 {
            continue;
        }
        // Size by area: a patch is about `unit` across.
        let size = (0.5 * den.sqrt()).sqrt();
        let side = (size / unit).ceil().clamp(1.0, MAX_PATCH_SIDE as f64) as u32;
        m[id as usize] = side;
        total += (side * side) as u64;
    }
    if total > MAX_PATCHES as u64 {
        // Scale every side down alike.
        let k = (MAX_PATCHES as f64 / total as f64).sqrt();
        for x in m.iter_mut().filter(|x| **x > 1) {
            *x = ((*x as f64 * k).floor() as u32).max(1);
        }
    }
    m
}

/// The point of triangle `v` at barycentrics `(b1, b2)` (weights of `v[1]`, `v[2]`).
fn barycentric_point(v: &[DVec3; 3], b1: f64, b2: f64) -> DVec3 {
    v[0] + (v[1] - v[0]) * b1 + (v[2] - v[0]) * b2
}

/// Bounding sphere of patch `(i, j)` of the `m×m` barycentric grid: the square
/// `b1 ∈ [i/m, (i+1)/m] × b2 ∈ [j/m, (j+1)/m]`, which holds every point the lookup
/// [`crate::mirror::triangle_patch`] assigns to the patch (it may reach past the hypotenuse).
pub fn patch_sphere(v: &[DVec3; 3], m: u32, i: u32, j: u32) -> (DVec3, f64) {
    let s = 1.0 / m as f64;
    let (b1, b2) = (i as f64 * s, j as f64 * s);
    let corners =
        [(b1, b2), (b1 + s, b2), (b1, b2 + s), (b1 + s, b2 + s)].map(|(a, b)| barycentric_point(v, a, b));
    let c = corners.iter().copied().sum::<DVec3>() / 4.0;
    let r = corners.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
    (c, r)
}

/// How far an f32 barycentric lookup may misplace a point of triangle `v` (its rounding,
/// relative to the coordinates' magnitude and the triangle's size), with a wide margin.
pub fn patch_rounding(v: &[DVec3; 3]) -> f64 {
    let mag = v.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max);
    let edge = (0..3).map(|k| (v[(k + 1) % 3] - v[k]).length()).fold(0.0, f64::max);
    1e-5 * (mag + edge)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clusters_partition_the_ids() {
        let centers: Vec<DVec3> =
            (0..103).map(|i| DVec3::new((i * 37 % 101) as f64, (i % 7) as f64, 0.0)).collect();
        let ids: Vec<u32> = (0..103).collect();
        for k in [1, 2, 5, 16, 200] {
            let cl = cluster(&ids, &centers, k);
            let mut all: Vec<u32> = cl.iter().flatten().copied().collect();
            all.sort();
            assert_eq!(all, ids);
            assert!(cl.iter().all(|c| !c.is_empty() && c.len() <= k));
        }
    }

    #[test]
    fn bvh_spheres_contain_their_targets() {
        let targets: Vec<Target> = (0..57)
            .map(|i| {
                let c = DVec3::new((i * 13 % 17) as f64, (i * 7 % 5) as f64, (i % 3) as f64);
                Target {
                    shape: Shape::Sphere { c, r: 0.5 },
                    center: c,
                    radius: 0.5,
                    self_list: false,
                    occluder: true,
                }
            })
            .collect();
        let bvh = Bvh::build(&targets);
        // Every target of a subtree lies inside the subtree's root sphere.
        fn subtree(bvh: &Bvh, n: usize, out: &mut Vec<u32>) {
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
