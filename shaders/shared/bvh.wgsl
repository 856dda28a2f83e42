// The BVH walk (`--accel bvh`): the baseline the candidate tables are timed against, and,
// with `--accel cube`, the walk of the rays leaving surfaces (walk.wgsl). The
// tree is flattened on the host into six threaded orders (src/layout/bvh.rs), one per major
// direction axis and sign, each listing the nodes depth first with the nearer child first
// and a `skip` index past every subtree. A ray takes the order of its direction and walks it
// with one index and no stack: a missed box goes on at `skip`, a hit inner node at the next
// node, a hit leaf tests its primitives and goes on at `skip`. A walk interrupted between
// passes keeps only that index and the leaf's primitives left. The same queries as walk.wgsl
// and brute.wgsl, with
// the same intersection functions and tie rule (`consider`); node tests are counted as
// bound tests, once per node the walk passes (a leaf's box tested again while it waits for
// the last leaf's primitives is not counted again).

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
    return BoxRay(ray.o, 1.0 / d, BVH_SLACK * max3(abs(ray.o)), order * params.bvh_stride);
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

// A position in a walk: the next node `at`, and the primitives k..kend of the last leaf
// entered still to test.
struct BvhWalk {
    at: u32,
    k: u32,
    kend: u32,
}

fn bvh_done(w: BvhWalk) -> bool {
    return w.at >= params.bvh_stride && w.k >= w.kend;
}

// Enters or skips node `w.at` after its box test `hit`: a hit leaf queues its primitives.
// A leaf hit while the last leaf's primitives are still queued waits (false): its box is
// tested again in the next iteration. Counts the tests that move the walk.
fn bvh_advance(w: ptr<function, BvhWalk>, n: BvhNode, hit: bool, ray_kind: u32) {
    if hit && n.leaf != 0u && (*w).k < (*w).kend {
        return;
    }
    count_bound(ray_kind);
    if hit && n.leaf == 0u {
        (*w).at += 1u;
        return;
    }
    if hit {
        (*w).k = n.leaf >> BVH_LEAF_SHIFT;
        (*w).kend = (*w).k + (n.leaf & ((1u << BVH_LEAF_SHIFT) - 1u));
    }
    (*w).at = n.skip;
}

// Continues the nearest-hit walk `w` for at most `budget` loop iterations, keeping the
// nearest hit in `best` (ties to the lower id; `skip` never tested). True when the walk is
// over. One flat loop (lavapipe's loop limit counts a loop's iterations while any lane of
// the SIMD vector is still in it, so nested loops would count the inner one for every
// lane), each iteration testing the next queued primitive *and* the next box: lavapipe runs
// both halves of an iteration whatever its lanes take, so the primitives of a leaf are
// tested while the walk goes on to the boxes after it, in about as many iterations as the
// walk has boxes instead of boxes and primitives. A box tested before the leaf's last
// primitives only sees a farther nearest hit, and is entered more often, never less: the
// hits are those of the walk that tests them in turn.
fn bvh_nearest(w: ptr<function, BvhWalk>, best: ptr<function, Closest>, ray: Ray, r: BoxRay, t_max: f32, skip: u32,
    ray_kind: u32, budget: u32) -> bool {
    var left = budget;
    var best_t = select(t_max, (*best).hit.t, (*best).found);
    loop {
        if bvh_done(*w) {
            break;
        }
        count_step();
        if left == 0u {
            return false;
        }
        left -= 1u;
        if (*w).k < (*w).kend {
            let id = bvh_prims[(*w).k];
            (*w).k += 1u;
            if id != skip {
                best_t = consider(id, best, ray, t_max, ray_kind, best_t);
            }
        }
        if (*w).at < params.bvh_stride {
            let n = bvh_nodes[r.base + (*w).at];
            bvh_advance(w, n, box_hit(n, r, best_t), ray_kind);
        }
    }
    return true;
}

#if BVH
// The nearest hit with 0 < t < t_max, ties to the lower id; `skip` is never tested (NO_ID:
// none). The BVH needs neither the ray's origin entity nor `from_prim`.
fn closest(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Closest {
    var best = no_closest();
    if max3(abs(ray.d)) == 0.0 {
        return best;
    }
    var w = BvhWalk(0u, 0u, 0u);
    bvh_nearest(&w, &best, ray, box_ray(ray), t_max, skip, ray_kind, UNBOUNDED);
    return best;
}

// `closest` for a job, in bounded passes: `done` false when the walk goes on in a later
// pass (from the position kept in `walk_state`: `i` the node,
// `j..jend` the leaf's primitives left).
fn closest_step(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Stepped {
    var best = no_closest();
    var w = BvhWalk(0u, 0u, 0u);
    if walking == 0u {
        if max3(abs(ray.d)) == 0.0 {
            return Stepped(true, best);
        }
    } else {
        let s = walk_state;
        w = BvhWalk(s.i, s.j, s.jend);
        if s.prim != NO_ID {
            best = Closest(true, s.prim, PrimHit(true, s.t, s.b1, s.b2));
        }
    }
    if bvh_nearest(&w, &best, ray, box_ray(ray), t_max, skip, ray_kind, WALK_CHUNK) {
        walking = 0u;
        return Stepped(true, best);
    }
    walking = 1u;
    walk_state = WalkState(w.at, 0u, w.k, w.kend, best.prim, best.hit.t, best.hit.b1, best.hit.b2);
    return Stepped(false, best);
}

#endif

#if SHADOWS
// Continues the any-hit walk `w` for at most `budget` loop iterations (as `bvh_nearest`, a
// primitive and a box an iteration):
// ANY_BLOCKED when some primitive other than `skip` is hit at 0 < t < t_max (its t noted in
// `blocker_t`), ANY_CLEAR when the walk ended without one, ANY_UNFINISHED when the budget
// ran out first.
fn bvh_any(w: ptr<function, BvhWalk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> u32 {
    let r = box_ray(ray);
    var left = budget;
    loop {
        if bvh_done(*w) {
            break;
        }
        count_step();
        if left == 0u {
            return ANY_UNFINISHED;
        }
        left -= 1u;
        if (*w).k < (*w).kend {
            let id = bvh_prims[(*w).k];
            (*w).k += 1u;
            if id != skip && blocks(id, ray, t_max) {
                return ANY_BLOCKED;
            }
        }
        if (*w).at < params.bvh_stride {
            let n = bvh_nodes[r.base + (*w).at];
            bvh_advance(w, n, box_hit(n, r, t_max), RAY_SHADOW);
        }
    }
    return ANY_CLEAR;
}

#if BVH
// `bvh_any`'s verdict on shadow ray `sr`, its blocker's distance from the spawn origin noted
// in `blocked_at`.
fn bvh_shadow(w: ptr<function, BvhWalk>, sr: ShadowRay, skip: u32, budget: u32) -> u32 {
    let r = bvh_any(w, sr.ray, sr.t_max, skip, budget);
    if r == ANY_BLOCKED {
        blocked_at = abs(blocker_t - sr.q_t);
    }
    return r;
}

// Whether light `light` is blocked from `q`, the spawn origin on primitive `from_prim` (the
// shadow ray of `shadow_ray`, geometry.wgsl, the one the other queries trace), when its
// walk ends within `params.bvh_inline` loop iterations (set by the host:
// `layout::budget::bvh_shadow_inline`); ANY_UNFINISHED when
// it does not, and the shadow ray becomes a job whose walk starts over.
fn occluded_short(q: vec3<f32>, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32) -> u32 {
    let sr = shadow_ray(q, to_light, light);
    if sr.empty {
        return ANY_CLEAR;
    }
    var w = BvhWalk(0u, 0u, 0u);
    return bvh_shadow(&w, sr, skip, params.bvh_inline);
}

// Whether light `light` is blocked from `q`, for a shadow job, in bounded passes (the
// walk's position kept in `walk_state`): ANY_UNFINISHED when it goes on in a later pass.
fn occluded_step(q: vec3<f32>, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32) -> u32 {
    let sr = shadow_ray(q, to_light, light);
    if sr.empty {
        walking = 0u;
        return ANY_CLEAR;
    }
    var w = BvhWalk(0u, 0u, 0u);
    if walking != 0u {
        w = BvhWalk(walk_state.i, walk_state.j, walk_state.jend);
    }
    let r = bvh_shadow(&w, sr, skip, WALK_CHUNK);
    walking = select(0u, 1u, r == ANY_UNFINISHED);
    walk_state = WalkState(w.at, 0u, w.k, w.kend, NO_ID, 0.0, 0.0, 0.0);
    return r;
}
#endif
#endif
