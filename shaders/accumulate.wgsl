// The preview's `accumulate` kernel (src/preview/session/accumulate.rs): adds one finished
// tile of the wavefront kernels' output (`resolve`) to the whole-image accumulation.

// Which points of the image the tile holds. Keep in sync with `Tile` in
// src/preview/session/accumulate.rs.
struct Tile {
    first_point: u32,
    point_count: u32,
    pad0: u32,
    pad1: u32,
}

// A storage buffer, not a uniform, for the reason `params` is one (shared/layout.wgsl).
@group(0) @binding(0) var<storage, read> tile: Tile;
@group(0) @binding(1) var<storage, read> tile_out: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> accum: array<vec4<f32>>;

const ACCUMULATE_WORKGROUP: u32 = 64u;

@compute @workgroup_size(ACCUMULATE_WORKGROUP)
fn accumulate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if k < tile.point_count {
        let p = tile.first_point + k;
        accum[p] = vec4<f32>(accum[p].xyz + tile_out[k].xyz, 1.0);
    }
}
