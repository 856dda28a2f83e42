// Entry points: `render` advances the ray trees of one tile of grid points (pixels, or
// pixel corners with SPD sampling) by one ray each and writes each point's radiance so
// far; `aov` traces the eye ray through each pixel centre and writes depth, normal or
// object id.
#include "common.wgsl"
#include "geometry.wgsl"
#if CUBE
#include "cube.wgsl"
#else
#include "brute.wgsl"
#endif
#include "sampling.wgsl"
#if TEXTURES
#include "texture.wgsl"
#endif
#include "shade.wgsl"

const WORKGROUP: u32 = 64u;

// One step of every grid point of the tile: start the next sample (of
// sample_first..sample_end; `state.sample` counts those started) when the point's tree
// is done, trace one pending ray, and write the radiance summed so far. The host repeats
// steps until no point has work left (`points_left[0]` stays 0).
@compute @workgroup_size(64)
fn render(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let k = gid.x;
    if k < params.point_count {
        let point = params.first_point + k;
        state = states[k];
        if state.sp == 0u && params.sample_first + state.sample < params.sample_end {
            let i = point % params.grid_w;
            let j = point / params.grid_w;
            let eye = camera_ray(sample_position(i, j, params.sample_first + state.sample));
            state.stack[0] = Pending(eye.o, RAY_EYE, eye.d, 1u, vec3<f32>(1.0), 0xffffffffu);
            state.sp = 1u;
            state.sample += 1u;
        }
        if state.sp > 0u {
            trace_step();
        }
        if state.sp > 0u || params.sample_first + state.sample < params.sample_end {
            atomicAdd(&points_left[0], 1u);
        }
        states[k] = state;
        out_color[k] = vec4<f32>(state.color, 1.0);
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
        let h = closest(ray, FAR, RAY_EYE, NO_ID, NO_ID);
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
