// The `shade` kernel: shades each hit of queue `pass_desc.src` (the hit queue the `nearest`
// passes of a depth filled, the hit in each job's walk state): adds what the hit sends to
// its point, traces its short shadow walks, and pushes the rays it spawns into the pass's
// queues (src/gpu/schedule.rs runs the passes).
#include "shared/trace.wgsl"
#if TEXTURES
#include "shared/texture.wgsl"
#endif
#include "shared/shade.wgsl"

@compute @workgroup_size(WORKGROUP)
fn shade(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = gid.x;
    let busy = i < queue_len(pass_desc.src);
    if busy {
        let job = jobs[queue_base(pass_desc.src) + i];
        shade_hit(job.ray, restored_closest(job.walk, WALK_RESUME), job.point);
        if (job.point & POINT_UNOWNED) != 0u {
            drop_counts();
        }
    }
    flush_counters(lid);
    flush_lanes(lid, busy, LANE_SHADE);
}
