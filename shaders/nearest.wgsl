// The `nearest` kernel: traces each job of queue `pass_desc.src` for its nearest hit (a long
// walk a chunk per pass, the rest through the retry queue), adds what its hit sends to its
// point, and pushes the rays the hit spawns into the pass's queues (src/gpu/schedule.rs runs
// the passes).
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
#if TEXTURES
#include "shared/texture.wgsl"
#endif
#include "shared/shade.wgsl"

@compute @workgroup_size(WORKGROUP)
fn nearest(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = gid.x;
    if i < queue_len(pass_desc.src) {
        let job = jobs[queue_base(pass_desc.src) + i];
        trace_job(job);
        if (job.point & POINT_UNOWNED) != 0u {
            drop_counts();
        }
    }
    flush_counters(lid);
}
