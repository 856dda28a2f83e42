// The candidate tables (`--accel cube`) as the kernels read them: the flattened buffers and
// their structs (keep in sync with src/coherence/flat.rs), the group test
// (src/coherence/groups.rs), the cell of a direction (src/coherence/cube.rs) and the beam of
// a ray leaving a surface (src/coherence/beams/mod.rs). A ray without a table uses the
// fallback origin, whose always-test list holds every primitive (d_min 0, ascending ids):
// the same walk, so these kernels contain no separate brute-force loop.

// One direction cube; `kind` is coherence::OriginKind (eye, light, fallback).
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

// A node of the beam tree: an inner node sends a ray to child a or a + 1 by its origin
// (axis 0-2: o[axis] >= bitcast<f32>(split) goes to a + 1) or its direction's cell on a
// BEAM_CELLS-cube (axis 3: iu, 4: iv; >= split goes to a + 1), or to child a + face by its
// direction's face (axis BEAM_FACE); a leaf (axis BEAM_LEAF) lists entries[a..b].
struct GpuBeamNode {
    axis: u32,
    split: u32,
    a: u32,
    b: u32,
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
// Per primitive: 1 when the rays leaving it are classified into the beams, else 0.
@group(0) @binding(15) var<storage, read> prim_beams: array<u32>;
// Per light: its light origin (NO_ORIGIN: none).
@group(0) @binding(16) var<storage, read> light_origin: array<u32>;
// The beam tree, its root first.
@group(0) @binding(17) var<storage, read> beam_nodes: array<GpuBeamNode>;
// Primitive groups, named by entries whose id has GROUP_BIT set, and their members.
@group(0) @binding(18) var<storage, read> groups: array<GpuGroup>;
@group(0) @binding(19) var<storage, read> group_prims: array<u32>;

const NO_ORIGIN: u32 = 0xffffffffu;
const GROUP_BIT: u32 = 0x80000000u;
const BEAM_LEAF: u32 = 5u;
const BEAM_FACE: u32 = 6u;
// `Walk::iend` of a walk of the BVH (walk.wgsl; coherence::walk::BVH_WALK, keep in sync).
const BVH_WALK: u32 = 0xffffffffu;
// Cells per face edge of the cube the beams' direction splits name.
const BEAM_CELLS: u32 = 4096u;
// The deepest beam node below a root (checked on the host).
const BEAM_DEPTH: u32 = 64u;
// Relative widening of the group test (coherence::groups::GROUP_SLACK).
const GROUP_SLACK: f32 = 1e-5;

#if BEAMS
// Whether the ray may meet group `g`'s sphere at some 0 < t <= t_far: the twin of
// `coherence::groups::group_hit`, conservative for f32 rounding. Only beam lists name
// groups.
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
#endif

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

#if SURFACE_RAYS
#if BEAMS
// Whether a ray leaving a surface from `at` is classified into the beams: inside their box
// (twin of coherence::beams::in_beams).
fn in_beams(at: vec3<f32>) -> bool {
    return params.beam_nodes > 0u && all(at >= params.beam_lo) && all(at <= params.beam_hi);
}

// The [begin, end) range of `entries` listing the beam of the ray from `at` (in the beams'
// box) along `d` (not zero): the twin of coherence::beams::beam_range.
fn beam_range(at: vec3<f32>, d: vec3<f32>) -> vec2<u32> {
    let fc = cube_face_cell(d, BEAM_CELLS);
    var k = 0u;
    for (var depth = 0u; depth <= BEAM_DEPTH; depth++) {
        let n = beam_nodes[k];
        if n.axis == BEAM_LEAF {
            return vec2<u32>(n.a, n.b);
        }
        if n.axis == BEAM_FACE {
            k = n.a + fc.x;
        } else if n.axis < 3u {
            k = n.a + select(0u, 1u, at[n.axis] >= bitcast<f32>(n.split));
        } else {
            k = n.a + select(0u, 1u, fc[n.axis - 2u] >= n.split);
        }
    }
    return vec2<u32>(0u, 0u);
}
#endif
#endif
