// The hits a query takes: the nearest-hit tie rule (`Closest`, `take_hit`), and the test of
// one primitive for a nearest-hit query (`consider`) or an any-hit query (`test_any`), at
// whose hits alpha may make no hit (`alpha_passes`). Keep in sync with their Rust twins in
// src/arith/closest.rs.

// A nearest-hit answer (`closest`, query.wgsl): the winning primitive and its hit, and the
// tie rule's bookkeeping. Every hit's t comes with `err`; the *window* is the least t + err
// over the hits, and every hit with t ≤ window ties: the lowest primitive id among them
// wins, whatever the order of the tests (twin: src/arith/closest.rs, which says why). A
// walk goes on until its lower bound passes the window (`closest_limit`); `lost` says that
// a hit narrowed the window past the winner while another hit stayed in it, so that the
// query walks again from `closest_again`.
struct Closest {
    found: bool,
    prim: u32,
    hit: PrimHit,
    window: f32,
    t_min: f32,
    lost: bool,
}

fn no_closest() -> Closest {
    return Closest(false, NO_ID, no_hit(), FAR, FAR, false);
}

// The second walk of a ray whose first lost its winner: no hit yet, the final window.
fn closest_again(c: Closest) -> Closest {
    var again = no_closest();
    again.window = c.window;
    return again;
}

// How far a walk must go on: no hit beyond this can join the answer.
fn closest_limit(c: Closest, t_max: f32) -> f32 {
    return min(c.window, t_max);
}

// Takes hit `h` of primitive `id` into `best` by the tie rule; returns the new limit.
fn take_hit(id: u32, best: ptr<function, Closest>, h: PrimHit, t_max: f32) -> f32 {
    if h.ok {
        let window = min((*best).window, h.t + h.err);
        let stays = (*best).found && (*best).hit.t <= window;
        if (*best).found && !stays && (*best).t_min <= window {
            (*best).lost = true;
        }
        if h.t <= window && (!stays || id < (*best).prim) {
            (*best).found = true;
            (*best).prim = id;
            (*best).hit = h;
        }
        (*best).window = window;
        (*best).t_min = min((*best).t_min, h.t);
    }
    return closest_limit(*best, t_max);
}

// Tests primitive `id` for a nearest-hit query (table walk, BVH or brute force) and takes its
// hit into `best` by the tie rule. Returns the new limit.
fn consider(id: u32, best: ptr<function, Closest>, ray: Ray, t_max: f32, ray_kind: u32) -> f32 {
    let p = prim_at(id);
    count_test(ray_kind, p.kind);
    var h = intersect_prim(p, ray, t_max);
#if ALPHA
    h.ok = h.ok && alpha_passes(p, h, false);
#endif
    return take_hit(id, best, h, t_max);
}

#if CUTOUTS
// The alpha of material `m` at a point with texture coordinates `u`: its opacity times the
// base colour texture's alpha (twin: reference::texture `alpha`).
fn hit_alpha(m: Material, u: UvSets) -> f32 {
    var a = m.opacity;
#if TEXTURES
    a *= read_texture(m.base, u.uv0, u.has0, u.uv1, u.has1, vec4<f32>(1.0)).w;
#endif
    return a;
}

// Whether hit `h` on primitive `p` counts for a nearest (`shadow` false) or shadow query:
// on a masked material (FLAG_CUTOUT), or a blended one for a shadow ray
// (FLAG_CUTOUT_SHADOW), a hit whose alpha is below the cutoff is no hit, and the walk goes
// on (twin: reference::accel `Hittable::hit`).
fn alpha_passes(p: Prim, h: PrimHit, shadow: bool) -> bool {
    let flag = select(FLAG_CUTOUT, FLAG_CUTOUT_SHADOW, shadow);
    if (p.flags & flag) == 0u || p.kind != KIND_TRIANGLE {
        return true;
    }
    let m = materials[p.material];
    return hit_alpha(m, uv_sets(p, h.b1, h.b2)) >= select(m.alpha_cutoff, m.shadow_cutoff, shadow);
}
#endif

#if SHADOWS
// Tests primitive `id` for an any-hit query (a shadow ray): a hit at 0 < t < t_max, if any.
// The any-hit twin of `consider`.
fn test_any(id: u32, ray: Ray, t_max: f32) -> PrimHit {
    let p = prim_at(id);
    count_test(RAY_SHADOW, p.kind);
    var h = intersect_prim(p, ray, t_max);
#if CUTOUTS
    h.ok = h.ok && alpha_passes(p, h, true);
#endif
    return h;
}
#endif
