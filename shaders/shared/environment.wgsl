// The environment map (ENVIRONMENT): the radiance a ray that leaves the scene sees, looked
// up as the CPU reference looks it up (twin: src/scene/environment.rs, Environment::radiance;
// keep in sync). Equirectangular, the glTF Sample Viewer's convention: a direction of local
// coordinates (x front, y up, z side) lies at u = 0.5 + atan2(z, x)/2π across the map and
// v = acos(y)/π down it; bilinear between texel centres, wrapped around in u, clamped at
// the poles. Texels are shared-exponent RGB: mantissa bytes times 2^(e − 136).

#include "shared/bilinear.wgsl"

// Texel (`x`, `y`) of the map, `x` wrapped around, `y` clamped, decoded (`w` 0).
fn env_texel(t: TextureInfo, x: i32, y: i32) -> vec4<f32> {
    let w = i32(t.width);
    let xi = ((x % w) + w) % w;
    let yi = clamp(y, 0, i32(t.height) - 1);
    let c = texels[t.offset + u32(yi) * t.width + u32(xi)];
    let e = c >> 24u;
    if e == 0u {
        return vec4<f32>(0.0);
    }
    let m = vec3<f32>(f32(c & 255u), f32((c >> 8u) & 255u), f32((c >> 16u) & 255u));
    return vec4<f32>(m * ldexp(1.0, i32(e) - 136), 0.0);
}

// The radiance arriving from direction `d` (unit).
fn environment(d: vec3<f32>) -> vec3<f32> {
    let inv_pi = 0.31830988618379067;
    let l = vec3<f32>(dot(params.env_x, d), dot(params.env_y, d), dot(params.env_z, d));
    // atan2(0, 0) is not defined: at the poles any u does (the top and bottom rows).
    var u = 0.5;
    if l.x != 0.0 || l.z != 0.0 {
        u = 0.5 + atan2(l.z, l.x) * (0.5 * inv_pi);
    }
    let v = acos(clamp(l.y / length(l), -1.0, 1.0)) * inv_pi;
    let t = texture_infos[params.env_texture - 1u];
    let p = footprint(u * f32(t.width), v * f32(t.height));
    let i = p.i;
    let j = p.j;
    let c = bilinear(env_texel(t, i, j), env_texel(t, i + 1, j), env_texel(t, i, j + 1), env_texel(t, i + 1, j + 1), p.f);
    return c.xyz * params.env_intensity;
}
