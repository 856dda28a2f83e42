// Brute force: every primitive for every ray (`--accel brute`); twin of the CPU's Brute.

struct Closest {
    found: bool,
    prim: u32,
    hit: PrimHit,
}

// The nearest hit with 0 < t < t_max (FAR: unbounded), ties to the lower id.
fn closest(ray: Ray, t_max: f32, ray_kind: u32) -> Closest {
    var best: Closest;
    best.found = false;
    best.prim = 0u;
    best.hit = no_hit();
    var limit = t_max;
    for (var id = 0u; id < params.prim_count; id++) {
        let p = prims[id];
        count_test(ray_kind, p.kind);
        let h = intersect_prim(p, ray, limit);
        // Ascending ids with a strict limit: a tie stays with the lower id.
        if h.ok {
            best.found = true;
            best.prim = id;
            best.hit = h;
            limit = h.t;
        }
    }
    return best;
}

#if SHADOWS
// True when some primitive blocks the shadow ray before t_max.
fn occluded(ray: Ray, t_max: f32) -> bool {
    for (var id = 0u; id < params.prim_count; id++) {
        let p = prims[id];
        count_test(RAY_SHADOW, p.kind);
        if intersect_prim(p, ray, t_max).ok {
            return true;
        }
    }
    return false;
}
#endif
