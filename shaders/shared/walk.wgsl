// The table walk: line-by-line twin of src/coherence/walk.rs (keep them in sync), but for the
// BVH branches, whose CPU counterpart is the reference's own BVH (reference/tables.rs), and
// for a group entry's members, which go through the walk's own loop here (a nested loop
// there: the same tests in the same order), so that the kernels hold one copy of the
// intersection code for the table walks: lavapipe runs kernels with code inlined twice
// markedly slower. (Taking the BVH's steps in that loop too made the BVH walks slower:
// balls_s4 +11 %, rings_s7 +17 %.) A ray
// finds its list (the cell of its direction in the direction cube of the eye or the light it
// is traced from; the beam of a ray leaving a surface) and walks it merged with the origin's
// always-test list by increasing d_min, stopping once d_min passes the nearest hit so far; a
// long walk is spread over several passes. Rays leaving surfaces walk the BVH instead
// (bvh.wgsl) when the tables have no beams (`--accel cube`; `--accel beams` builds them).
// Then the queries the shading asks: `closest`, and its stepped form, and `occluded_short`
// and `occluded_step`.

#if SURFACE_RAYS
#include "shared/bvh.wgsl"
#endif

// A position in the merged walk of a cell's list (i..iend) and the always list (j..jend);
// with `iend` BVH_WALK, a walk of the BVH (bvh.wgsl: node `i`, the leaf's primitives j..jend
// left).
struct Walk {
    i: u32,
    iend: u32,
    j: u32,
    jend: u32,
}

fn walk_start(origin: u32, d: vec3<f32>) -> Walk {
    let org = origins[origin];
    let range = cube_cell_range(origin, d);
    return Walk(range.x, range.y, org.always_start, org.always_start + org.always_count);
}

// The walk of a ray leaving primitive `from_prim` (NO_ID: the eye) from `at` along `d` (not
// zero): the eye's cell; for a ray leaving a surface, the BVH (`params.surface_bvh`: the
// tables classify no such rays) or its beam; else the fallback origin (twin of
// FlatTables::start_walk, where `reference::tables` hands the BVH's rays to the reference's
// own BVH).
fn start_walk(from_prim: u32, at: vec3<f32>, d: vec3<f32>) -> Walk {
    if from_prim == NO_ID {
        let o = params.eye_origin;
        return walk_start(select(o, params.fallback_origin, o == NO_ORIGIN), d);
    }
#if SURFACE_RAYS
    if params.surface_bvh != 0u {
        return Walk(0u, BVH_WALK, 0u, 0u);
    }
#if BEAMS
    if from_prim < params.prim_count && prim_beams[from_prim] != 0u && in_beams(at) {
        let r = beam_range(at, d);
        return Walk(r.x, r.y, 0u, 0u);
    }
#endif
#endif
    return walk_start(params.fallback_origin, d);
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
// so that either kind of chunk counts as at most one (layout::budget::check_loop_budget).
fn step_budget(w: Walk) -> u32 {
    return select(WALK_CHUNK, WALK_CHUNK / 2u, w.iend == BVH_WALK);
}

// Continues the nearest-hit walk `w` for at most about `budget` loop iterations (an entry,
// or a group's members), keeping the nearest hit in `best` (ties to the lower id; `skip`
// never tested). True when the walk is over.
fn walk_nearest(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32, ray_kind: u32,
    budget: u32) -> bool {
#if SURFACE_RAYS
    if (*w).iend == BVH_WALK {
        var bw = BvhWalk((*w).i, (*w).j, (*w).jend);
        let done = bvh_nearest(&bw, best, ray, box_ray(ray), t_max, skip, ray_kind, budget);
        *w = Walk(bw.at, BVH_WALK, bw.k, bw.kend);
        return done;
    }
#endif
    var left = budget;
    var best_t = select(t_max, (*best).hit.t, (*best).found);
    // The members k..kend of the group entry being tested: they go through the same loop
    // as the entries, so that the kernel holds one copy of `consider` (lavapipe runs a
    // kernel with its code inlined twice markedly slower). Only beam lists name groups:
    // without `BEAMS` (`--accel cube`) the loop takes entries alone, and lavapipe does not
    // run the group test, taken or not, in every iteration.
    var k = 0u;
    var kend = 0u;
    loop {
        count_step();
        var id: u32;
#if BEAMS
        if k < kend {
            id = group_prims[k];
            k += 1u;
        } else {
#endif
            if walk_done(*w) {
                break;
            }
            if left == 0u {
                return false;
            }
            left -= 1u;
            let e = walk_next(w);
            if e.d_min > best_t {
                break;
            }
#if BEAMS
            if (e.id & GROUP_BIT) != 0u {
                let g = groups[e.id & ~GROUP_BIT];
                count_bound(ray_kind);
                if group_hit(g, ray, best_t) {
                    left -= min(left, g.count);
                    k = g.first;
                    kend = g.first + g.count;
                }
                continue;
            }
#endif
            id = e.id;
#if BEAMS
        }
#endif
        if id != skip {
            best_t = consider(id, best, ray, t_max, ray_kind, best_t);
        }
    }
    return true;
}

// The nearest hit with 0 < t < t_max of a ray leaving primitive `from_prim` (NO_ID: the
// eye), ties to the lower id; `skip` is never tested (NO_ID: none).
fn cube_walk_nearest(from_prim: u32, ray: Ray, t_max: f32, skip: u32, ray_kind: u32) -> Closest {
    var best = no_closest();
    if max3(abs(ray.d)) == 0.0 {
        return best;
    }
    var w = start_walk(from_prim, ray.o, ray.d);
    walk_nearest(&w, &best, ray, t_max, skip, ray_kind, UNBOUNDED);
    return best;
}

// The nearest hit of a ray leaving primitive `from_prim` (NO_ID: the eye).
fn closest(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Closest {
    return cube_walk_nearest(from_prim, ray, t_max, skip, ray_kind);
}

// `closest` for a job, in bounded passes: `done` false when the walk goes on in a later
// pass (its position kept in `walk_state`).
fn closest_step(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Stepped {
    var best = no_closest();
    var w: Walk;
    if walking == 0u {
        if max3(abs(ray.d)) == 0.0 {
            return Stepped(true, best);
        }
        w = start_walk(from_prim, ray.o, ray.d);
    } else {
        let s = walk_state;
        w = Walk(s.i, s.iend, s.j, s.jend);
        if s.prim != NO_ID {
            best = Closest(true, s.prim, PrimHit(true, s.t, s.b1, s.b2));
        }
    }
    if walk_nearest(&w, &best, ray, t_max, skip, ray_kind, step_budget(w)) {
        walking = 0u;
        return Stepped(true, best);
    }
    walking = 1u;
    walk_state = WalkState(w.i, w.iend, w.j, w.jend, best.prim, best.hit.t, best.hit.b1, best.hit.b2);
    return Stepped(false, best);
}

#if SHADOWS
// Continues the any-hit walk `w` for at most about `budget` loop iterations: ANY_BLOCKED
// when some primitive other than `skip` is hit at 0 < t < t_max, ANY_CLEAR when the walk
// ended without one, ANY_UNFINISHED when the budget ran out first.
fn walk_any(w: ptr<function, Walk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> u32 {
#if SURFACE_RAYS
    if (*w).iend == BVH_WALK {
        var bw = BvhWalk((*w).i, (*w).j, (*w).jend);
        let r = bvh_any(&bw, ray, t_max, skip, budget);
        *w = Walk(bw.at, BVH_WALK, bw.k, bw.kend);
        return r;
    }
#endif
    var left = budget;
    // A group entry's members k..kend go through the same loop (see `walk_nearest`).
    var k = 0u;
    var kend = 0u;
    loop {
        count_step();
        var id: u32;
#if BEAMS
        if k < kend {
            id = group_prims[k];
            k += 1u;
        } else {
#endif
            if walk_done(*w) {
                break;
            }
            if left == 0u {
                return ANY_UNFINISHED;
            }
            left -= 1u;
            let e = walk_next(w);
            if e.d_min >= t_max {
                break;
            }
#if BEAMS
            if (e.id & GROUP_BIT) != 0u {
                let g = groups[e.id & ~GROUP_BIT];
                count_bound(RAY_SHADOW);
                if group_hit(g, ray, t_max) {
                    left -= min(left, g.count);
                    k = g.first;
                    kend = g.first + g.count;
                }
                continue;
            }
#endif
            id = e.id;
#if BEAMS
        }
#endif
        if id != skip && blocks(id, ray, t_max) {
            return ANY_BLOCKED;
        }
    }
    return ANY_CLEAR;
}

// The walk that answers whether light `light` is blocked from `q`, the spawn origin on
// primitive `from_prim`: the one shadow ray of `shadow_ray` (geometry.wgsl), walked in the
// light's table when it is traced from the light, else as a ray leaving the surface
// (`start_walk`: the BVH, or the beam it lies in, or the fallback origin where there is
// none). `empty`: nothing to walk (and `walk` unset).
struct ShadowWalk {
    walk: Walk,
    ray: Ray,
    t_max: f32,
    empty: bool,
    q_t: f32,
}

// Notes (in `blocked_at`, layout.wgsl) where the blocker of `sw`'s walk lies when `r` is ANY_BLOCKED; returns `r`.
fn note_blocker(sw: ShadowWalk, r: u32) -> u32 {
    if r == ANY_BLOCKED {
        blocked_at = abs(blocker_t - sw.q_t);
    }
    return r;
}

fn shadow_walk(q: vec3<f32>, to_light: vec3<f32>, light: u32, from_prim: u32) -> ShadowWalk {
    let sr = shadow_ray(q, to_light, light);
    var w = Walk(0u, 0u, 0u, 0u);
    if sr.empty {
        return ShadowWalk(w, sr.ray, sr.t_max, true, sr.q_t);
    }
    if sr.from_light {
        let lo = light_table(light);
        w = walk_start(select(lo, params.fallback_origin, lo == NO_ORIGIN), sr.ray.d);
    } else {
        w = start_walk(from_prim, sr.ray.o, sr.ray.d);
    }
    return ShadowWalk(w, sr.ray, sr.t_max, false, sr.q_t);
}

// Whether light `light` is blocked from `q` (see `shadow_walk`), when its walk has at most
// `params.shadow_inline` entries (groups counted once), or for a walk of the BVH ends within
// `params.bvh_inline` loop iterations: ANY_CLEAR or ANY_BLOCKED; ANY_UNFINISHED when it is
// longer (a list without walking it).
fn occluded_short(q: vec3<f32>, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32) -> u32 {
    let sw = shadow_walk(q, to_light, light, from_prim);
    if sw.empty {
        return ANY_CLEAR;
    }
    var w = sw.walk;
    // One call of `walk_any` for both kinds of walk: the kernel holds one copy of it.
    var budget = UNBOUNDED;
    if w.iend == BVH_WALK {
        // A BVH walk that outlasts its inline budget of loop iterations becomes a job, whose
        // walk starts over.
        budget = params.bvh_inline;
    } else if (w.iend - w.i) + (w.jend - w.j) > params.shadow_inline {
        return ANY_UNFINISHED;
    }
    return note_blocker(sw, walk_any(&w, sw.ray, sw.t_max, skip, budget));
}

// Whether light `light` is blocked from `q`, for a shadow job, in bounded passes (the
// walk's position kept in `walk_state`): ANY_UNFINISHED when it goes on in a later pass.
fn occluded_step(q: vec3<f32>, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32) -> u32 {
    let sw = shadow_walk(q, to_light, light, from_prim);
    if sw.empty {
        return ANY_CLEAR;
    }
    var w = sw.walk;
    if walking != 0u {
        let s = walk_state;
        w = Walk(s.i, s.iend, s.j, s.jend);
    }
    let r = note_blocker(sw, walk_any(&w, sw.ray, sw.t_max, skip, step_budget(w)));
    walking = select(0u, 1u, r == ANY_UNFINISHED);
    walk_state = WalkState(w.i, w.iend, w.j, w.jend, NO_ID, 0.0, 0.0, 0.0);
    return r;
}
#endif
