// The `nearest` kernel: traces each job of queue `pass_desc.src` (SRC_EYE: the eye ray of
// sample `pass_desc.sample` of each point of the tile, made here) for its nearest hit (a long
// walk a chunk per pass, the rest through the retry queue), adds what its hit sends to its
// point, and pushes the rays the hit spawns into the pass's queues (src/gpu/schedule.rs runs
// the passes).
#include "shared/layout.wgsl"
#include "shared/geometry.wgsl"
#include "shared/sampling.wgsl"
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
#if TEXTURES
#include "shared/texture.wgsl"
#endif
#include "shared/shade.wgsl"

// The job of tile point `k`'s eye ray, for sample `pass_desc.sample`.
fn eye_job(k: u32) -> Job {
    let point = window_point(params.first_point + k);
    let eye = camera_ray(sample_position(point.x, point.y, pass_desc.sample));
    let ray = Pending(eye.o, RAY_EYE | (1u << RAY_DEPTH_SHIFT), eye.d, 0.0, vec3<f32>(1.0), NO_ID);
    return new_job(ray, k | select(POINT_UNOWNED, 0u, point.z != 0u));
}

@compute @workgroup_size(WORKGROUP)
fn nearest(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = gid.x;
    // One call of `trace_job` for both sources: lavapipe ran the kernel 15 % slower on
    // balls_s4 with the shading inlined twice.
    var job: Job;
    var traced = false;
    if pass_desc.src == SRC_EYE {
        if i < params.point_count {
            job = eye_job(i);
            traced = true;
        }
    } else if i < queue_len(pass_desc.src) {
        job = jobs[queue_base(pass_desc.src) + i];
        traced = true;
    }
    if traced {
        trace_job(job);
        if (job.point & POINT_UNOWNED) != 0u {
            drop_counts();
        }
    }
    flush_counters(lid);
}
