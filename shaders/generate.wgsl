// The `generate` kernel: starts sample `pass_desc.sample` of every grid point of the tile (pixels,
// or pixel corners with SPD sampling): its eye ray goes into queue `pass_desc.next`, where the
// `nearest` kernel traces it (src/gpu/schedule.rs runs the passes).
#include "shared/layout.wgsl"
#include "shared/geometry.wgsl"
#include "shared/sampling.wgsl"

@compute @workgroup_size(WORKGROUP)
fn generate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if k < params.point_count {
        let point = window_point(params.first_point + k);
        let eye = camera_ray(sample_position(point.x, point.y, pass_desc.sample));
        let ray = Pending(eye.o, RAY_EYE | (1u << RAY_DEPTH_SHIFT), eye.d, 0.0, vec3<f32>(1.0), NO_ID);
        push_job(pass_desc.next, new_job(ray, k | select(POINT_UNOWNED, 0u, point.z != 0u)));
    }
}
