// Eye-ray placement and the camera; twins of src/sampling.rs and Camera::ray.

// PCG-RXS-M-XS 32-bit hash (Jarzynski and Olano 2020).
fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A number in [0, 1) for (pixel, sample, dimension); `params.seed_hash` is the seed part
// pcg(pcg(seed_hi) ^ seed_lo), computed on the CPU.
fn random(pixel: u32, sample: u32, dim: u32) -> f32 {
    let h = pcg(pcg(params.seed_hash ^ pixel) ^ (2u * sample + dim));
    return f32(h >> 8u) / 16777216.0;
}

// Image position of sample `s` of grid point (i, j).
fn sample_position(i: u32, j: u32, s: u32) -> vec2<f32> {
    if params.corners != 0u {
        return vec2<f32>(f32(i), f32(j));
    }
    if params.spp <= 1u {
        return vec2<f32>(f32(i) + 0.5, f32(j) + 0.5);
    }
    let pixel = j * params.grid_w + i;
    let sy = (s * params.lattice_g) % params.spp;
    let n = f32(params.spp);
    let x = (f32(s) + random(pixel, s, 0u)) / n;
    let y = (f32(sy) + random(pixel, s, 1u)) / n;
    return vec2<f32>(f32(i) + x, f32(j) + y);
}

// The primary ray through image position `xy` (the eye is the origin of the re-centred
// scene).
fn camera_ray(xy: vec2<f32>) -> Ray {
    let sx = (xy.x - params.half_w) * params.cam_scale;
    let sy = (params.half_h - xy.y) * params.cam_scale;
    if params.ortho != 0u {
        return make_ray(vec3r(params.cam_right * sx + params.cam_up * sy), params.cam_forward);
    }
    return make_ray(vec3r(0.0), params.cam_forward + params.cam_right * sx + params.cam_up * sy);
}
