// Entry points: `render` traces the ray trees of one tile of grid points (pixels, or
// pixel corners with SPD sampling) and writes each point's summed radiance; `aov` traces
// the eye ray through each pixel centre and writes depth, normal or object id.
#include "common.wgsl"
#include "geometry.wgsl"
#include "brute.wgsl"
#include "sampling.wgsl"
#if TEXTURES
#include "texture.wgsl"
#endif
#include "shade.wgsl"

const WORKGROUP: u32 = 64u;

@compute @workgroup_size(64)
fn render(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let k = gid.x;
    if k < params.point_count {
        let point = params.first_point + k;
        let i = point % params.grid_w;
        let j = point / params.grid_w;
        var sum = vec3<f32>(0.0);
        for (var s = 0u; s < params.spp; s++) {
            sum += trace_tree(camera_ray(sample_position(i, j, s)));
        }
        out_color[k] = vec4<f32>(sum, 1.0);
    }
    flush_counters(lid);
}

@compute @workgroup_size(64)
fn aov(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let k = gid.x;
    if k < params.point_count {
        let point = params.first_point + k;
        let i = point % params.grid_w;
        let j = point / params.grid_w;
        let ray = camera_ray(vec2<f32>(f32(i) + 0.5, f32(j) + 0.5));
        count(RAY_EYE);
        let h = closest(ray, FAR, RAY_EYE);
        var v = vec4<f32>(0.0);
        if h.found {
            count(C_EYE_HIT);
            let prim = prims[h.prim];
            let s = surface(prim, ray, h.hit);
            switch params.aov {
                case 0u: {
                    v = vec4<f32>(vec3<f32>(h.hit.t), 1.0);
                }
                case 1u: {
                    v = vec4<f32>(select(-s.ns, s.ns, dot(ray.d, s.ng) < 0.0), 1.0);
                }
                default: {
                    v = vec4<f32>(vec3<f32>(f32(h.prim)), 1.0);
                }
            }
        } else if params.aov == 2u {
            v = vec4<f32>(-1.0, -1.0, -1.0, 0.0);
        }
        out_color[k] = v;
    }
    flush_counters(lid);
}
