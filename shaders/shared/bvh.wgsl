// The BVH walk (`--accel bvh`): the baseline the candidate tables are timed against, and,
// with `--accel cube`, the walk of the rays leaving surfaces (walk.wgsl). The
// tree is flattened on the host into six threaded orders (src/layout/bvh.rs), one per major
// direction axis and sign, each listing the nodes depth first with the nearer child first
// and a `skip` index past every subtree. A ray takes the order of its direction and walks it
// with one index and no stack: a missed box goes on at `skip`, a hit inner node at the next
// node, a hit leaf tests its primitives and goes on at `skip`. A walk interrupted between
// passes keeps only that index and the leaf's primitives left. As an accelerator of its own
// (`BVH`) it supplies query.wgsl's protocol, with the same intersection functions and tie
// rule (`consider`) as the others; the table walk (walk.wgsl) walks it for rays leaving
// surfaces. A walk's `Walk` holds the next node in `i` and the last leaf's primitives left
// in `j..jend`. Node tests are counted as bound tests, once per node the walk passes (a
// leaf's box tested again while it waits for the last leaf's primitives is not counted
// again).

// One node of a threaded order (src/layout/bvh.rs `BvhNode`): `leaf` 0 for an inner node,
// else `first << BVH_LEAF_SHIFT | count` primitives at bvh_prims[first..first + count].
struct BvhNode {
    lo: vec3<f32>,
    skip: u32,
    hi: vec3<f32>,
    leaf: u32,
}

const BVH_LEAF_SHIFT: u32 = 4u;
// Boxes grow by this much of the ray origin's largest coordinate, and the far slab distance
// by this much of itself, so that the box test never misses what the primitive test hits.
const BVH_SLACK: f32 = 1e-5;

@group(0) @binding(20) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(21) var<storage, read> bvh_prims: array<u32>;

// A ray ready for box tests: its reciprocal direction (components below 1e-20 taken as
// 1e-20, so that nothing divides by zero), the growth of the boxes, and where its order
// starts in `bvh_nodes`.
struct BoxRay {
    o: vec3<f32>,
    inv: vec3<f32>,
    pad: f32,
    base: u32,
}

fn box_ray(ray: Ray) -> BoxRay {
    let a = abs(ray.d);
    var axis = 2u;
    if a.x >= a.y && a.x >= a.z {
        axis = 0u;
    } else if a.y >= a.z {
        axis = 1u;
    }
    let order = 2u * axis + select(0u, 1u, ray.d[axis] < 0.0);
    let d = select(ray.d, vec3<f32>(1e-20), a < vec3<f32>(1e-20));
    // An f64 origin rounded to f32 moves by 2⁻²⁴ of its magnitude, far inside BVH_SLACK.
    let o = vec3<f32>(ray.o);
    return BoxRay(o, 1.0 / d, BVH_SLACK * max3(abs(o)), order * params.bvh_stride);
}

// Whether the ray meets node `n`'s box, grown by `r.pad`, at some t in [0, t_far].
fn box_hit(n: BvhNode, r: BoxRay, t_far: f32) -> bool {
    let a = (n.lo - vec3<f32>(r.pad) - r.o) * r.inv;
    let b = (n.hi + vec3<f32>(r.pad) - r.o) * r.inv;
    let near = min(a, b);
    let far = max(a, b);
    let t0 = max(max(near.x, near.y), max(near.z, 0.0));
    let t1 = min(min(far.x, far.y), far.z) * (1.0 + BVH_SLACK);
    return t0 <= min(t1, t_far);
}

#if BVH
// A position in a walk: the next node `i`, and the primitives j..jend of the last leaf
// entered still to test (`iend` unused).
struct Walk {
    i: u32,
    iend: u32,
    j: u32,
    jend: u32,
}
#endif

fn bvh_walk() -> Walk {
    return Walk(0u, 0u, 0u, 0u);
}

fn bvh_done(w: Walk) -> bool {
    return w.i >= params.bvh_stride && w.j >= w.jend;
}

// Enters or skips node `w.at` after its box test `hit`: a hit leaf queues its primitives.
// A leaf hit while the last leaf's primitives are still queued waits (false): its box is
// tested again in the next iteration. Counts the tests that move the walk.
fn bvh_advance(w: ptr<function, Walk>, n: BvhNode, hit: bool, ray_kind: u32) {
    if hit && n.leaf != 0u && (*w).j < (*w).jend {
        return;
    }
    count_bound(ray_kind);
    if hit && n.leaf == 0u {
        (*w).i += 1u;
        return;
    }
    if hit {
        (*w).j = n.leaf >> BVH_LEAF_SHIFT;
        (*w).jend = (*w).j + (n.leaf & ((1u << BVH_LEAF_SHIFT) - 1u));
    }
    (*w).i = n.skip;
}

// Continues the nearest-hit walk `w` for at most `*left` more loop iterations (taken from
// `*left`), taking the hits into `best` by the tie rule (`consider`; `skip` never tested),
// and entering the boxes the window reaches. True when the walk is over. One flat loop (lavapipe's loop limit counts a loop's iterations while any lane of
// the SIMD vector is still in it, so nested loops would count the inner one for every
// lane), each iteration testing the next queued primitive *and* the next box: lavapipe runs
// both halves of an iteration whatever its lanes take, so the primitives of a leaf are
// tested while the walk goes on to the boxes after it, in about as many iterations as the
// walk has boxes instead of boxes and primitives. A box tested before the leaf's last
// primitives only sees a farther nearest hit, and is entered more often, never less: the
// hits are those of the walk that tests them in turn.
fn bvh_nearest(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32,
    ray_kind: u32, left: ptr<function, u32>) -> bool {
    let r = box_ray(ray);
    var limit = closest_limit(*best, t_max);
    loop {
        if bvh_done(*w) {
            break;
        }
        count_step();
        if *left == 0u {
            return false;
        }
        *left -= 1u;
        if (*w).j < (*w).jend {
            let id = bvh_prims[(*w).j];
            (*w).j += 1u;
            if id != skip {
                limit = consider(id, best, ray, t_max, ray_kind);
            }
        }
        if (*w).i < params.bvh_stride {
            let n = bvh_nodes[r.base + (*w).i];
            bvh_advance(w, n, box_hit(n, r, limit), ray_kind);
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
    return WALK_CHUNK;
}
#endif

#if SHADOWS
// Continues the any-hit walk `w` for at most `budget` loop iterations (as `bvh_nearest`, a
// primitive and a box an iteration): ANY_BLOCKED when some primitive other than `skip` is
// hit at 0 < t < t_max (with its t), ANY_CLEAR when the walk ended without one,
// ANY_UNFINISHED when the budget ran out first.
fn bvh_any(w: ptr<function, Walk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> AnyHit {
    let r = box_ray(ray);
    var left = budget;
    loop {
        if bvh_done(*w) {
            break;
        }
        count_step();
        if left == 0u {
            return any_answer(ANY_UNFINISHED);
        }
        left -= 1u;
        if (*w).j < (*w).jend {
            let id = bvh_prims[(*w).j];
            (*w).j += 1u;
            if id != skip {
                let h = test_any(id, ray, t_max);
                if h.ok {
                    return AnyHit(ANY_BLOCKED, h.t);
                }
            }
        }
        if (*w).i < params.bvh_stride {
            let n = bvh_nodes[r.base + (*w).i];
            bvh_advance(w, n, box_hit(n, r, t_max), RAY_SHADOW);
        }
    }
    return any_answer(ANY_CLEAR);
}

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
