// The two ends of every ray tree, the same in both kernel forms (the wavefront's `nearest`,
// the `tree` kernel): the eye ray at its root, and what a ray that leaves the scene brings.
#include "shared/sampling.wgsl"
#if ENVIRONMENT
#include "shared/environment.wgsl"
#endif

// The job of tile point `k`'s eye ray, for sample `pass_desc.sample` (POINT_UNOWNED set in
// its point where the window does not own the point).
fn eye_job(k: u32) -> Job {
    let point = window_point(params.first_point + k);
    let eye = camera_ray(sample_position(point.x, point.y, pass_desc.sample));
    let ray = new_pending(eye.o, RAY_EYE | (1u << RAY_DEPTH_SHIFT), eye.d, 0.0, vec3<f32>(1.0), NO_ID);
    return new_job(ray, k | select(POINT_UNOWNED, 0u, point.z != 0u));
}

// The radiance a ray leaving the scene along unit `d` brings: the environment's (ENVIRONMENT)
// or the background's.
fn background(d: vec3<f32>) -> vec3<f32> {
#if ENVIRONMENT
    return environment(d);
#else
    return params.background;
#endif
}
