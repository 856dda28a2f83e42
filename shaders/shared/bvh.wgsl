// The BVH walk (`--accel bvh`): the baseline the candidate tables are timed against, and,
// with `--accel cube`, the walk of the rays leaving surfaces (walk.wgsl). The tree is the
// compressed 8-wide BVH of Ylitie, Karras and Laine (2017), built by obvhs and quantised
// conservatively on the host (src/layout/bvh.rs, keep in sync): a node holds its eight
// children's boxes in bytes against a grid of its own, slots ordered by direction octant.
// A ray tests all eight boxes of a node at once and takes the hit inner children in the
// order `rank = slot ^ octant` (the nearer side first), and the hit leaves' primitives
// (up to 24 a node) as a mask. One flat loop, each iteration testing the next queued
// primitive and, once the node's primitives are done, entering the next node: lavapipe's
// loop limit counts a loop while any lane is in it, so nested loops would count the inner
// one for every lane. Nodes above the current one wait on a short stack of BVH_STACK
// entries in registers; what it drops, and what a pass leaves between passes (only the
// current node, its children left and its primitives left), is found again by climbing to
// the parent (`bvh_parents`) and testing its children anew, which with a shrinking limit
// finds no more than the first test did. As an accelerator of its own (`BVH`) it supplies
// query.wgsl's protocol, with the same intersection functions and tie rule (`consider`) as
// the others. Node tests are counted as bound tests, one per node (eight boxes).

// One node (src/layout/bvh.rs `WideNode`): the grid origin `p`, the grid steps as biased
// exponent bytes (bits 0-23) and which slots are inner nodes (bits 24-31), where the inner
// children and the leaves' primitives start, a meta byte a slot (0 empty; a leaf: first
// primitive's offset in bits 0-4, count in unary in bits 5-7), and the quantised planes (per
// axis: lower planes of slots 0-3, 4-7, then upper).
struct WideNode {
    p: vec3<f32>,
    e_imask: u32,
    child_base: u32,
    prim_base: u32,
    child_meta: array<u32, 2>,
    q: array<array<u32, 4>, 3>,
}

// Boxes grow by this much of the ray origin's largest coordinate, and the far slab distance
// by this much of itself, so that the box test never misses what the primitive test hits.
const BVH_SLACK: f32 = 1e-5;
// Each slab side moves out by this much (2⁻²⁰, 16 ulps) of the magnitudes its distance is
// computed from: more than the rounding of (p − o)·inv and of q·a + b.
const BVH_DECODE_REL: f32 = 9.5367431640625e-7;
// The root's entry in `bvh_parents` (the others: parent << 3 | slot).
const BVH_NO_PARENT: u32 = 0xffffffffu;
// `Walk.i` of a walk not started.
const BVH_FRESH: u32 = 0xffffffffu;
// Entries of the in-pass stack of nodes with children left (BvhWalk's s0..s3).
const BVH_STACK: u32 = 4u;
// Loop iterations one pass gives a nearest-hit walk of the BVH as an accelerator of its own:
// WALK_CHUNK less the room a walk takes to test the primitives it holds when they run out.
const BVH_CHUNK: u32 = WALK_CHUNK - 2u * WIDE_NODE_PRIMS;
// The most primitives of one node's leaves.
const WIDE_NODE_PRIMS: u32 = 24u;

@group(0) @binding(20) var<storage, read> bvh_nodes: array<WideNode>;
@group(0) @binding(21) var<storage, read> bvh_prims: array<u32>;
@group(0) @binding(24) var<storage, read> bvh_parents: array<u32>;

// A ray ready for box tests: its reciprocal direction (components below 1e-20 taken as
// +1e-20, so that nothing divides by zero), the growth of the boxes, and the octant of that
// direction (bit 2: x negative, bit 1: y, bit 0: z).
struct BoxRay {
    o: vec3<f32>,
    inv: vec3<f32>,
    pad: f32,
    octant: u32,
}

fn box_ray(ray: Ray) -> BoxRay {
    let d = select(ray.d, vec3<f32>(1e-20), abs(ray.d) < vec3<f32>(1e-20));
    // An f64 origin rounded to f32 moves by 2⁻²⁴ of its magnitude, far inside BVH_SLACK.
    let o = vec3<f32>(ray.o);
    let octant = select(0u, 4u, d.x < 0.0) | select(0u, 2u, d.y < 0.0) | select(0u, 1u, d.z < 0.0);
    return BoxRay(o, 1.0 / d, BVH_SLACK * max3(abs(o)), octant);
}

// The children of a node that a ray meets: the inner ones as bits of their rank, the leaves'
// primitives as bits of their offset from the node's `prim_base`.
struct NodeHits {
    inner: u32,
    prims: u32,
}

// A slab side's distances along the ray for four children's planes of quantised bytes `q`,
// on an axis whose planes lie at t = q·a + b.
fn slab4(q: u32, a: f32, b: f32) -> vec4<f32> {
    return vec4<f32>(unpack4xU8(q)) * a + b;
}

// Which of four children the ray meets before `t_far`, as bits 0-3: their near plane bytes on
// each axis `nx`, `ny`, `nz` and far ones `fx`, `fy`, `fz`, at t = q·a + bn (near) or q·a + bf
// (far).
fn half_hits(nx: u32, ny: u32, nz: u32, fx: u32, fy: u32, fz: u32, a: vec3<f32>, bn: vec3<f32>, bf: vec3<f32>,
    t_far: f32) -> u32 {
    let t0 = max(max(slab4(nx, a.x, bn.x), slab4(ny, a.y, bn.y)), max(slab4(nz, a.z, bn.z), vec4<f32>(0.0)));
    let t1 = min(min(slab4(fx, a.x, bf.x), slab4(fy, a.y, bf.y)), slab4(fz, a.z, bf.z)) * (1.0 + BVH_SLACK);
    let hit = t0 <= min(t1, vec4<f32>(t_far));
    return select(0u, 1u, hit.x) | select(0u, 2u, hit.y) | select(0u, 4u, hit.z) | select(0u, 8u, hit.w);
}

// The children of node `n` that ray `r` meets before `t_far` (twin: WideNode::hits). A plane
// of byte q lies at p + q·step, and along the ray at t = q·a + b with a = step·inv (exact:
// the step is a power of two) and b = (p − o)·inv; each side is moved out by the box growth
// `r.pad` and by BVH_DECODE_REL of the magnitudes involved, which bounds the rounding of
// b and of q·a + b (a product and a sum; a driver that fuses them errs less), so that the
// slab holds the box the planes decode to (which holds the primitives: src/layout/bvh.rs).
// The far side grows by BVH_SLACK of itself.
fn node_hits(n: WideNode, r: BoxRay, t_far: f32) -> NodeHits {
    let e = n.e_imask;
    let step = vec3<f32>(bitcast<f32>((e & 0xffu) << 23u), bitcast<f32>(((e >> 8u) & 0xffu) << 23u),
        bitcast<f32>(((e >> 16u) & 0xffu) << 23u));
    let po = n.p - r.o;
    let a = step * r.inv;
    let m = (vec3<f32>(r.pad) + BVH_DECODE_REL * (abs(po) + 255.0 * step)) * abs(r.inv);
    let bn = po * r.inv - m;
    let bf = po * r.inv + m;
    // The lower planes are near where the direction is positive, the upper ones where not
    // (chosen by select: an index that varies across lanes costs lavapipe a loop over them).
    let neg = r.inv < vec3<f32>(0.0);
    let x = n.q[0];
    let y = n.q[1];
    let z = n.q[2];
    let nx = select(vec2<u32>(x[0], x[1]), vec2<u32>(x[2], x[3]), neg.x);
    let fx = select(vec2<u32>(x[2], x[3]), vec2<u32>(x[0], x[1]), neg.x);
    let ny = select(vec2<u32>(y[0], y[1]), vec2<u32>(y[2], y[3]), neg.y);
    let fy = select(vec2<u32>(y[2], y[3]), vec2<u32>(y[0], y[1]), neg.y);
    let nz = select(vec2<u32>(z[0], z[1]), vec2<u32>(z[2], z[3]), neg.z);
    let fz = select(vec2<u32>(z[2], z[3]), vec2<u32>(z[0], z[1]), neg.z);
    let m0 = unpack4xU8(n.child_meta[0]);
    let m1 = unpack4xU8(n.child_meta[1]);
    let none = vec4<u32>(0u);
    let slot_bits = vec4<u32>(1u, 2u, 4u, 8u);
    // An empty slot (meta 0) may pass the box test: it is no inner child (no imask bit)
    // and names no primitive (a count of 0), so it adds nothing.
    let hit = half_hits(nx.x, ny.x, nz.x, fx.x, fy.x, fz.x, a, bn, bf, t_far) |
        (half_hits(nx.y, ny.y, nz.y, fx.y, fy.y, fz.y, a, bn, bf, t_far) << 4u);
    let imask = e >> 24u;
    // Slot bits to rank bits: rank = slot ^ octant swaps bits, pairs and nibbles.
    var inner = hit & imask;
    inner = select(inner, ((inner & 0x55u) << 1u) | ((inner >> 1u) & 0x55u), (r.octant & 1u) != 0u);
    inner = select(inner, ((inner & 0x33u) << 2u) | ((inner >> 2u) & 0x33u), (r.octant & 2u) != 0u);
    inner = select(inner, ((inner & 0x0fu) << 4u) | ((inner >> 4u) & 0x0fu), (r.octant & 4u) != 0u);
    let leaf = hit & ~imask;
    let five = vec4<u32>(5u);
    let l0 = select(none, (m0 >> five) << (m0 & vec4<u32>(31u)), (vec4<u32>(leaf) & slot_bits) != none);
    let l1 = select(none, (m1 >> five) << (m1 & vec4<u32>(31u)), (vec4<u32>(leaf >> 4u) & slot_bits) != none);
    let l = l0 | l1;
    return NodeHits(inner, l.x | l.y | l.z | l.w);
}

#if BVH
// A position in a walk between passes: `i` the node whose children the walk is taking
// (BVH_FRESH: not started), `j` those children left (by rank); `iend` and `jend` unused. A
// walk stops between passes only with no primitive left to test.
struct Walk {
    i: u32,
    iend: u32,
    j: u32,
    jend: u32,
}
#endif

fn bvh_walk() -> Walk {
    return Walk(BVH_FRESH, 0u, 0u, 0u);
}

// A walk within a pass: the node whose children it is taking, with its `child_base`, its
// inner-child mask and the children left (by rank); two groups of primitives to test, each
// a node's hit leaves (bits of `pmask` at `bvh_prims[pbase + bit]`): the group being tested,
// and the group of the node entered last, waiting; the stack (`s0` on top: node,
// child_base, inner mask, children left); and whether nodes above the stack's bottom may
// have children left (the stack dropped one, or the walk was resumed).
struct BvhWalk {
    node: u32,
    base: u32,
    imask: u32,
    hits: u32,
    pbase: u32,
    pmask: u32,
    next_pbase: u32,
    next_pmask: u32,
    depth: u32,
    climb: bool,
    s0: vec4<u32>,
    s1: vec4<u32>,
    s2: vec4<u32>,
    s3: vec4<u32>,
}

// Makes node `node` the one whose children the walk takes: its hit inner children, and its
// hit leaves' primitives, which wait for the group being tested.
fn bvh_enter(st: ptr<function, BvhWalk>, node: u32, r: BoxRay, limit: f32, ray_kind: u32) {
    count_bound(ray_kind);
    let n = bvh_nodes[node];
    let h = node_hits(n, r, limit);
    (*st).node = node;
    (*st).base = n.child_base;
    (*st).imask = n.e_imask >> 24u;
    (*st).hits = h.inner;
    (*st).next_pbase = n.prim_base;
    (*st).next_pmask = h.prims;
}

// The walk `w` within a pass: one not started enters the root (a BVH without nodes has
// nothing to walk); a resumed one stands where it stood, with the nodes above it to climb.
fn bvh_resume(w: Walk, r: BoxRay, limit: f32, ray_kind: u32) -> BvhWalk {
    var st: BvhWalk;
    if params.bvh_node_count == 0u {
        return st;
    }
    if w.i == BVH_FRESH {
        bvh_enter(&st, 0u, r, limit, ray_kind);
        return st;
    }
    let n = bvh_nodes[w.i];
    st.node = w.i;
    st.base = n.child_base;
    st.imask = n.e_imask >> 24u;
    st.hits = w.j;
    st.climb = true;
    return st;
}

// Where `st` stands, with no primitive left to test, to resume in a later pass (`w`'s
// `iend`, the table walk's tag, kept).
fn bvh_saved(st: BvhWalk, w: Walk) -> Walk {
    return Walk(st.node, w.iend, st.hits, 0u);
}

// The waiting group of primitives becomes the one tested once that is done.
fn bvh_next_group(st: ptr<function, BvhWalk>) {
    if (*st).pmask == 0u {
        (*st).pbase = (*st).next_pbase;
        (*st).pmask = (*st).next_pmask;
        (*st).next_pmask = 0u;
    }
}

// Whether walk `st` is over (after `bvh_next_group`): nothing left to test, on the stack or
// above it.
fn bvh_over(st: BvhWalk) -> bool {
    return st.pmask == 0u && st.hits == 0u && st.depth == 0u && !(st.climb && st.node != 0u);
}

// The next primitive of the group being tested (one is left).
fn bvh_next_prim(st: ptr<function, BvhWalk>) -> u32 {
    let b = firstTrailingBit((*st).pmask);
    (*st).pmask &= (*st).pmask - 1u;
    return bvh_prims[(*st).pbase + b];
}

// One node of the walk: the next hit child is entered (its parent, if it has children left,
// goes on the stack, whose bottom entry drops when full); with none left, the stack's top is
// taken, or else the parent is climbed to, its children after this node tested anew. Either
// way one node is fetched and tested: lavapipe runs every branch a lane of its SIMD group
// takes, so the entering and the climbing share one `bvh_enter`.
fn bvh_step(st: ptr<function, BvhWalk>, r: BoxRay, limit: f32, ray_kind: u32) {
    if (*st).hits == 0u && (*st).depth > 0u {
        let top = (*st).s0;
        (*st).s0 = (*st).s1;
        (*st).s1 = (*st).s2;
        (*st).s2 = (*st).s3;
        (*st).depth -= 1u;
        (*st).node = top.x;
        (*st).base = top.y;
        (*st).imask = top.z;
        (*st).hits = top.w;
    }
    var next: u32;
    // With a climb: the rank of the child climbed from, whose parent's children up to it are
    // taken already.
    var climbed_from = 8u;
    if (*st).hits != 0u {
        let rank = firstTrailingBit((*st).hits);
        (*st).hits &= (*st).hits - 1u;
        let slot = rank ^ r.octant;
        next = (*st).base + countOneBits((*st).imask & ((1u << slot) - 1u));
        if (*st).hits != 0u {
            if (*st).depth == BVH_STACK {
                (*st).climb = true;
            } else {
                (*st).depth += 1u;
            }
            (*st).s3 = (*st).s2;
            (*st).s2 = (*st).s1;
            (*st).s1 = (*st).s0;
            (*st).s0 = vec4<u32>((*st).node, (*st).base, (*st).imask, (*st).hits);
        }
    } else if (*st).climb && (*st).node != 0u {
        let up = bvh_parents[(*st).node];
        next = up >> 3u;
        climbed_from = (up & 7u) ^ r.octant;
    } else {
        return;
    }
    bvh_enter(st, next, r, limit, ray_kind);
    if climbed_from < 8u {
        // Its leaves were tested when it was entered, its children up to this one taken.
        (*st).hits &= ~((2u << climbed_from) - 1u);
        (*st).next_pmask = 0u;
    }
}

// Continues the nearest-hit walk `w` for at most `*left` more loop iterations (taken from
// `*left`), taking the hits into `best` by the tie rule (`consider`; `skip` never tested),
// and entering the boxes the window reaches. True when the walk is over. Each iteration
// tests the next primitive of the group being tested, and enters a node unless a group
// waits already: a node entered before the last primitives only sees a farther nearest hit
// and enters more, never less, so the hits are those of the walk that tests them in turn;
// and a walk of p primitives and n nodes takes about max(p, n) iterations, not p + n. With
// `*left` spent, the walk enters no more nodes and tests the groups it holds (at most
// 2·WIDE_NODE_PRIMS iterations more: `walk_chunk` leaves room), so that it stops with none.
fn bvh_nearest(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32,
    ray_kind: u32, left: ptr<function, u32>) -> bool {
    let r = box_ray(ray);
    var limit = closest_limit(*best, t_max);
    var st = bvh_resume(*w, r, limit, ray_kind);
    var draining = false;
    loop {
        bvh_next_group(&st);
        if draining && st.pmask == 0u {
            *w = bvh_saved(st, *w);
            return false;
        }
        if bvh_over(st) {
            break;
        }
        count_step();
        if *left == 0u {
            draining = true;
        } else {
            *left -= 1u;
        }
        if st.pmask != 0u {
            let id = bvh_next_prim(&st);
            if id != skip {
                limit = consider(id, best, ray, t_max, ray_kind);
            }
        }
        if !draining && st.next_pmask == 0u {
            bvh_step(&st, r, limit, ray_kind);
        }
    }
    return true;
}

#if BVH
// The protocol of query.wgsl: every ray walks the BVH from its root, in one or many passes.
fn walk_of_ray(from_prim: u32, ray: Ray) -> Walk {
    return bvh_walk();
}

fn walk_nearest(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32,
    ray_kind: u32, left: ptr<function, u32>) -> bool {
    return bvh_nearest(w, best, ray, t_max, skip, ray_kind, left);
}

fn walk_chunk(w: Walk) -> u32 {
    return BVH_CHUNK;
}
#endif

#if SHADOWS
#if BVH_SHADOWS
// Continues the any-hit walk `w` for at most `budget` loop iterations (as `bvh_nearest`, and
// as many more as it takes to test the groups it holds when the budget runs out):
// ANY_BLOCKED when some primitive other than `skip` is hit at 0 < t < t_max (with its t),
// ANY_CLEAR when the walk ended without one, ANY_UNFINISHED when the budget ran out first.
fn bvh_any(w: ptr<function, Walk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> AnyHit {
    let r = box_ray(ray);
    var st = bvh_resume(*w, r, t_max, RAY_SHADOW);
    var left = budget;
    var draining = false;
    loop {
        bvh_next_group(&st);
        if draining && st.pmask == 0u {
            *w = bvh_saved(st, *w);
            return any_answer(ANY_UNFINISHED);
        }
        if bvh_over(st) {
            break;
        }
        count_step();
        if left == 0u {
            draining = true;
        } else {
            left -= 1u;
        }
        if st.pmask != 0u {
            let id = bvh_next_prim(&st);
            if id != skip {
                let h = test_any(id, ray, t_max);
                if h.ok {
                    return AnyHit(ANY_BLOCKED, h.t);
                }
            }
        }
        if !draining && st.next_pmask == 0u {
            bvh_step(&st, r, t_max, RAY_SHADOW);
        }
    }
    return any_answer(ANY_CLEAR);
}
#endif

#if BVH
// The protocol of query.wgsl for shadow rays: the BVH from its root; a walk traced at its
// hit gets `params.bvh_inline` loop iterations (`layout::budget::bvh_shadow_inline`), and
// one that outlasts them becomes a job whose walk starts over.
fn walk_of_shadow(sr: ShadowRay, light: u32, from_prim: u32) -> Walk {
    return bvh_walk();
}

fn walk_any(w: ptr<function, Walk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> AnyHit {
    return bvh_any(w, ray, t_max, skip, budget);
}

fn walk_inline(w: Walk) -> u32 {
    return params.bvh_inline;
}
#endif
#endif
