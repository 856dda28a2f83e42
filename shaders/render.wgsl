// The `render` kernel: advances the ray trees of one tile of grid points (pixels, or pixel
// corners with SPD sampling) by one ray each and writes each point's radiance so far. The
// host (src/gpu/schedule.rs) repeats steps until no point has work left.
#include "shared/layout.wgsl"
#include "shared/geometry.wgsl"
#if TABLES
#include "shared/tables.wgsl"
#include "shared/walk.wgsl"
#endif
#if BVH
#include "shared/bvh.wgsl"
#endif
#if BRUTE
#include "shared/brute.wgsl"
#endif
#include "shared/sampling.wgsl"
#if TEXTURES
#include "shared/texture.wgsl"
#endif
#include "shared/shade.wgsl"

// One step of every grid point of the tile: start the next sample (of
// sample_first..sample_end; `state.sample` counts those started) when the point's tree
// is done, trace one pending ray, and write the radiance summed so far. The host repeats
// steps until no point has work left (`points_left[0]` stays 0).
@compute @workgroup_size(WORKGROUP)
fn render(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let k = gid.x;
    if k < params.point_count {
        let point = window_point(params.first_point + k);
        // The state is loaded and stored field by field, and only the live part of the
        // stack: a whole PointState is 832 bytes, most of them unused slots (loading it
        // whole made tetra_s6's render 1.75 times as long).
        state.color = states[k].color;
        state.sp = states[k].sp;
        state.sample = states[k].sample;
        state.walking = states[k].walking;
        if state.walking != 0u {
            state.walk = states[k].walk;
        }
        for (var i = 0u; i < state.sp; i++) {
            state.stack[i] = states[k].stack[i];
        }
        if state.sp == 0u && params.sample_first + state.sample < params.sample_end {
            let eye = camera_ray(sample_position(point.x, point.y, params.sample_first + state.sample));
            state.stack[0] = Pending(eye.o, RAY_EYE | (1u << RAY_DEPTH_SHIFT), eye.d, 0.0, vec3<f32>(1.0), NO_ID);
            state.sp = 1u;
            state.sample += 1u;
        }
        if state.sp > 0u {
            trace_step();
        }
        if state.sp > 0u || params.sample_first + state.sample < params.sample_end {
            atomicAdd(&points_left[0], 1u);
        }
        states[k].color = state.color;
        states[k].sp = state.sp;
        states[k].sample = state.sample;
        states[k].walking = state.walking;
        if state.walking != 0u {
            states[k].walk = state.walk;
        }
        for (var i = 0u; i < state.sp; i++) {
            states[k].stack[i] = state.stack[i];
        }
        out_color[k] = vec4<f32>(state.color, 1.0);
        if point.z == 0u {
            drop_counts();
        }
    }
    flush_counters(lid);
}
