// The `resolve` kernel: each tile point's radiance, summed in 64-bit fixed point in `accum`
// (add_radiance, wavefront.wgsl), as the f32 colour the host and the preview read.
#include "shared/layout.wgsl"
#include "shared/wavefront.wgsl"

// Channel `c` of point `k`'s sum: the high word (signed whole units) plus the low word's two
// halves, each exact in f32, so that only the last addition rounds.
fn resolved(k: u32, c: u32) -> f32 {
    let lo = atomicLoad(&accum[6u * k + 2u * c]);
    let hi = bitcast<i32>(atomicLoad(&accum[6u * k + 2u * c + 1u]));
    let frac = f32(lo >> 16u) * (1.0 / 65536.0) + f32(lo & 0xffffu) * (1.0 / ACCUM_ONE);
    return f32(hi) + frac;
}

@compute @workgroup_size(WORKGROUP)
fn resolve(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if k < params.point_count {
        out_color[k] = vec4<f32>(resolved(k, 0u), resolved(k, 1u), resolved(k, 2u), 1.0);
    }
}
