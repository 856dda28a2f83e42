// The direction-cube candidate tables (`--accel cube`): line-by-line twins of
// `cube_face_cell`, `cube_cell_range`, `cube_walk_nearest` and `cube_walk_any` in
// src/mirror/mod.rs, over the flattened buffers of src/coherence/flat.rs. A ray looks up
// the table of its origin entity (the eye, the light it is traced from, the primitive it
// leaves), finds the cell of its direction, and walks the cell's list merged with the
// origin's always-test list by increasing d_min, stopping once d_min passes the nearest
// hit so far. A ray whose origin has no table uses the host's fallback origin, whose
// always-test list holds every primitive (d_min 0, ascending ids): the same walk, so these
// kernels contain no separate brute-force loop.

// One origin entity; kind 0 eye, 1 light, 2 surface cluster, 3 the fallback (all primitives).
struct GpuOrigin {
    n: u32,
    always_start: u32,
    always_count: u32,
    kind: u32,
}

// The stored window of one cube face: cells iu0..iu0+width × iv0..iv0+height, row by row
// from cell_base.
struct GpuFace {
    iu0: u32,
    iv0: u32,
    width: u32,
    height: u32,
    cell_base: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// A candidate: primitive id and a lower bound of its hit distance along a unit direction.
struct GpuEntry {
    id: u32,
    d_min: f32,
}

// A group of primitives (coherence::groups): its camera-relative bounding sphere, widened
// for rounding, and its members group_prims[first .. first + count].
struct GpuGroup {
    cx: f32,
    cy: f32,
    cz: f32,
    radius: f32,
    first: u32,
    count: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(11) var<storage, read> origins: array<GpuOrigin>;
@group(0) @binding(12) var<storage, read> faces: array<GpuFace>;
@group(0) @binding(13) var<storage, read> cell_start: array<u32>;
@group(0) @binding(14) var<storage, read> entries: array<GpuEntry>;
// Per primitive: its surface origin; per light: its light origin (NO_ORIGIN: none).
@group(0) @binding(15) var<storage, read> prim_origin: array<u32>;
@group(0) @binding(16) var<storage, read> light_origin: array<u32>;
// Per primitive: m, its m×m surface patches (1: one origin for the whole primitive).
@group(0) @binding(17) var<storage, read> prim_patches: array<u32>;
// Primitive groups, named by entries whose id has GROUP_BIT set, and their members.
@group(0) @binding(18) var<storage, read> groups: array<GpuGroup>;
@group(0) @binding(19) var<storage, read> group_prims: array<u32>;

const NO_ORIGIN: u32 = 0xffffffffu;
const GROUP_BIT: u32 = 0x80000000u;
// Relative widening of the group test (coherence::groups::GROUP_SLACK).
const GROUP_SLACK: f32 = 1e-5;

// Whether the ray may meet group `g`'s sphere at some 0 < t <= t_far: the twin of
// `coherence::groups::group_hit`, conservative for f32 rounding.
fn group_hit(g: GpuGroup, ray: Ray, t_far: f32) -> bool {
    let oc = vec3<f32>(g.cx, g.cy, g.cz) - ray.o;
    let tc = dot(oc, ray.d);
    let rr = g.radius + GROUP_SLACK * (abs(tc) + g.radius + max3(abs(ray.o)));
    if tc + rr < 0.0 || tc - rr > t_far {
        return false;
    }
    let v = oc - tc * ray.d;
    return dot(v, v) <= rr * rr;
}

// Origin keys (coherence::OriginKey).
const KEY_EYE: u32 = 0u;
const KEY_LIGHT: u32 = 1u;
const KEY_SURFACE: u32 = 2u;

// The surface patch of triangle (p0, p1, p2), split into an m×m barycentric grid, holding
// the ray origin `at`: the twin of `triangle_patch`.
fn triangle_patch(p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, m: u32, at: vec3<f32>) -> u32 {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let w = at - p0;
    let d11 = dot(e1, e1);
    let d12 = dot(e1, e2);
    let d22 = dot(e2, e2);
    let w1 = dot(w, e1);
    let w2 = dot(w, e2);
    let den = d11 * d22 - d12 * d12;
    let b1 = (d22 * w1 - d12 * w2) / den;
    let b2 = (d11 * w2 - d12 * w1) / den;
    let last = f32(m - 1u);
    let i = u32(min(max(floor(b1 * f32(m)), 0.0), last));
    let j = u32(min(max(floor(b2 * f32(m)), 0.0), last));
    return min(j, m - 1u - i) * m + i;
}

// The table a ray from `key` (with light or primitive `index`, starting at `at`) uses: the
// twin of `FlatTables::origin`, then the fallback origin where that has none.
fn cube_origin(key: u32, index: u32, at: vec3<f32>) -> u32 {
    var o = NO_ORIGIN;
    switch key {
        case KEY_EYE: {
            o = params.eye_origin;
        }
        case KEY_LIGHT: {
            if index < params.light_count {
                o = light_origin[index];
            }
        }
        default: {
            if index < params.prim_count {
                o = prim_origin[index];
                let m = prim_patches[index];
                if o != NO_ORIGIN && m > 1u {
                    let p = prims[index];
                    o += triangle_patch(p.a.xyz, p.b.xyz, p.c.xyz, m, at);
                }
            }
        }
    }
    return select(o, params.fallback_origin, o == NO_ORIGIN);
}

// Face and cell of direction `d` (not zero) on a cube of n×n cells per face:
// (face, iu, iv), the major axis taking ties in the order x, y, z.
fn cube_face_cell(d: vec3<f32>, n: u32) -> vec3<u32> {
    let a = abs(d);
    var ax = 0u;
    var m = a.x;
    if a.y > m {
        ax = 1u;
        m = a.y;
    }
    if a.z > m {
        ax = 2u;
        m = a.z;
    }
    let major = d[ax];
    let face = 2u * ax + select(0u, 1u, major < 0.0);
    let u = d[(ax + 1u) % 3u] / m;
    let v = d[(ax + 2u) % 3u] / m;
    let nf = f32(n);
    let iu = u32(clamp(floor((u + 1.0) * 0.5 * nf), 0.0, nf - 1.0));
    let iv = u32(clamp(floor((v + 1.0) * 0.5 * nf), 0.0, nf - 1.0));
    return vec3<u32>(face, iu, iv);
}

// The [begin, end) range of `entries` listing the cell of direction `d` of `origin`;
// empty outside the face's stored window.
fn cube_cell_range(origin: u32, d: vec3<f32>) -> vec2<u32> {
    let org = origins[origin];
    let fc = cube_face_cell(d, org.n);
    let w = faces[origin * 6u + fc.x];
    // u32 subtraction wraps, so a cell left of or below the window fails the test too.
    let lu = fc.y - w.iu0;
    let lv = fc.z - w.iv0;
    if lu >= w.width || lv >= w.height {
        return vec2<u32>(0u, 0u);
    }
    let c = w.cell_base + lv * w.width + lu;
    return vec2<u32>(cell_start[c], cell_start[c + 1u]);
}

// A position in the merged walk of a cell's list (i..iend) and the always list (j..jend).
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

// Continues the nearest-hit walk `w` for at most about `budget` loop iterations (an entry,
// or a group's members), keeping the nearest hit in `best` (ties to the lower id; `skip`
// never tested). True when the walk is over.
fn walk_nearest(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32, ray_kind: u32,
    budget: u32) -> bool {
    var left = budget;
    var best_t = select(t_max, (*best).hit.t, (*best).found);
    loop {
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
        if (e.id & GROUP_BIT) != 0u {
            let g = groups[e.id & ~GROUP_BIT];
            count_bound(ray_kind);
            if group_hit(g, ray, best_t) {
                left -= min(left, g.count);
                for (var k = g.first; k < g.first + g.count; k++) {
                    let m = group_prims[k];
                    if m != skip {
                        best_t = consider(m, best, ray, t_max, ray_kind, best_t);
                    }
                }
            }
            continue;
        }
        if e.id == skip {
            continue;
        }
        best_t = consider(e.id, best, ray, t_max, ray_kind, best_t);
    }
    return true;
}

// The nearest hit with 0 < t < t_max from the table of `origin`, ties to the lower id;
// `skip` is never tested (NO_ID: none).
fn cube_walk_nearest(origin: u32, ray: Ray, t_max: f32, skip: u32, ray_kind: u32) -> Closest {
    var best = no_closest();
    if max3(abs(ray.d)) == 0.0 {
        return best;
    }
    var w = walk_start(origin, ray.d);
    walk_nearest(&w, &best, ray, t_max, skip, ray_kind, 0xffffffffu);
    return best;
}

// The nearest hit of a ray leaving primitive `from_prim` (NO_ID: the eye).
fn closest(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Closest {
    let key = select(KEY_SURFACE, KEY_EYE, from_prim == NO_ID);
    return cube_walk_nearest(cube_origin(key, from_prim, ray.o), ray, t_max, skip, ray_kind);
}

// `closest` for the ray on top of the point's stack, in bounded steps: `done` false when
// the walk goes on in the next step.
fn closest_step(ray: Ray, t_max: f32, ray_kind: u32, from_prim: u32, skip: u32) -> Stepped {
    var best = no_closest();
    var w: Walk;
    if state.walking == 0u {
        if max3(abs(ray.d)) == 0.0 {
            return Stepped(true, best);
        }
        let key = select(KEY_SURFACE, KEY_EYE, from_prim == NO_ID);
        w = walk_start(cube_origin(key, from_prim, ray.o), ray.d);
    } else {
        let s = state.walk;
        w = Walk(s.i, s.iend, s.j, s.jend);
        if s.prim != NO_ID {
            best = Closest(true, s.prim, PrimHit(true, s.t, s.b1, s.b2));
        }
    }
    if walk_nearest(&w, &best, ray, t_max, skip, ray_kind, WALK_CHUNK) {
        state.walking = 0u;
        return Stepped(true, best);
    }
    state.walking = 1u;
    state.walk = WalkState(w.i, w.iend, w.j, w.jend, best.prim, best.hit.t, best.hit.b1, best.hit.b2);
    return Stepped(false, best);
}

#if SHADOWS
// Continues the any-hit walk `w` for at most about `budget` loop iterations: ANY_BLOCKED
// when some primitive other than `skip` is hit at 0 < t < t_max, ANY_CLEAR when the walk
// ended without one, ANY_UNFINISHED when the budget ran out first.
fn walk_any(w: ptr<function, Walk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> u32 {
    var left = budget;
    loop {
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
        if (e.id & GROUP_BIT) != 0u {
            let g = groups[e.id & ~GROUP_BIT];
            count_bound(RAY_SHADOW);
            if group_hit(g, ray, t_max) {
                left -= min(left, g.count);
                for (var k = g.first; k < g.first + g.count; k++) {
                    let m = group_prims[k];
                    if m != skip {
                        let p = prims[m];
                        count_test(RAY_SHADOW, p.kind);
                        if intersect_prim(p, ray, t_max).ok {
                            return ANY_BLOCKED;
                        }
                    }
                }
            }
            continue;
        }
        if e.id == skip {
            continue;
        }
        let p = prims[e.id];
        count_test(RAY_SHADOW, p.kind);
        if intersect_prim(p, ray, t_max).ok {
            return ANY_BLOCKED;
        }
    }
    return ANY_CLEAR;
}

// True when some primitive other than `skip` is hit at 0 < t < t_max.
fn cube_walk_any(origin: u32, ray: Ray, t_max: f32, skip: u32) -> bool {
    if max3(abs(ray.d)) == 0.0 {
        return false;
    }
    var w = walk_start(origin, ray.d);
    return walk_any(&w, ray, t_max, skip, 0xffffffffu) == ANY_BLOCKED;
}

// The walk that answers whether light `light` is blocked from `q`, the spawn origin on
// primitive `from_prim` (direction `to_light`, `t_max` before a positional light). A light
// with a table traces the ray light-buffer style, from the light towards `q`; otherwise
// the ray leaves `q` with the table of `from_prim`. `empty`: nothing to walk.
struct ShadowWalk {
    origin: u32,
    ray: Ray,
    t_max: f32,
    empty: bool,
}

fn shadow_walk(q: vec3<f32>, to_light: vec3<f32>, t_max: f32, light: u32, from_prim: u32) -> ShadowWalk {
    let lo = cube_origin(KEY_LIGHT, light, q);
    if lo != params.fallback_origin {
        let l = lights[light].position;
        let v = q - l;
        let dist = length(v);
        if !(dist > 0.0) {
            return ShadowWalk(lo, make_ray(l, to_light), 0.0, true);
        }
        let ray = make_ray(l, v);
        return ShadowWalk(lo, ray, dist * (1.0 - SHADOW_END_REL), max3(abs(ray.d)) == 0.0);
    }
    let ray = make_ray(q, to_light);
    return ShadowWalk(cube_origin(KEY_SURFACE, from_prim, q), ray, t_max, max3(abs(ray.d)) == 0.0);
}

// `occluded` when its walk has at most `params.shadow_inline` entries (groups counted
// once): ANY_CLEAR or ANY_BLOCKED; ANY_UNFINISHED, without walking, when it is longer.
fn occluded_short(q: vec3<f32>, to_light: vec3<f32>, t_max: f32, light: u32, from_prim: u32, skip: u32) -> u32 {
    let sw = shadow_walk(q, to_light, t_max, light, from_prim);
    if sw.empty {
        return ANY_CLEAR;
    }
    var w = walk_start(sw.origin, sw.ray.d);
    if (w.iend - w.i) + (w.jend - w.j) > params.shadow_inline {
        return ANY_UNFINISHED;
    }
    return walk_any(&w, sw.ray, sw.t_max, skip, 0xffffffffu);
}

// Whether light `light` is blocked from `q` (see `shadow_walk`), in one go.
fn occluded(q: vec3<f32>, to_light: vec3<f32>, t_max: f32, light: u32, from_prim: u32, skip: u32) -> bool {
    let sw = shadow_walk(q, to_light, t_max, light, from_prim);
    if sw.empty {
        return false;
    }
    return cube_walk_any(sw.origin, sw.ray, sw.t_max, skip);
}

// `occluded` for the shadow job on top of the point's stack, in bounded steps (the walk's
// position kept in `state.walk`): ANY_UNFINISHED when it goes on in the next step.
fn occluded_step(q: vec3<f32>, to_light: vec3<f32>, t_max: f32, light: u32, from_prim: u32, skip: u32) -> u32 {
    let sw = shadow_walk(q, to_light, t_max, light, from_prim);
    if sw.empty {
        return ANY_CLEAR;
    }
    var w: Walk;
    if state.walking == 0u {
        w = walk_start(sw.origin, sw.ray.d);
    } else {
        let s = state.walk;
        w = Walk(s.i, s.iend, s.j, s.jend);
    }
    let r = walk_any(&w, sw.ray, sw.t_max, skip, WALK_CHUNK);
    state.walking = select(0u, 1u, r == ANY_UNFINISHED);
    state.walk = WalkState(w.i, w.iend, w.j, w.jend, NO_ID, 0.0, 0.0, 0.0);
    return r;
}
#endif
