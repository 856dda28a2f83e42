// The `shadow` kernel (scenes with shadows): traces each shadow job of queue
// `pass_desc.src` (a long walk a chunk per pass, the rest through the retry queue) and adds
// its light to its point unless blocked (src/gpu/schedule.rs runs the passes).
#include "shared/trace.wgsl"
#if TEXTURES
#include "shared/texture.wgsl"
#endif
#include "shared/shade.wgsl"

@compute @workgroup_size(WORKGROUP)
fn shadow(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = gid.x;
    let busy = i < queue_len(pass_desc.src);
    if busy {
        let job = jobs[queue_base(pass_desc.src) + i];
        trace_shadow(job);
        if (job.point & POINT_UNOWNED) != 0u {
            drop_counts();
        }
    }
    flush_counters(lid);
    flush_lanes(lid, busy, LANE_SHADOW);
}
