// Textures: texels decoded to linear (sRGB colour textures; data textures as stored), wrap
// modes, nearest or bilinear, as the CPU reference samples them (src/reference/texture.rs);
// and a material's texture read at a surface point through its UV set and transform.

#include "shared/bilinear.wgsl"

fn srgb_to_linear(v: u32) -> f32 {
    let c = f32(v) / 255.0;
    if c <= 0.04045 {
        return c / 12.92;
    }
    return pow((c + 0.055) / 1.055, 2.4);
}

fn wrap_coord(i: i32, n: i32, mode: u32) -> i32 {
    switch mode {
        case WRAP_REPEAT: {
            return ((i % n) + n) % n;
        }
        case WRAP_MIRRORED_REPEAT: {
            let m = ((i % (2 * n)) + 2 * n) % (2 * n);
            return select(m, 2 * n - 1 - m, m >= n);
        }
        default: {
            return clamp(i, 0, n - 1);
        }
    }
}

fn texel(t: TextureInfo, i: i32, j: i32) -> vec4<f32> {
    let x = wrap_coord(i, i32(t.width), t.flags & 3u);
    let y = wrap_coord(j, i32(t.height), (t.flags >> 2u) & 3u);
    let c = texels[t.offset + u32(y) * t.width + u32(x)];
    let a = f32(c >> 24u) / 255.0;
    if (t.flags & TEX_SRGB) != 0u {
        return vec4<f32>(srgb_to_linear(c & 255u), srgb_to_linear((c >> 8u) & 255u),
            srgb_to_linear((c >> 16u) & 255u), a);
    }
    return vec4<f32>(f32(c & 255u), f32((c >> 8u) & 255u), f32((c >> 16u) & 255u), f32(c >> 24u)) / 255.0;
}

fn sample_texture(index: u32, uv: vec2<f32>) -> vec4<f32> {
    let t = texture_infos[index];
    // Beyond 2^24 an f32 holds no fraction; every wrap mode is periodic or constant there.
    let x = clamp(uv.x * f32(t.width), -16777216.0, 16777216.0);
    let y = clamp(uv.y * f32(t.height), -16777216.0, 16777216.0);
    if (t.flags & TEX_BILINEAR) == 0u {
        return texel(t, i32(floor(x)), i32(floor(y)));
    }
    let p = footprint(x, y);
    let i = p.i;
    let j = p.j;
    return bilinear(texel(t, i, j), texel(t, i + 1, j), texel(t, i, j + 1), texel(t, i + 1, j + 1), p.f);
}

// Texture `r` at a point with UV sets `uv0` (`has0`) and `uv1` (`has1`); `fallback` where
// there is no texture or the point lacks its set (twin: reference::texture `read`).
fn read_texture(r: TexRef, uv0: vec2<f32>, has0: bool, uv1: vec2<f32>, has1: bool, fallback: vec4<f32>) -> vec4<f32> {
    if r.texture == 0u {
        return fallback;
    }
    let uv = select(uv0, uv1, r.texcoord == 1u);
    if !select(has0, has1, r.texcoord == 1u) {
        return fallback;
    }
    let t = vec2<f32>(dot(r.row0.xy, uv) + r.row0.z, dot(r.row1.xy, uv) + r.row1.z);
    return sample_texture(r.texture - 1u, t);
}
