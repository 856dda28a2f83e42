// Brute force: every primitive for every ray (`--accel brute`); twin of
// `crate::mirror::brute_nearest`. Same entry points as cube.wgsl (`closest`, `occluded`),
// which take the ray's origin entity although testing everything needs none.

// The nearest hit with 0 < t < t_max (FAR: unbounded), ties to the lower id; `skip` is
// never tested (NO_ID: none).
fn brute_nearest(ray: Ray, t_max: f32, skip: u32, ray_kind: u32) -> Closest {
    var best: Closest;
    best.found = false;
    best.prim = NO_ID;
    best.hit = no_hit();
    var best_t = t_max;
    for (var id = 0u; id < params.prim_count; id++) {
        if id == skip {
            continue;
        }
        let p = prims[id];
        count_test(ray_kind, p.kind);
        // Every test against t_max and the same rule as the table walk, so that the answer
        // does not depend on the order of the tests.
        let h = intersect_prim(p, ray, t_max);
        if h.ok && (h.t < best_t || (h.t == best_t && best.found && id < best.prim)) {
            best.found = true;
            best.prim = id;
            best.hit = h;
            best_t = h.t;
        }
    }
    return best;
}

fn closest(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Closest {
    return brute_nearest(ray, t_max, skip, ray_kind);
}

// `closest` for the ray on top of the point's stack: brute force ends in one step.
fn closest_step(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Stepped {
    return Stepped(true, closest(ray, t_max, ray_kind, from_prim, skip));
}

#if SHADOWS
// True when some primitive other than `skip` blocks the ray before t_max.
fn brute_any(ray: Ray, t_max: f32, skip: u32) -> bool {
    for (var id = 0u; id < params.prim_count; id++) {
        if id == skip {
            continue;
        }
        let p = prims[id];
        count_test(RAY_SHADOW, p.kind);
        if intersect_prim(p, ray, t_max).ok {
            return true;
        }
    }
    return false;
}

// Whether light `light` is blocked from `q`, the spawn origin on primitive `from_prim`:
// the ray from `q` towards the light, up to `t_max`.
fn occluded(q: vec3<f32>, to_light: vec3<f32>, t_max: f32, light: u32, from_prim: u32, skip: u32) -> bool {
    return brute_any(make_ray(q, to_light), t_max, skip);
}
#endif
