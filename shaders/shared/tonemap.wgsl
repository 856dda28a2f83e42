// Tone mapping: how radiance beyond 1 comes into [0, 1] before the transfer encodes it
// (twin: scene::Tonemap::apply in src/scene/mod.rs; keep in sync). The preview's display
// pass applies it; tests/it/arith/tonemap.rs runs it against the twin.

const TONEMAP_NONE: u32 = 0u;
const TONEMAP_PBR_NEUTRAL: u32 = 1u;
const TONEMAP_ACES: u32 = 2u;

// Khronos PBR Neutral (twin: scene::Tonemap::apply, `pbr_neutral`).
fn pbr_neutral(c_in: vec3<f32>) -> vec3<f32> {
    let start = 0.8 - 0.04;
    let desaturation = 0.15;
    let x = min(c_in.x, min(c_in.y, c_in.z));
    let offset = select(0.04, x - 6.25 * x * x, x < 0.08);
    var c = c_in - vec3<f32>(offset);
    let peak = max(c.x, max(c.y, c.z));
    if peak < start {
        return c;
    }
    let d = 1.0 - start;
    let new_peak = 1.0 - d * d / (peak + d - start);
    c = c * (new_peak / peak);
    let g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return c * (1.0 - g) + vec3<f32>(new_peak * g);
}

fn aces_fit(v: f32) -> f32 {
    return (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.432951) + 0.238081);
}

// ACES filmic, Hill's fit (twin: scene::Tonemap::apply, `aces`).
fn aces(c: vec3<f32>) -> vec3<f32> {
    let i = vec3<f32>(0.59719 * c.x + 0.35458 * c.y + 0.04823 * c.z, 0.07600 * c.x + 0.90834 * c.y + 0.01566 * c.z,
        0.02840 * c.x + 0.13383 * c.y + 0.83777 * c.z);
    let f = vec3<f32>(aces_fit(i.x), aces_fit(i.y), aces_fit(i.z));
    return vec3<f32>(1.60475 * f.x - 0.53108 * f.y - 0.07367 * f.z, -0.10208 * f.x + 1.10813 * f.y - 0.00605 * f.z,
        -0.00327 * f.x - 0.07276 * f.y + 1.07602 * f.z);
}

// `c` (times the exposure already) tone mapped by `mode` (TONEMAP_*) and clamped to [0, 1]:
// NaN and negative values first become 0.
fn tonemap(c_in: vec3<f32>, mode: u32) -> vec3<f32> {
    var c = max(select(c_in, vec3<f32>(0.0), c_in != c_in), vec3<f32>(0.0));
    if mode == TONEMAP_PBR_NEUTRAL {
        c = pbr_neutral(c);
    } else if mode == TONEMAP_ACES {
        c = aces(c);
    }
    return clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
}
