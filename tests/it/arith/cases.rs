//! The cases the intersection twins run on: random primitives at three scales, each with its
//! box one child of a wide node among random siblings, and rays at them (aimed, grazing,
//! through edges and vertices, axis-parallel, from the box's faces), the same on every run.

use cuberay::arith::geometry::Prim32;
use cuberay::layout::bvh::{quantise, WideNode};
use cuberay::layout::{Prim, KIND_CYLINDER, KIND_SPHERE, KIND_TRIANGLE};
use glam::Vec3;

use super::Rng;

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct Case {
    pub(super) o: [f32; 3],
    pub(super) prim: u32,
    pub(super) d: [f32; 3],
    pub(super) t_max: f32,
}

/// A primitive, its packed twin, its box, and the wide node its box is slot `slot` of.
pub(super) struct Shape {
    pub(super) prim: Prim32,
    pub(super) packed: Prim,
    pub(super) lo: [f32; 3],
    pub(super) hi: [f32; 3],
    pub(super) node: WideNode,
    pub(super) slot: u32,
}

impl Shape {
    /// The largest coordinate of the primitive's box.
    pub(super) fn extent(&self) -> f32 {
        self.lo.iter().chain(&self.hi).fold(0.0f32, |m, x| m.max(x.abs()))
    }

    /// Whether the node test's answer (`inner`, `prims`) for a ray of octant `octant` holds
    /// the primitive's own slot.
    pub(super) fn slot_hit(&self, inner: u32, prims: u32, octant: u32) -> bool {
        if self.node.imask() & (1 << self.slot) != 0 {
            inner & (1 << (self.slot ^ octant)) != 0
        } else {
            prims & (1 << (self.node.meta(self.slot as usize) & 31)) != 0
        }
    }
}

/// A wide node whose slot `slot` holds the box `lo`..`hi` (an inner child if `inner`, else
/// a leaf), the other slots empty or random boxes around it, inner or leaves of 1–3
/// primitives; quantised as the BVH's nodes are.
fn node_around(lo: Vec3, hi: Vec3, slot: usize, inner: bool, rng: &mut Rng) -> WideNode {
    let size = (hi - lo).max_element().max(1e-3);
    let mut children = [None; 8];
    let (mut meta, mut imask, mut offset) = ([0u8; 8], 0u32, 0u8);
    for s in 0..8 {
        let b = if s == slot {
            (lo, hi)
        } else if rng.next() % 4 == 0 {
            continue;
        } else {
            let a = (lo + hi) * 0.5 + rng.vec(size);
            (a, a + Vec3::new(rng.unit(), rng.unit(), rng.unit()) * size)
        };
        children[s] = Some((b.0.to_array(), b.1.to_array()));
        if if s == slot { inner } else { rng.next() % 2 == 0 } {
            imask |= 1 << s;
            meta[s] = 0b0010_0000 | (24 + s as u8);
        } else {
            let count = 1 + (rng.next() % 3) as u8;
            meta[s] = offset | ([0, 0b001, 0b011, 0b111][count as usize] << 5);
            offset += count;
        }
    }
    let all = children.iter().flatten().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), (a, b)| {
        (l.min(Vec3::from(*a)), h.max(Vec3::from(*b)))
    });
    let mut node = WideNode {
        e_imask: imask << 24,
        child_meta: [
            u32::from_le_bytes(meta[..4].try_into().unwrap()),
            u32::from_le_bytes(meta[4..].try_into().unwrap()),
        ],
        ..WideNode::default()
    };
    quantise(&mut node, (all.0.to_array(), all.1.to_array()), &children);
    node
}

fn shape(prim: Prim32, rng: &mut Rng) -> Shape {
    let v4 = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
    let (packed, lo, hi) = match prim {
        Prim32::Sphere { c, r, inside_only } => (
            Prim { a: v4(c, r), kind: KIND_SPHERE, flags: inside_only as u32, ..Prim::default() },
            c - Vec3::splat(r),
            c + Vec3::splat(r),
        ),
        Prim32::Triangle { p } => (
            Prim {
                a: v4(p[0], 0.0),
                b: v4(p[1], 0.0),
                c: v4(p[2], 0.0),
                kind: KIND_TRIANGLE,
                ..Prim::default()
            },
            p[0].min(p[1]).min(p[2]),
            p[0].max(p[1]).max(p[2]),
        ),
        Prim32::Cylinder { base, apex, inside_only } => {
            let (b, a) = (Vec3::from_slice(&base), Vec3::from_slice(&apex));
            let r = base[3].max(apex[3]);
            (
                Prim { a: base, b: apex, kind: KIND_CYLINDER, flags: inside_only as u32, ..Prim::default() },
                b.min(a) - Vec3::splat(r),
                b.max(a) + Vec3::splat(r),
            )
        }
    };
    let slot = (rng.next() % 8) as usize;
    let node = node_around(lo, hi, slot, rng.next() % 2 == 0, rng);
    Shape { prim, packed, lo: lo.to_array(), hi: hi.to_array(), node, slot: slot as u32 }
}

/// Random primitives and rays at them: rays aimed at a random point of the primitive,
/// grazing rays (tangent to a sphere or a cylinder, within a few ulps; through a triangle's
/// edge or vertex), axis-parallel rays, and rays whose origin sits on the box's face.
pub(super) fn cases(n: usize) -> (Vec<Shape>, Vec<Case>) {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut shapes = Vec::new();
    let mut cases = Vec::new();
    let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
    while cases.len() < n {
        let scale = rng.pick(&[1e-3f32, 1.0, 1e3]);
        let centre = rng.vec(4.0 * scale);
        let s = match rng.next() % 3 {
            0 => {
                let sphere = Prim32::Sphere {
                    c: centre,
                    r: rng.range(0.1, 2.0) * scale,
                    inside_only: rng.next() % 5 == 0,
                };
                shape(sphere, &mut rng)
            }
            1 => {
                let p = [
                    centre + rng.vec(2.0 * scale),
                    centre + rng.vec(2.0 * scale),
                    centre + rng.vec(2.0 * scale),
                ];
                shape(Prim32::Triangle { p }, &mut rng)
            }
            _ => {
                let base = centre;
                let apex = centre + rng.vec(2.0 * scale);
                let (rb, ra) = (rng.range(0.05, 1.0) * scale, rng.pick(&[0.0, 0.3, 1.0]) * scale);
                let inside_only = rng.next() % 5 == 0;
                let cylinder = Prim32::Cylinder {
                    base: [base.x, base.y, base.z, rb],
                    apex: [apex.x, apex.y, apex.z, ra],
                    inside_only,
                };
                shape(cylinder, &mut rng)
            }
        };
        let id = shapes.len() as u32;
        let (lo, hi) = (Vec3::from(s.lo), Vec3::from(s.hi));
        for k in 0..24 {
            // A target on or near the primitive.
            let target = match s.prim {
                Prim32::Sphere { c, r, .. } => {
                    let u = rng.dir();
                    // Grazing: the target sits on the silhouette seen from the origin, nudged
                    // by a few ulps of r.
                    c + u * r * (1.0 + rng.range(-4.0, 4.0) * f32::EPSILON)
                }
                Prim32::Triangle { p } => match k % 4 {
                    0 => p[(k / 4) % 3],
                    1 => p[(k / 4) % 3].lerp(p[(k / 4 + 1) % 3], rng.unit()),
                    _ => {
                        let (a, b) = (rng.unit(), rng.unit());
                        let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                        p[0] + (p[1] - p[0]) * a + (p[2] - p[0]) * b
                    }
                },
                Prim32::Cylinder { base, apex, .. } => {
                    let (b, a) = (Vec3::from_slice(&base), Vec3::from_slice(&apex));
                    b.lerp(a, rng.range(-0.1, 1.1)) + rng.dir() * base[3].max(apex[3])
                }
            };
            let (o, d) = match k % 6 {
                // Axis-parallel, through the target.
                0 => {
                    let d = rng.pick(&axes);
                    (target - d * rng.range(1.0, 8.0) * scale, d)
                }
                // From the box's face.
                1 => {
                    let mut o = target - rng.dir() * 3.0 * scale;
                    let axis = (rng.next() % 3) as usize;
                    o[axis] = if rng.next() % 2 == 0 { lo[axis] } else { hi[axis] };
                    (o, target - o)
                }
                // From inside the box, or anywhere around.
                2 => {
                    let o = lo.lerp(hi, rng.unit());
                    (o, rng.dir())
                }
                _ => {
                    let o = target + rng.dir() * rng.range(0.5, 10.0) * scale;
                    (o, target - o)
                }
            };
            if d.length_squared() == 0.0 || !d.is_finite() {
                continue;
            }
            let t_max = if k % 7 == 3 { (target - o).length() * rng.range(0.9, 1.1) } else { f32::MAX };
            cases.push(Case { o: o.to_array(), prim: id, d: d.to_array(), t_max });
        }
        shapes.push(s);
    }
    (shapes, cases)
}
