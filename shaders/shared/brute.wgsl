// Brute force (`--accel brute`): every primitive for every ray, as query.wgsl's protocol (the
// twin of src/arith/closest.rs's `brute_nearest`: keep them in sync). A walk is the run of
// primitive ids `i..iend` still to test.

struct Walk {
    i: u32,
    iend: u32,
    j: u32,
    jend: u32,
}

// Every primitive, whatever the ray.
fn walk_of_ray(from_prim: u32, ray: Ray) -> Walk {
    return Walk(0u, params.prim_count, 0u, 0u);
}

// Tests the next primitives of walk `w`, at most `*left` of them (taken from `*left`),
// taking the hits into `best` by the tie rule (`consider`), which does not depend on the
// order of the tests; `skip` is never tested. True when the walk is over.
fn walk_nearest(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32,
    ray_kind: u32, left: ptr<function, u32>) -> bool {
    let end = (*w).i + min(*left, (*w).iend - (*w).i);
    *left -= end - (*w).i;
    for (var id = (*w).i; id < end; id++) {
        count_step();
        if id != skip {
            _ = consider(id, best, ray, t_max, ray_kind);
        }
    }
    (*w).i = end;
    return end >= (*w).iend;
}

// The number of loop iterations one pass gives a walk.
fn walk_chunk(w: Walk) -> u32 {
    return WALK_CHUNK;
}

#if SHADOWS
fn walk_of_shadow(sr: ShadowRay, light: u32, from_prim: u32) -> Walk {
    return Walk(0u, params.prim_count, 0u, 0u);
}

// Tests the next primitives of walk `w`, at most `budget` of them, for a hit before t_max.
fn walk_any(w: ptr<function, Walk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> AnyHit {
    let end = (*w).i + min(budget, (*w).iend - (*w).i);
    for (var id = (*w).i; id < end; id++) {
        count_step();
        if id != skip {
            let h = test_any(id, ray, t_max);
            if h.ok {
                (*w).i = id + 1u;
                return AnyHit(ANY_BLOCKED, h.t);
            }
        }
    }
    (*w).i = end;
    return any_answer(select(ANY_UNFINISHED, ANY_CLEAR, end >= (*w).iend));
}

// Every primitive is tested at the hit when there are at most `params.shadow_inline` of them.
fn walk_inline(w: Walk) -> u32 {
    return select(UNBOUNDED, 0u, w.iend - w.i > params.shadow_inline);
}
#endif
