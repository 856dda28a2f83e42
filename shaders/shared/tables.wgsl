// The direction-cube candidate tables (`--accel cube`) as the kernels read them: the
// flattened buffers and their structs (keep in sync with src/coherence/flat.rs), the group
// test (src/coherence/groups.rs), the surface patch lookup (src/coherence/patches.rs), the
// origin a ray's table belongs to and the cell of its direction (src/coherence/walk.rs and
// cube.rs). A ray whose origin has no table uses the fallback origin, whose always-test list
// holds every primitive (d_min 0, ascending ids): the same walk, so these kernels contain no
// separate brute-force loop.

// One origin entity; `kind` is coherence::OriginKind (eye, light, surface, fallback).
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

// The table a ray leaving primitive `from_prim` (NO_ID: the eye) from `at` walks: its
// origin's (OriginKey::Surface or OriginKey::Eye), or the fallback origin where there is
// none. Together with `light_table`, the twin of `FlatTables::cube_origin`.
fn cube_origin(from_prim: u32, at: vec3<f32>) -> u32 {
    var o = NO_ORIGIN;
    if from_prim == NO_ID {
        o = params.eye_origin;
    } else if from_prim < params.prim_count {
        o = prim_origin[from_prim];
        let m = prim_patches[from_prim];
        if o != NO_ORIGIN && m > 1u {
            let p = prims[from_prim];
            o += triangle_patch(p.a.xyz, p.b.xyz, p.c.xyz, m, at);
        }
    }
    return select(o, params.fallback_origin, o == NO_ORIGIN);
}

// The table of light `light`'s shadow rays (OriginKey::Light), or NO_ORIGIN.
fn light_table(light: u32) -> u32 {
    if light < params.light_count {
        return light_origin[light];
    }
    return NO_ORIGIN;
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
