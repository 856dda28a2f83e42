// The table walk: line-by-line twin of src/coherence/walk.rs (keep them in sync), but for the
// BVH branches, whose CPU counterpart is the reference's own BVH (reference/tables.rs). (Taking
// the BVH's steps in the list walk's loop made the BVH walks slower: balls_s4 +11 %,
// rings_s7 +17 %.) A ray finds its list (the cell of its direction in the direction cube of
// the eye or the light it is traced from) and walks it merged with the origin's always-test
// list by increasing d_min, stopping once d_min passes the nearest hit so far; a long walk
// is spread over several passes. Rays leaving surfaces walk the BVH (bvh.wgsl) or, with
// SURFACE_RQ, take the platform's ray queries (rayquery.wgsl). It supplies query.wgsl's
// protocol.

#if SURFACE_RAYS
#if SURFACE_RQ
#include "shared/rayquery.wgsl"
#else
#include "shared/bvh.wgsl"
#endif
#endif

// A position in the merged walk of a cell's list (i..iend) and the always list (j..jend);
// with `iend` SURFACE_WALK, the walk of a ray leaving a surface: of the BVH (bvh.wgsl: the
// node `i` whose children it takes, those children and its primitives left in `j`), or a ray
// query (`i` unused).
struct Walk {
    i: u32,
    iend: u32,
    j: u32,
    jend: u32,
}

// The walk of the cell of direction `d` (not zero) in direction cube `origin`'s table,
// merged with the origin's always list (twin: coherence::walk::cell_walk).
fn cell_walk(origin: u32, d: vec3<f32>) -> Walk {
    let org = origins[origin];
    let range = cube_cell_range(origin, d);
    return Walk(range.x, range.y, org.always_start, org.always_start + org.always_count);
}

// The walk of a ray leaving primitive `from_prim` (NO_ID: the eye) along `d` (not zero): the
// eye's cell; for a ray leaving a surface, or from an eye without a table (`--accel auto`
// built none), the surface walk (`params.surface_walk`); else the fallback origin (twin of
// FlatTables::walk_from, where `reference::tables` hands the BVH's rays to the reference's
// own BVH).
fn walk_from(from_prim: u32, d: vec3<f32>) -> Walk {
    if from_prim == NO_ID && params.eye_origin != NO_ORIGIN {
        return cell_walk(params.eye_origin, d);
    }
#if SURFACE_RAYS
    if params.surface_walk != 0u {
#if SURFACE_RQ
        return Walk(0u, SURFACE_WALK, 0u, 0u);
#else
        return Walk(BVH_FRESH, SURFACE_WALK, 0u, 0u);
#endif
    }
#endif
    return cell_walk(params.fallback_origin, d);
}

// The protocol of query.wgsl: a ray's walk, and the loop iterations a pass gives it.
fn walk_of_ray(from_prim: u32, ray: Ray) -> Walk {
    return walk_from(from_prim, ray.d);
}

// The entry the merged walk visits next; the walk is over when `w.i == w.iend` and
// `w.j == w.jend` before the call (`walk_done`).
fn walk_next(w: ptr<function, Walk>) -> GpuEntry {
    var e: GpuEntry;
    if (*w).i < (*w).iend && ((*w).j >= (*w).jend || entries[(*w).i].d_min <= entries[(*w).j].d_min) {
        e = entries[(*w).i];
        (*w).i += 1u;
    } else {
        e = entries[(*w).j];
        (*w).j += 1u;
    }
    return e;
}

fn walk_done(w: Walk) -> bool {
    return w.i >= w.iend && w.j >= w.jend;
}

// The loop iterations one pass spends on walk `w`: WALK_CHUNK, and half of it for a walk of
// the BVH, whose iterations lavapipe's loop limit may count twice (layout::bvh::walk_bounds),
// so that either kind of chunk counts as at most one (layout::budget::check_loop_budget); a
// BVH walk whose chunk runs out takes up to 2·WIDE_NODE_PRIMS more to finish its primitives.
fn walk_chunk(w: Walk) -> u32 {
    return select(WALK_CHUNK, WALK_CHUNK / 2u, w.iend == SURFACE_WALK);
}

// Continues the nearest-hit walk `w` for at most `*left` more loop iterations (an entry
// each, taken from `*left`), taking the hits into `best` by the tie rule (`consider`;
// `skip` never tested) until an entry's d_min passes the window. True when the walk is over.
fn walk_nearest(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32, ray_kind: u32,
    left: ptr<function, u32>) -> bool {
#if SURFACE_RAYS
    if (*w).iend == SURFACE_WALK {
#if SURFACE_RQ
        rq_nearest(best, ray, t_max, skip, ray_kind);
        return true;
#else
        return bvh_nearest(w, best, ray, t_max, skip, ray_kind, left);
#endif
    }
#endif
    var limit = closest_limit(*best, t_max);
    loop {
        count_step();
        if walk_done(*w) {
            break;
        }
        if *left == 0u {
            return false;
        }
        *left -= 1u;
        let e = walk_next(w);
        if e.d_min > limit {
            break;
        }
        if e.id != skip {
            limit = consider(e.id, best, ray, t_max, ray_kind);
        }
    }
    return true;
}

#if SHADOWS
// Continues the any-hit walk `w` for at most about `budget` loop iterations: ANY_BLOCKED
// when some primitive other than `skip` is hit at 0 < t < t_max (with its t), ANY_CLEAR
// when the walk ended without one, ANY_UNFINISHED when the budget ran out first. Only the
// shadow rays of lights without a table (directional ones, and those `--accel auto` built
// none for) walk the BVH (BVH_SHADOWS: in scenes with such a light).
fn walk_any(w: ptr<function, Walk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> AnyHit {
#if BVH_SHADOWS
    if (*w).iend == SURFACE_WALK {
#if SURFACE_RQ
        return rq_any(ray, t_max, skip);
#else
        return bvh_any(w, ray, t_max, skip, budget);
#endif
    }
#endif
    var left = budget;
    loop {
        count_step();
        if walk_done(*w) {
            break;
        }
        if left == 0u {
            return any_answer(ANY_UNFINISHED);
        }
        left -= 1u;
        let e = walk_next(w);
        if e.d_min >= t_max {
            break;
        }
        if e.id != skip {
            let h = test_any(e.id, ray, t_max);
            if h.ok {
                return AnyHit(ANY_BLOCKED, h.t);
            }
        }
    }
    return any_answer(ANY_CLEAR);
}

// The protocol of query.wgsl for shadow rays: the walk of shadow ray `sr` towards light
// `light` from a hit on primitive `from_prim`, in the light's table when it is traced from
// the light and the light has one, else as a ray leaving the surface (`walk_from`: the BVH,
// or the fallback origin where there is none). The ray is the same either way.
fn walk_of_shadow(sr: ShadowRay, light: u32, from_prim: u32) -> Walk {
    let lo = light_table(light);
    if sr.from_light && lo != NO_ORIGIN {
        return cell_walk(lo, sr.ray.d);
    }
    return walk_from(from_prim, sr.ray.d);
}

// A shadow walk is traced at its hit when its lists hold at most `params.shadow_inline`
// entries, or, for a walk of the BVH, within `params.bvh_inline` loop iterations (a ray
// query, whole); a longer list is not walked there (0): the shadow ray becomes a job.
fn walk_inline(w: Walk) -> u32 {
    if w.iend == SURFACE_WALK {
#if SURFACE_RQ
        return UNBOUNDED;
#else
        return params.bvh_inline;
#endif
    }
    return select(UNBOUNDED, 0u, (w.iend - w.i) + (w.jend - w.j) > params.shadow_inline);
}
#endif
