// The `aov` kernel: traces the eye ray through each pixel centre of one tile and writes the
// distance to its first hit, the shading normal or the object id (params.aov).
#include "shared/trace.wgsl"
#include "shared/sampling.wgsl"

@compute @workgroup_size(WORKGROUP)
fn aov(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let k = gid.x;
    if k < params.point_count {
        let point = window_point(params.first_point + k);
        let ray = camera_ray(vec2<f32>(f32(point.x) + 0.5, f32(point.y) + 0.5));
        count(C_RAYS + RAY_EYE);
        let h = closest(ray, FAR, RAY_EYE, NO_ID, NO_ID);
        var v = vec4<f32>(0.0);
        if h.found {
            count(C_EYE_HIT);
            let prim = prim_at(h.prim);
            let s = surface(prim, ray, h.hit);
            switch params.aov {
                case AOV_DEPTH: {
                    v = vec4<f32>(vec3<f32>(h.hit.t), 1.0);
                }
                case AOV_NORMAL: {
                    v = vec4<f32>(select(-s.ns, s.ns, dot(ray.d, s.ng) < 0.0), 1.0);
                }
                default: {
                    v = vec4<f32>(vec3<f32>(f32(h.prim)), 1.0);
                }
            }
        } else if params.aov == AOV_ID {
            v = vec4<f32>(-1.0, -1.0, -1.0, 0.0);
        }
        out_color[k] = v;
    }
    flush_counters(lid);
}
