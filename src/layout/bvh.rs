//! The BVH as the GPU walks it (`--accel bvh`, and the rays leaving surfaces under `cube`;
//! `shaders/shared/bvh.wgsl`): the compressed 8-wide BVH of Ylitie, Karras and Laine (2017)
//! that obvhs builds ([`crate::bvh::build_wide`]) over the scene re-centred on the eye.
//!
//! A node ([`WideNode`], 80 bytes) holds its eight children's boxes quantised to 8 bits per
//! plane against a grid of the node (origin `p`, a power-of-two step per axis), which
//! children are inner nodes, where their nodes and the leaves' primitives start, and each
//! leaf's primitives (up to 3; up to 24 a node). Slots are ordered by direction octant, so a
//! ray takes its hit children in the order `rank = slot ^ octant` and meets the nearer ones
//! first. A walk keeps the node whose children it is taking, those children left (8 bits) and
//! the primitives left to test (24 bits); a short stack of nodes above it lives only within a
//! kernel pass. What the stack drops, and everything above the walk when a pass ends it, is
//! found again by climbing [`GpuBvh::parents`] and testing the parent's children anew.
//!
//! **Conservative boxes.** The boxes going in are grown by [`BVH_PAD_REL`] of their size and
//! distance from the eye and rounded outward to f32, and the kernel grows them by
//! `BVH_SLACK` of the ray origin's distance (`WideNode::hits`). obvhs quantises the child boxes with
//! f32 `floor`/`ceil` of rounded differences and an exponent from an f32 `log2`, which can
//! cut a box short; so every node is quantised again here ([`quantise`]): each plane is the
//! one whose decoded f32 value, computed as the kernel computes it (`p + q·step`, one
//! rounding), lies on the outer side of the child's f32 box (a decoded value that would be
//! a subnormal counts as both itself and the zero a driver may flush it to).

use bytemuck::{Pod, Zeroable};

use crate::bvh::{self, WIDE_NODE_PRIMS};
use crate::coherence::reach::WalkBounds;
use crate::coherence::walk::WALK_CHUNK;
use crate::scene::{Aabb, Scene};

/// One node of the compressed wide BVH (WGSL `WideNode`, keep in sync with
/// `shaders/shared/bvh.wgsl`); its layout is obvhs's `CwBvhNode` with the exponents and the
/// inner-child mask in one word.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct WideNode {
    /// The grid's origin: the node box's lower corner.
    pub p: [f32; 3],
    /// The grid step of each axis as a biased f32 exponent byte (`step = 2^(e − 127)`, bits
    /// 0–23, x first), and in bits 24–31 which slots hold inner nodes.
    pub e_imask: u32,
    /// The first inner child's node; inner children follow in slot order.
    pub child_base: u32,
    /// The first of the node's leaf primitives in `bvh_prims`.
    pub prim_base: u32,
    /// One byte a slot (slots 0–3 in word 0): 0 empty; an inner child `0b001_00000 | (24 +
    /// slot)`; a leaf its first primitive's offset from `prim_base` (bits 0–4) and its
    /// count in unary (bits 5–7).
    pub child_meta: [u32; 2],
    /// The quantised planes, one byte a slot: per axis x, y, z a `[u32; 4]` of the lower
    /// planes of slots 0–3 and 4–7, then the upper ones.
    pub q: [[u32; 4]; 3],
}

/// The kernel grows a box by this much of the ray origin's largest coordinate, and the far
/// slab distance by this much of itself (WGSL `BVH_SLACK`): the f32 primitive tests err by a
/// few ulps of the distances involved.
pub const BVH_SLACK: f32 = 1e-5;

/// Each slab side of the kernel's node test moves out by this much, `2⁻²⁰`, of the
/// magnitudes its distance is computed from (WGSL `BVH_DECODE_REL`; see
/// [`WideNode::hits`]).
pub const BVH_DECODE_REL: f32 = 1.0 / 1_048_576.0;

/// Boxes are grown by this much of their size plus their largest coordinate (eye-relative)
/// before rounding outward to f32: it covers the f32 rounding of the packed primitives.
pub const BVH_PAD_REL: f64 = 1e-5;

/// The parent of the root in [`GpuBvh::parents`] (WGSL `BVH_NO_PARENT`).
pub const BVH_NO_PARENT: u32 = u32::MAX;

/// `Walk::i` of a BVH walk not started (WGSL `BVH_FRESH`); a started one holds there the
/// node whose children it takes.
pub const BVH_FRESH: u32 = u32::MAX;

/// Entries of the kernels' in-pass stack of nodes with children left (WGSL `BVH_STACK`):
/// deeper, the bottom entry drops and is found again by climbing.
pub const BVH_STACK: u32 = 4;

/// Loop iterations one pass gives a nearest-hit walk under `--accel bvh` (WGSL `BVH_CHUNK`):
/// [`WALK_CHUNK`] less the room a walk whose budget runs out takes to test the two groups of
/// primitives it holds (a walk stops between passes with none left).
pub const BVH_CHUNK: u32 = WALK_CHUNK - 2 * WIDE_NODE_PRIMS;

/// A ray ready for box tests (WGSL `BoxRay`, twin of `box_ray` in
/// `shaders/shared/bvh.wgsl`: keep them in sync): its reciprocal direction (components below
/// 1e-20 in size taken as +1e-20, so that nothing divides by zero), the growth of the boxes,
/// and its direction octant (bit 2: x negative, bit 1: y, bit 0: z, of the same direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxRay {
    pub o: [f32; 3],
    pub inv: [f32; 3],
    pub pad: f32,
    pub octant: u32,
}

/// The box-test form of the ray from `o` along unit `d` (WGSL `box_ray`).
pub fn box_ray(o: [f32; 3], d: [f32; 3]) -> BoxRay {
    // WGSL `select(ray.d, vec3(1e-20), abs(ray.d) < vec3(1e-20))`, per component.
    let d: [f32; 3] = std::array::from_fn(|k| if d[k].abs() < 1e-20 { 1e-20 } else { d[k] });
    let inv = d.map(|x| 1.0 / x);
    let pad = BVH_SLACK * o.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    let octant = u32::from(d[0] < 0.0) << 2 | u32::from(d[1] < 0.0) << 1 | u32::from(d[2] < 0.0);
    BoxRay { o, inv, pad, octant }
}

/// Byte `i` of a little-endian array of words.
fn byte(words: &[u32], i: usize) -> u32 {
    (words[i / 4] >> (8 * (i % 4))) & 0xff
}

impl WideNode {
    /// The grid step of each axis.
    pub fn step(&self) -> [f32; 3] {
        std::array::from_fn(|k| f32::from_bits(((self.e_imask >> (8 * k)) & 0xff) << 23))
    }

    /// Which slots hold inner nodes.
    pub fn imask(&self) -> u32 {
        self.e_imask >> 24
    }

    /// Slot `slot`'s meta byte (0: empty).
    pub fn meta(&self, slot: usize) -> u32 {
        byte(&self.child_meta, slot)
    }

    /// Slot `slot`'s quantised planes: (lower, upper) per axis.
    pub fn planes(&self, slot: usize) -> [(u32, u32); 3] {
        std::array::from_fn(|k| (byte(&self.q[k], slot), byte(&self.q[k], 8 + slot)))
    }

    /// Slot `slot`'s box as its planes decode: `p + q·step` (one rounding: `q·step` is
    /// exact). The quantisation makes it hold the child's box.
    pub fn child_box(&self, slot: usize) -> ([f32; 3], [f32; 3]) {
        let (s, pl) = (self.step(), self.planes(slot));
        (
            std::array::from_fn(|k| self.p[k] + pl[k].0 as f32 * s[k]),
            std::array::from_fn(|k| self.p[k] + pl[k].1 as f32 * s[k]),
        )
    }

    /// The node index of inner child `slot`.
    pub fn child(&self, slot: u32) -> u32 {
        self.child_base + (self.imask() & ((1 << slot) - 1)).count_ones()
    }

    /// The children the ray meets before `t_far` (WGSL `node_hits`, operation for
    /// operation): the inner ones as bits of their rank (`slot ^ octant`, the order the walk
    /// takes them in), and the leaves' primitives as bits of their offset from `prim_base`.
    ///
    /// A plane of byte `q` lies along the ray at `t = q·a + b`, `a = step·inv` (exact: the step
    /// is a power of two) and `b = (p − o)·inv`. Each slab side moves out by the box growth
    /// `r.pad` and by [`BVH_DECODE_REL`] of `|p − o| + 255·step` (times `|inv|`): more than the
    /// rounding of `p − o`, of `q·a + b` (a product and a sum, as lavapipe computes them; a
    /// driver that fuses them errs less), of `inv`, and of the decoded plane itself (whose
    /// rounding the pad covers where `o` is large). So a child whose decoded box the ray meets is hit, and the
    /// decoded box holds the child's. The far side grows by [`BVH_SLACK`] of itself, as the
    /// primitive tests err relative to the distance.
    pub fn hits(&self, r: &BoxRay, t_far: f32) -> (u32, u32) {
        let step = self.step();
        let (mut a, mut bn, mut bf) = ([0.0f32; 3], [0.0f32; 3], [0.0f32; 3]);
        for k in 0..3 {
            let po = self.p[k] - r.o[k];
            a[k] = step[k] * r.inv[k];
            let m = (r.pad + BVH_DECODE_REL * (po.abs() + 255.0 * step[k])) * r.inv[k].abs();
            bn[k] = po * r.inv[k] - m;
            bf[k] = po * r.inv[k] + m;
        }
        let (mut inner, mut prims) = (0, 0);
        for slot in 0..8 {
            let meta = self.meta(slot);
            let pl = self.planes(slot);
            let side = |k: usize, near: bool| {
                let lower = (r.inv[k] < 0.0) != near;
                let q = if lower { pl[k].0 } else { pl[k].1 };
                q as f32 * a[k] + if near { bn[k] } else { bf[k] }
            };
            let t0 = side(0, true).max(side(1, true)).max(side(2, true).max(0.0));
            let t1 = side(0, false).min(side(1, false)).min(side(2, false)) * (1.0 + BVH_SLACK);
            // An empty slot (meta 0) adds nothing: no imask bit, no primitive.
            if t0 > t1.min(t_far) {
                continue;
            }
            if self.imask() & (1 << slot) != 0 {
                inner |= 1 << (slot as u32 ^ r.octant);
            } else {
                prims |= (meta >> 5) << (meta & 31);
            }
        }
        (inner, prims)
    }
}

/// The BVH as the GPU holds it: its nodes (node 0 the root; the preview leaves room after
/// them), the primitive ids its leaves point into, and each node's parent and slot there
/// (`parent << 3 | slot`; the root's [`BVH_NO_PARENT`]).
#[derive(Clone, Debug, Default)]
pub struct GpuBvh {
    pub nodes: Vec<WideNode>,
    pub prims: Vec<u32>,
    pub parents: Vec<u32>,
    /// Levels of nodes from the root to the deepest leaf (1: the root alone).
    pub depth: u32,
}

impl GpuBvh {
    /// Bytes on the GPU.
    pub fn bytes(&self) -> u64 {
        (std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.prims.as_slice())
            + std::mem::size_of_val(self.parents.as_slice())) as u64
    }

    /// Bounds on the kernels' walks, for the loop budget and the tile size. One loop
    /// iteration tests at most a primitive and a node; a walk enters each node once and tests
    /// each primitive once, and climbs to a parent at most once per child of it, so it takes
    /// at most `prims + 9·nodes` iterations, which lavapipe's loop limit counts as up to twice
    /// as many (see [`super::budget::bvh_shadow_inline`]). A typical walk takes a few nodes a
    /// level and a few leaves' primitives; the waves are planned for a walk of sixteen
    /// typical ones, not for the worst, which no ray of a real scene comes near.
    pub fn walk_bounds(&self) -> WalkBounds {
        let worst = 2 * (self.prims.len() as u64 + 9 * self.nodes.len() as u64);
        let mean_list = 3.0 * self.depth.max(1) as f64 + WIDE_NODE_PRIMS as f64;
        WalkBounds {
            worst_closest: worst,
            worst_eye: worst,
            worst_shadow: worst,
            mean_list,
            planned: worst.min(16 * mean_list as u64),
            fallback_reachable: false,
            eye_untabled: false,
            mixed: false,
        }
    }
}

/// The box of a primitive relative to `eye`, grown by [`BVH_PAD_REL`] and rounded out.
fn eye_box(b: &Aabb, eye: glam::DVec3) -> ([f32; 3], [f32; 3]) {
    let rel = Aabb { min: b.min - eye, max: b.max - eye };
    let size = (rel.max - rel.min).max_element();
    let far = rel.min.abs().max(rel.max.abs()).max_element();
    bvh::outward_box(&rel, BVH_PAD_REL * (size + far))
}

/// The boxes the GPU BVH of `scene` is built over: each primitive's, re-centred on the eye
/// (as [`super::pack()`] packs it), grown and rounded out.
pub fn eye_boxes(scene: &Scene) -> Vec<([f32; 3], [f32; 3])> {
    let eye = scene.camera.eye;
    scene.primitives.iter().map(|p| eye_box(&p.bounds(), eye)).collect()
}

/// Builds the wide BVH of `scene` re-centred on its eye.
pub fn pack_bvh(scene: &Scene) -> GpuBvh {
    wide(&eye_boxes(scene))
}

/// The wide BVH of `boxes` (one per primitive, in f32), quantised conservatively.
pub fn wide(boxes: &[([f32; 3], [f32; 3])]) -> GpuBvh {
    let cw = bvh::build_wide(boxes);
    let n = cw.nodes.len();
    if n == 0 {
        return GpuBvh::default();
    }
    // Children come after their parents: each node's box from the leaves up.
    let mut node_box = vec![([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]); n];
    let mut child_boxes = vec![[None; 8]; n];
    for i in (0..n).rev() {
        let c = &cw.nodes[i];
        let mut all = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for slot in 0..8 {
            if c.is_child_empty(slot) {
                continue;
            }
            let b = if !c.is_leaf(slot) {
                node_box[c.child_node_index(slot) as usize]
            } else {
                let (first, count) = c.child_primitives(slot);
                let ids = &cw.primitive_indices[first as usize..(first + count) as usize];
                ids.iter()
                    .fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |b, &id| union(b, boxes[id as usize]))
            };
            child_boxes[i][slot] = Some(b);
            all = union(all, b);
        }
        node_box[i] = all;
    }
    let mut nodes = Vec::with_capacity(n);
    let mut parents = vec![BVH_NO_PARENT; n];
    let mut depth = vec![1u32; n];
    for (i, c) in cw.nodes.iter().enumerate() {
        let mut node = WideNode {
            e_imask: (c.imask as u32) << 24,
            child_base: c.child_base_idx,
            prim_base: c.primitive_base_idx,
            child_meta: std::array::from_fn(|w| {
                u32::from_le_bytes(std::array::from_fn(|b| c.child_meta[4 * w + b]))
            }),
            ..WideNode::default()
        };
        quantise(&mut node, node_box[i], &child_boxes[i]);
        for slot in 0..8 {
            if !c.is_child_empty(slot) && !c.is_leaf(slot) {
                let child = c.child_node_index(slot) as usize;
                parents[child] = (i as u32) << 3 | slot as u32;
                depth[child] = depth[i] + 1;
            }
        }
        nodes.push(node);
    }
    debug_assert!(n < 1 << 29, "a parent's index and slot share a word");
    GpuBvh { nodes, prims: cw.primitive_indices, parents, depth: depth.into_iter().max().unwrap_or(1) }
}

fn union(a: ([f32; 3], [f32; 3]), b: ([f32; 3], [f32; 3])) -> ([f32; 3], [f32; 3]) {
    (std::array::from_fn(|k| a.0[k].min(b.0[k])), std::array::from_fn(|k| a.1[k].max(b.1[k])))
}

/// The values `p + q·step` may decode to on a device: the f32 sum, and zero where the sum is
/// subnormal (a driver may flush it).
fn decoded(p: f32, q: u32, step: f32) -> [f32; 2] {
    let v = p + q as f32 * step;
    if v != 0.0 && v.abs() < f32::MIN_POSITIVE {
        [v, 0.0]
    } else {
        [v, v]
    }
}

/// Quantises `node`'s grid and child planes for a node box `all` and its children's boxes
/// (`None`: an empty slot), so that every decoded child box contains its box: the origin is
/// the node box's lower corner (a subnormal taken to zero or the least normal below it), and
/// each axis's step the least power of two whose 255 steps from the origin decode to the
/// node box's upper side or beyond.
pub fn quantise(
    node: &mut WideNode,
    all: ([f32; 3], [f32; 3]),
    children: &[Option<([f32; 3], [f32; 3])>; 8],
) {
    let mut exponents = 0u32;
    for k in 0..3 {
        let mut p = all.0[k];
        if p != 0.0 && p.abs() < f32::MIN_POSITIVE {
            p = if p > 0.0 { 0.0 } else { -f32::MIN_POSITIVE };
        }
        node.p[k] = p;
        let top = all.1[k];
        let reaches = |e: i32| decoded(p, 255, (e as f32).exp2()).iter().all(|&v| v >= top);
        // The least exponent, from the estimate, stepped up or down by f32's own sums.
        let extent = (top as f64 - p as f64).max(0.0);
        let mut e = if extent > 0.0 { (extent / 255.0).log2().ceil() as i32 } else { -126 };
        e = e.clamp(-126, 127);
        while !reaches(e) {
            assert!(e < 127, "a BVH node's box is too large for f32 to quantise");
            e += 1;
        }
        while e > -126 && reaches(e - 1) {
            e -= 1;
        }
        let step = (e as f32).exp2();
        exponents |= (((e + 127) as u32) & 0xff) << (8 * k);
        for (slot, child) in children.iter().enumerate() {
            let Some((lo, hi)) = child else { continue };
            let below = |q: u32| decoded(p, q, step).iter().all(|&v| v <= lo[k]);
            let above = |q: u32| decoded(p, q, step).iter().all(|&v| v >= hi[k]);
            let mut qlo = ((lo[k] as f64 - p as f64) / step as f64).floor().clamp(0.0, 255.0) as u32;
            while qlo > 0 && !below(qlo) {
                qlo -= 1;
            }
            while qlo < 255 && below(qlo + 1) {
                qlo += 1;
            }
            let mut qhi = ((hi[k] as f64 - p as f64) / step as f64).ceil().clamp(0.0, 255.0) as u32;
            while qhi < 255 && !above(qhi) {
                qhi += 1;
            }
            while qhi > 0 && above(qhi - 1) {
                qhi -= 1;
            }
            debug_assert!(below(qlo) && above(qhi), "quantisation cannot cover a child box");
            let set = |words: &mut [u32; 4], i: usize, v: u32| {
                words[i / 4] = (words[i / 4] & !(0xff << (8 * (i % 4)))) | v << (8 * (i % 4));
            };
            set(&mut node.q[k], slot, qlo);
            set(&mut node.q[k], 8 + slot, qhi);
        }
    }
    node.e_imask = (node.e_imask & 0xff00_0000) | exponents;
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn boxes(n: usize) -> Vec<([f32; 3], [f32; 3])> {
        (0..n)
            .map(|i| {
                let c = DVec3::new((i % 9) as f64 * 2.0, (i / 9 % 4) as f64, (i as f64 * 0.71).cos() * 3.0);
                bvh::outward_box(&Aabb { min: c, max: c + DVec3::splat(0.5) }, 0.0)
            })
            .collect()
    }

    fn contains(outer: ([f32; 3], [f32; 3]), inner: ([f32; 3], [f32; 3])) -> bool {
        (0..3).all(|k| outer.0[k] <= inner.0[k] && inner.1[k] <= outer.1[k])
    }

    /// The primitives under slot `slot` of node `i`, and every box of every node on the way.
    fn check_subtree(
        g: &GpuBvh,
        boxes: &[([f32; 3], [f32; 3])],
        i: usize,
        above: &[([f32; 3], [f32; 3])],
        seen: &mut [u32],
    ) {
        let n = &g.nodes[i];
        for slot in 0..8 {
            let meta = n.meta(slot);
            if meta == 0 {
                continue;
            }
            let mut path = above.to_vec();
            path.push(n.child_box(slot));
            if n.imask() & (1 << slot) != 0 {
                let child = n.child(slot as u32) as usize;
                assert_eq!(g.parents[child], (i as u32) << 3 | slot as u32);
                check_subtree(g, boxes, child, &path, seen);
            } else {
                let (first, count) = (n.prim_base + (meta & 31), (meta >> 5).count_ones());
                assert!((1..=3).contains(&count), "a leaf of {count}");
                for &p in &g.prims[first as usize..(first + count) as usize] {
                    seen[p as usize] += 1;
                    for b in &path {
                        assert!(contains(*b, boxes[p as usize]), "primitive {p} outside a box above it");
                    }
                }
            }
        }
    }

    #[test]
    fn every_primitive_is_in_one_leaf_inside_every_decoded_box_above_it() {
        for n in [1, 2, 3, 7, 40, 300, 2000] {
            let b = boxes(n);
            let g = wide(&b);
            let mut seen = vec![0u32; n];
            check_subtree(&g, &b, 0, &[], &mut seen);
            assert!(seen.iter().all(|&s| s == 1), "{n} primitives: each in exactly one leaf");
            assert_eq!(g.parents[0], BVH_NO_PARENT);
            assert!(g.depth >= 1);
        }
    }

    /// obvhs's f32 quantisation cut these boxes short (`../shared/docs/cwbvh-notes.md`: a
    /// child coordinate much smaller than the grid's origin, and an extent just above
    /// 255·2^k); the planes quantised here cover them.
    #[test]
    fn quantisation_covers_the_cases_obvhs_cuts_short() {
        let mut node = WideNode::default();
        let child = ([-1e-6, 0.0, 0.0], [1040.0, 1.0, 1.0]);
        quantise(
            &mut node,
            ([-1000.0, 0.0, 0.0], [1040.0, 1.0, 1.0]),
            &[Some(child), None, None, None, None, None, None, None],
        );
        node.child_meta[0] = 0b0010_0000;
        assert!(contains(node.child_box(0), child), "{:?} against {child:?}", node.child_box(0));
        for k in -20..20 {
            let e = (k as f32).exp2();
            for ulps in 1..40 {
                let top = f32::from_bits((255.0 * e).to_bits() + ulps);
                let child = ([0.0; 3], [top, top * 0.5, top]);
                let mut node = WideNode::default();
                quantise(&mut node, child, &[Some(child), None, None, None, None, None, None, None]);
                assert!(contains(node.child_box(0), child), "extent 255·2^{k} + {ulps} ulps");
            }
        }
    }

    /// Whether the ray from `o` along `d` meets the box `lo`..`hi` at some t in [0, t_far],
    /// in f64 (`d` not normalised: t in units of `d`).
    fn exact_slab(lo: [f32; 3], hi: [f32; 3], o: [f32; 3], d: [f32; 3], t_far: f64) -> bool {
        let (mut t0, mut t1) = (0.0f64, t_far);
        for k in 0..3 {
            let (lo, hi, o, d) = (lo[k] as f64, hi[k] as f64, o[k] as f64, d[k] as f64);
            if d == 0.0 {
                if o < lo || o > hi {
                    return false;
                }
                continue;
            }
            let (a, b) = ((lo - o) / d, (hi - o) / d);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        t0 <= t1
    }

    /// The node test never misses a child whose decoded box the ray meets (in f64), and
    /// takes few that it misses.
    #[test]
    fn node_hits_hold_every_decoded_box_the_ray_meets() {
        let b = boxes(500);
        let g = wide(&b);
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (rng >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let (mut met, mut extra) = (0, 0);
        for i in 0..20000 {
            let node = &g.nodes[(next().abs() * (g.nodes.len() - 1) as f32) as usize];
            // Aimed at a point near the node's box.
            let (lo, hi) = (node.child_box(0).0, node.child_box(0).1);
            let o = [next() * 20.0, next() * 10.0, next() * 10.0];
            let at: [f32; 3] =
                std::array::from_fn(|k| (lo[k] + hi[k]) * 0.5 + next() * (hi[k] - lo[k] + 1.0));
            let mut d: [f32; 3] = std::array::from_fn(|k| at[k] - o[k]);
            if i % 5 == 0 {
                d[i % 3] = 0.0;
            }
            let r = box_ray(o, d);
            let t_far = if i % 3 == 0 { 0.8 } else { f32::MAX };
            let (inner, prims) = node.hits(&r, t_far);
            for slot in 0..8 {
                let meta = node.meta(slot);
                if meta == 0 {
                    continue;
                }
                let (lo, hi) = node.child_box(slot);
                let exact = exact_slab(lo, hi, o, d, t_far as f64);
                let got = if node.imask() & (1 << slot) != 0 {
                    inner & 1 << (slot as u32 ^ r.octant) != 0
                } else {
                    prims & 1 << (meta & 31) != 0
                };
                assert!(got || !exact, "slot {slot} of {node:?} missed: o {o:?} d {d:?}");
                met += exact as u32;
                extra += (got && !exact) as u32;
            }
        }
        assert!(met > 1000 && extra * 100 < met, "{met} boxes met, {extra} more taken");
    }
}
