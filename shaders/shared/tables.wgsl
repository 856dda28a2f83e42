// The candidate tables (`--accel cube`) as the kernels read them: the flattened buffers and
// their structs (keep in sync with src/coherence/flat.rs) and the cell of a direction
// (src/coherence/cube.rs). A ray without a table uses the fallback origin, whose always-test
// list holds every primitive (d_min 0, ascending ids): the same walk, so these kernels
// contain no separate brute-force loop.

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

@group(0) @binding(11) var<storage, read> origins: array<GpuOrigin>;
@group(0) @binding(12) var<storage, read> faces: array<GpuFace>;
@group(0) @binding(13) var<storage, read> cell_start: array<u32>;
@group(0) @binding(14) var<storage, read> entries: array<GpuEntry>;
// Per light: its light origin (NO_ORIGIN: none).
@group(0) @binding(15) var<storage, read> light_origin: array<u32>;

const NO_ORIGIN: u32 = 0xffffffffu;
// `Walk::iend` of the walk of a ray leaving a surface, the BVH's or a ray query's (walk.wgsl;
// coherence::walk::SURFACE_WALK, keep in sync).
const SURFACE_WALK: u32 = 0xffffffffu;


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
