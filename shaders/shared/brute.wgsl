// Brute force: every primitive for every ray (`--accel brute`); `brute_nearest` is the twin
// of src/kernel/closest.rs's (keep them in sync). The same queries as walk.wgsl (`closest`
// and its stepped form, `occluded_short`, `occluded_step`), which take the ray's origin
// entity although testing everything needs none. The stepped forms test WALK_CHUNK
// primitives per pass.

// Tests primitives first..end for the nearest hit with 0 < t < t_max (FAR: unbounded),
// keeping it in `best` by the table walk's rule (`consider`), so that the answer does not
// depend on the order of the tests; `skip` is never tested (NO_ID: none).
fn brute_range(ray: Ray, t_max: f32, skip: u32, ray_kind: u32, first: u32, end: u32, best: ptr<function, Closest>) {
    var best_t = select(t_max, (*best).hit.t, (*best).found);
    for (var id = first; id < end; id++) {
        count_step();
        if id != skip {
            best_t = consider(id, best, ray, t_max, ray_kind, best_t);
        }
    }
}

fn brute_nearest(ray: Ray, t_max: f32, skip: u32, ray_kind: u32) -> Closest {
    var best = no_closest();
    brute_range(ray, t_max, skip, ray_kind, 0u, params.prim_count, &best);
    return best;
}

fn closest(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Closest {
    return brute_nearest(ray, t_max, skip, ray_kind);
}

// `closest` for a job, WALK_CHUNK primitives per pass: `done` false when the test goes on
// in a later pass.
fn closest_step(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Stepped {
    var best = no_closest();
    var first = 0u;
    if walking != 0u {
        let s = walk_state;
        first = s.i;
        if s.prim != NO_ID {
            best = Closest(true, s.prim, PrimHit(true, s.t, s.b1, s.b2));
        }
    }
    let end = min(first + WALK_CHUNK, params.prim_count);
    brute_range(ray, t_max, skip, ray_kind, first, end, &best);
    if end >= params.prim_count {
        walking = 0u;
        return Stepped(true, best);
    }
    walking = 1u;
    walk_state = WalkState(end, 0u, 0u, 0u, best.prim, best.hit.t, best.hit.b1, best.hit.b2);
    return Stepped(false, best);
}

#if SHADOWS
// Tests primitives first..end for a hit before t_max; the first hit found is noted in
// `blocked_at` as its distance from the shadow ray's spawn origin (`q_t` along the ray).
fn brute_any_range(ray: Ray, t_max: f32, q_t: f32, skip: u32, first: u32, end: u32) -> bool {
    for (var id = first; id < end; id++) {
        count_step();
        if id != skip && blocks(id, ray, t_max) {
            blocked_at = abs(blocker_t - q_t);
            return true;
        }
    }
    return false;
}

// Whether light `light` is blocked from `q`, the spawn origin on primitive `from_prim` (the
// shadow ray of `shadow_ray`, geometry.wgsl, the same ray the tables walk), when it tests at
// most `params.shadow_inline` primitives; ANY_UNFINISHED, without testing, when there are
// more.
fn occluded_short(q: vec3<f32>, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32) -> u32 {
    if params.prim_count > params.shadow_inline {
        return ANY_UNFINISHED;
    }
    let sr = shadow_ray(q, to_light, light);
    if sr.empty {
        return ANY_CLEAR;
    }
    let blocked = brute_any_range(sr.ray, sr.t_max, sr.q_t, skip, 0u, params.prim_count);
    return select(ANY_CLEAR, ANY_BLOCKED, blocked);
}

// Whether light `light` is blocked from `q`, for a shadow job, WALK_CHUNK primitives per
// pass: ANY_UNFINISHED when it goes on in a later pass.
fn occluded_step(q: vec3<f32>, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32) -> u32 {
    let sr = shadow_ray(q, to_light, light);
    if sr.empty {
        walking = 0u;
        return ANY_CLEAR;
    }
    let first = select(0u, walk_state.i, walking != 0u);
    let end = min(first + WALK_CHUNK, params.prim_count);
    if brute_any_range(sr.ray, sr.t_max, sr.q_t, skip, first, end) {
        walking = 0u;
        return ANY_BLOCKED;
    }
    if end >= params.prim_count {
        walking = 0u;
        return ANY_CLEAR;
    }
    walking = 1u;
    walk_state = WalkState(end, 0u, 0u, 0u, NO_ID, 0.0, 0.0, 0.0);
    return ANY_UNFINISHED;
}
#endif
