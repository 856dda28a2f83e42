//! Primitive groups: small sets of neighbouring primitives under one bounding sphere, which
//! long candidate lists name instead of their members.
//!
//! A reflecting cluster sees most of the scene through each of its cells, so its lists run
//! to thousands of candidates, and a ray that escapes to the background tests them all.
//! Where a list is long, the members of one group that it holds are replaced by a single
//! group entry ([`GROUP_BIT`] set in its id, `d_min` the least of theirs). The walker tests
//! the ray against the group's sphere first and, only if the sphere lies across the ray
//! before the nearest hit so far, tests every member of the group. The lists stay sorted
//! by `d_min`, so the early exit is unchanged, and a group entry tests a superset of the
//! members it replaced, so the hits are the same as testing every object.
//!
//! Groups are the subtrees of the bounding-sphere hierarchy ([`SphereTree`]) holding at most
//! [`GROUP_SIZE`] targets, in the hierarchy's order; the GPU copy of their spheres is in the
//! camera-relative f32 frame of the rays ([`Groups::gpu`]) and widened so that the f32 sphere
//! test ([`group_hit`]) never drops a member that the exact test would hit.

use glam::{DVec3, Vec3};

use super::flat::{GpuEntry, GpuGroup, GROUP_BIT};
use super::hierarchy::SphereTree;

/// Most targets in one group.
pub const GROUP_SIZE: usize = 16;

/// Lists shorter than this keep their members: grouping pays only where a ray would
/// otherwise walk many candidates.
pub const GROUP_MIN_LIST: usize = 24;

/// The partition of the targets into groups.
#[derive(Clone, Debug, Default)]
pub struct Groups {
    /// Per group: `members[first..first + count]`.
    pub spans: Vec<(u32, u32)>,
    /// Per group: bounding sphere (world frame, f64).
    pub spheres: Vec<(DVec3, f64)>,
    /// The targets, group after group.
    pub members: Vec<u32>,
    /// Per target: its group.
    pub of: Vec<u32>,
}

impl Groups {
    /// Groups of at most `max` targets: the largest hierarchy subtrees that small.
    pub fn of_bvh(bvh: &SphereTree, targets: usize, max: usize) -> Groups {
        let mut g = Groups { of: vec![0; targets], ..Groups::default() };
        if bvh.nodes.is_empty() {
            return g;
        }
        // Subtree ranges follow the build's median split: the left child gets half.
        let mut stack = vec![(0u32, 0usize, targets)];
        while let Some((ni, a, b)) = stack.pop() {
            let node = bvh.nodes[ni as usize];
            if b - a <= max || node.count > 0 {
                let first = g.members.len() as u32;
                for &t in &bvh.order[a..b] {
                    g.of[t as usize] = g.spans.len() as u32;
                    g.members.push(t);
                }
                g.spans.push((first, (b - a) as u32));
                g.spheres.push((node.center, node.radius));
                continue;
            }
            let mid = a + (b - a) / 2;
            // Right pushed first so that groups come out in the hierarchy's order.
            stack.push((node.first + 1, mid, b));
            stack.push((node.first, a, mid));
        }
        g
    }

    /// The groups' spheres relative to `eye` in f32, for the GPU and the walkers: the
    /// centre rounded, the radius widened by that rounding and rounded up.
    pub fn gpu(&self, eye: DVec3) -> Vec<GpuGroup> {
        self.spans
            .iter()
            .zip(&self.spheres)
            .map(|(&(first, count), &(c, r))| {
                let rel = c - eye;
                let cf = rel.as_vec3();
                let moved = (cf.as_dvec3() - rel).length();
                let radius = ((r + moved) * (1.0 + 1e-6) + 1e-30) as f32;
                GpuGroup {
                    cx: cf.x,
                    cy: cf.y,
                    cz: cf.z,
                    radius: radius * (1.0 + f32::EPSILON),
                    first,
                    count,
                    ..GpuGroup::default()
                }
            })
            .collect()
    }

    /// Replaces, in a list sorted by `d_min`, the
    /// members of every group holding two or more of them by one group entry with their
    /// least `d_min` (lists shorter than `min_list` stay as they are); the result is sorted by `d_min` again (ties by id).
    pub fn group_list(&self, list: &mut Vec<GpuEntry>, min_list: usize) {
        if list.len() < min_list || self.spans.is_empty() {
            return;
        }
        let mut keyed: Vec<(u32, GpuEntry)> = list.iter().map(|e| (self.of[e.id as usize], *e)).collect();
        keyed.sort_unstable_by_key(|x| x.0);
        list.clear();
        let mut i = 0;
        while i < keyed.len() {
            let mut j = i;
            while j < keyed.len() && keyed[j].0 == keyed[i].0 {
                j += 1;
            }
            if j - i >= 2 {
                let d_min = keyed[i..j].iter().map(|x| x.1.d_min).fold(f32::MAX, f32::min);
                list.push(GpuEntry { id: GROUP_BIT | keyed[i].0, d_min });
            } else {
                list.push(keyed[i].1);
            }
            i = j;
        }
        list.sort_unstable_by(|a, b| a.d_min.total_cmp(&b.d_min).then(a.id.cmp(&b.id)));
    }
}

/// Relative widening of the f32 group test: covers the rounding of the ray's origin and
/// direction (a reference ray converted from f64) and of the f32 primitives, with room
/// (WGSL `GROUP_SLACK` in `shaders/shared/tables.wgsl`, keep them in sync).
pub const GROUP_SLACK: f32 = 1e-5;

/// Whether the ray `o + t·d` (`d` unit, f32, camera-relative) may meet group `g`'s sphere at
/// some `0 < t ≤ t_far`: the twin of `group_hit` in `shaders/shared/tables.wgsl` (keep them in
/// sync). Conservative: false only when no
/// member can be hit there.
pub fn group_hit(g: &GpuGroup, o: Vec3, d: Vec3, t_far: f32) -> bool {
    let oc = Vec3::new(g.cx, g.cy, g.cz) - o;
    let tc = oc.dot(d);
    let rr = g.radius + GROUP_SLACK * (tc.abs() + g.radius + o.abs().max_element());
    if tc + rr < 0.0 || tc - rr > t_far {
        return false;
    }
    let v = oc - tc * d;
    v.dot(v) <= rr * rr
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coherence::targets::{Shape, Target};

    fn sphere_target(c: DVec3, r: f64) -> Target {
        Target { shape: Shape::Sphere { c, r }, center: c, radius: r, occluder: true }
    }

    fn targets(n: usize) -> Vec<Target> {
        (0..n)
            .map(|i| {
                let x = i as f64;
                sphere_target(
                    DVec3::new((x * 0.37).sin() * 40.0 + 1e4, (x * 0.11).cos() * 25.0, x * 0.05),
                    0.2,
                )
            })
            .collect()
    }

    #[test]
    fn groups_partition_the_targets_and_bound_them() {
        let t = targets(1000);
        let bvh = SphereTree::build(&t);
        let g = Groups::of_bvh(&bvh, t.len(), GROUP_SIZE);
        let mut seen = vec![0u32; t.len()];
        for (gi, &(first, count)) in g.spans.iter().enumerate() {
            assert!(count >= 1 && count as usize <= GROUP_SIZE);
            let (c, r) = g.spheres[gi];
            for &m in &g.members[first as usize..(first + count) as usize] {
                seen[m as usize] += 1;
                assert_eq!(g.of[m as usize], gi as u32);
                let tm = &t[m as usize];
                assert!(
                    (tm.center - c).length() + tm.radius <= r * (1.0 + 1e-12),
                    "member outside its group"
                );
            }
        }
        assert!(seen.iter().all(|&k| k == 1), "every target in exactly one group");
        assert!(g.spans.len() * GROUP_SIZE / 2 <= t.len(), "groups are at least half full on average");
    }

    #[test]
    fn group_test_never_drops_a_member_the_ray_meets() {
        // Far from the origin (x = 1e4), so the f32 frame's rounding matters.
        let t = targets(400);
        let bvh = SphereTree::build(&t);
        let g = Groups::of_bvh(&bvh, t.len(), GROUP_SIZE);
        let eye = DVec3::new(1e4 - 60.0, 3.0, 1.0);
        let gpu = g.gpu(eye);
        let (mut met, mut culled) = (0, 0);
        for (k, tm) in t.iter().enumerate() {
            let Shape::Sphere { c, r } = tm.shape else { unreachable!() };
            // Rays through a point just inside the member, from several origins.
            for s in 0..8 {
                let a = (k * 8 + s) as f64;
                let from = eye + DVec3::new(a.sin() * 30.0, a.cos() * 30.0, (a * 0.3).sin() * 10.0);
                let inside =
                    c + DVec3::new(a.cos(), (a * 1.3).sin(), (a * 0.7).cos()).normalize() * r * 0.999;
                let d = (inside - from).normalize();
                let hit_t = (inside - from).length();
                let grp = &gpu[g.of[k] as usize];
                assert!(
                    group_hit(grp, (from - eye).as_vec3(), d.as_vec3(), hit_t as f32),
                    "member {k} dropped"
                );
                met += 1;
                // The same ray stopped well before the group misses it.
                let (gc, gr) = g.spheres[g.of[k] as usize];
                let before = (gc - from).dot(d) - gr;
                if before > 1.0 && !group_hit(grp, (from - eye).as_vec3(), d.as_vec3(), (before * 0.5) as f32)
                {
                    culled += 1;
                }
            }
        }
        assert!(met > 0 && culled > met / 2, "the test culls: {culled} of {met}");
    }
}
