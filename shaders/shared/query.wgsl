// The ray queries every tracing kernel asks, written once over the walk of the variant's one
// accelerator (trace.wgsl includes exactly one: the candidate tables' walk.wgsl, the BVH's
// bvh.wgsl or brute.wgsl). A walk's state is passed explicitly: what a query needs from an
// earlier pass comes in its arguments, what a later pass needs goes out in its answer.
//
// An accelerator supplies the protocol below, and nothing else is asked of it:
//   struct Walk { i, iend, j, jend }  where a walk stands (saved between passes in a job's
//                                     WalkState: the accelerator decides what the words mean)
//   fn walk_of_ray(from_prim, ray) -> Walk
//                                     the walk of a nearest-hit query of a ray leaving
//                                     primitive `from_prim` (NO_ID: the eye)
//   fn walk_of_shadow(sr, light, from_prim) -> Walk
//                                     the walk of shadow ray `sr` (geometry.wgsl)
//   fn walk_nearest(w, best, ray, t_max, skip, ray_kind, left) -> bool
//                                     goes on for at most `*left` loop iterations (taken
//                                     from `*left`), taking the hits into `best` by the tie
//                                     rule (`consider`) and stopping where no hit can join
//                                     it (`closest_limit`); true when over
//   fn walk_any(w, ray, t_max, skip, budget) -> AnyHit
//                                     the any-hit twin: ANY_BLOCKED (with the blocker's t),
//                                     ANY_CLEAR, or ANY_UNFINISHED when the budget ran out
//   fn walk_chunk(w) -> u32           the loop iterations one pass gives walk `w`
//   fn walk_inline(w) -> u32          the budget of a shadow walk traced at its hit; 0 when
//                                     it is too long (it becomes a job of the shadow queue)

// An any-hit walk's answer: ANY_CLEAR, ANY_BLOCKED or ANY_UNFINISHED, and with ANY_BLOCKED
// the t of the blocker that answered it.
struct AnyHit {
    answer: u32,
    t: f32,
}

fn any_answer(answer: u32) -> AnyHit {
    return AnyHit(answer, 0.0);
}

// A walk's state as a job keeps it: the walk, and for a nearest-hit walk the winner so far
// (prim NO_ID: none) and the tie rule's window and least t. Whether the winner was lost is
// the job's `walking` (WALK_RESUME_LOST).
fn save_walk(w: Walk, best: Closest) -> WalkState {
    return WalkState(w.i, w.iend, w.j, w.jend, best.prim, best.hit.t, best.hit.b1, best.hit.b2, best.window,
        best.t_min);
}

fn restored_walk(s: WalkState) -> Walk {
    return Walk(s.i, s.iend, s.j, s.jend);
}

// The answer so far of a walk saved as `s` by a job whose `walking` is `walking`.
fn restored_closest(s: WalkState, walking: u32) -> Closest {
    var c = no_closest();
    if s.prim != NO_ID {
        c.found = true;
        c.prim = s.prim;
        c.hit = PrimHit(true, s.t, s.b1, s.b2, 0.0);
    }
    c.window = s.window;
    c.t_min = s.t_min;
    c.lost = walking == WALK_RESUME_LOST;
    return c;
}

// Walks on from `w` with the loop iterations `*left`; where the walk ends with its winner
// lost, walks the ray again from its start within the final window, with what is left. The
// second walk is the first's loop again, not a second copy of it: lavapipe (Mesa 22.3) runs
// a copy's code for every invocation, even where no invocation needs it, and a loop's second
// round only where one does.
fn walk_nearest_to_the_end(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32,
    ray_kind: u32, from_prim: u32, skip: u32, left: ptr<function, u32>) -> bool {
    loop {
        if !walk_nearest(w, best, ray, t_max, skip, ray_kind, left) {
            return false;
        }
        if !(*best).lost {
            break;
        }
        *best = closest_again(*best);
        *w = walk_of_ray(from_prim, ray);
    }
    return true;
}

// The nearest hit with 0 < t < t_max of a ray leaving primitive `from_prim` (NO_ID: the
// eye) by the tie rule (`consider`); `skip` is never tested (NO_ID: none). A zero
// direction hits nothing.
fn closest(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Closest {
    var best = no_closest();
    if max3(abs(ray.d)) == 0.0 {
        return best;
    }
    var w = walk_of_ray(from_prim, ray);
    var left = UNBOUNDED;
    walk_nearest_to_the_end(&w, &best, ray, t_max, ray_kind, from_prim, skip, &left);
    return best;
}

// `closest` in bounded passes, for a job: `walking` WALK_START starts the walk,
// WALK_RESUME or WALK_RESUME_LOST resume it from `state` (where the last pass left it);
// `done` false when it goes on in a later pass, from the answer's `state` (and with
// WALK_RESUME_LOST where the answer's `c.lost`).
struct Stepped {
    done: bool,
    c: Closest,
    state: WalkState,
}

fn closest_step(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32, walking: u32, state: WalkState)
    -> Stepped {
    var best = no_closest();
    var w: Walk;
    if walking == WALK_START {
        if max3(abs(ray.d)) == 0.0 {
            return Stepped(true, best, state);
        }
        w = walk_of_ray(from_prim, ray);
    } else {
        w = restored_walk(state);
        best = restored_closest(state, walking);
    }
    var left = walk_chunk(w);
    let done = walk_nearest_to_the_end(&w, &best, ray, t_max, ray_kind, from_prim, skip, &left);
    return Stepped(done, best, save_walk(w, best));
}

#if SHADOWS
// Whether a light is blocked from a hit: `answer` ANY_CLEAR, ANY_BLOCKED or ANY_UNFINISHED
// (the walk goes on in a later pass, from `state`); with ANY_BLOCKED, how far from the
// shadow ray's spawn origin its blocker lies (the self-hit count, shade.wgsl).
struct Occlusion {
    answer: u32,
    blocked_at: f32,
    state: WalkState,
}

// `any`'s answer for shadow ray `sr`, its walk left at `w`.
fn occlusion(sr: ShadowRay, any: AnyHit, w: Walk) -> Occlusion {
    let at = select(0.0, abs(any.t - sr.q_t), any.answer == ANY_BLOCKED);
    return Occlusion(any.answer, at, save_walk(w, no_closest()));
}

// Whether light `light` is blocked from `q`, the spawn origin of a hit on primitive
// `from_prim` (the one shadow ray of `shadow_ray`, geometry.wgsl, whatever the accelerator),
// when its walk is short enough to trace at the hit (`walk_inline`); ANY_UNFINISHED,
// without walking on, when it is not: the shadow ray becomes a job.
fn occluded_short(q: vec3r, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32) -> Occlusion {
    let sr = shadow_ray(q, to_light, light);
    var w = Walk(0u, 0u, 0u, 0u);
    if sr.empty {
        return occlusion(sr, any_answer(ANY_CLEAR), w);
    }
    w = walk_of_shadow(sr, light, from_prim);
    return occlusion(sr, walk_any(&w, sr.ray, sr.t_max, skip, walk_inline(w)), w);
}

// Whether light `light` is blocked from `q`, for a shadow job, in bounded passes: `walking`
// 0 starts the walk, 1 resumes it from `state`.
fn occluded_step(q: vec3r, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32, walking: u32,
    state: WalkState) -> Occlusion {
    let sr = shadow_ray(q, to_light, light);
    var w = Walk(0u, 0u, 0u, 0u);
    if sr.empty {
        return occlusion(sr, any_answer(ANY_CLEAR), w);
    }
    if walking == 0u {
        w = walk_of_shadow(sr, light, from_prim);
    } else {
        w = restored_walk(state);
    }
    return occlusion(sr, walk_any(&w, sr.ray, sr.t_max, skip, walk_chunk(w)), w);
}
#endif
