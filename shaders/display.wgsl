// The preview's `display` pass (src/preview/display.rs): draws the accumulation's average
// as the headless PNG output encodes it (times the exposure, tone mapped, clamped to [0, 1],
// then the render's transfer).

// What the window shows. Keep in sync with `View` in src/preview/display.rs.
struct View {
    width: u32,
    height: u32,
    grid_w: u32,
    // Samples accumulated per grid point (0: nothing to show yet).
    samples: u32,
    // 1: the accumulation holds pixel corners (SPD sampling); a pixel averages four.
    corners: u32,
    // What the shader does after clamping (ENCODE_*): the render's transfer, less what an
    // sRGB target format does in hardware.
    encode: u32,
    // Pixels per grid point edge: 1, or the block of a moving camera's coarse image.
    block: u32,
    // The tone mapping before the clamp (TONEMAP_*), after the values are multiplied by
    // `exposure`.
    tonemap: u32,
    exposure: f32,
    pad1: u32,
}

// A storage buffer, not a uniform, for the reason `params` is one (shared/layout.wgsl):
// `samples` changes with every frame.
@group(0) @binding(0) var<storage, read> view: View;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;

#include "shared/tonemap.wgsl"

struct VertexOut {
    @builtin(position) position: vec4<f32>,
}

// One triangle that covers the viewport.
@vertex
fn vs_main(@builtin(vertex_index) v: u32) -> VertexOut {
    let x = f32((v << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(v & 2u) * 2.0 - 1.0;
    return VertexOut(vec4<f32>(x, y, 0.0, 1.0));
}

// Store the value as it is; sRGB-encode it; or undo the sRGB encoding an sRGB target applies
// (display values on an sRGB surface).
const ENCODE_NONE: u32 = 0u;
const ENCODE_SRGB: u32 = 1u;
const ENCODE_LINEARIZE: u32 = 2u;

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        return c / 12.92;
    }
    return pow((c + 0.055) / 1.055, 2.4);
}

fn srgb(c: f32) -> f32 {
    if c <= 0.0031308 {
        return 12.92 * c;
    }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let i = u32(in.position.x);
    let j = u32(in.position.y);
    if i >= view.width || j >= view.height || view.samples == 0u {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    var c: vec3<f32>;
    if view.corners != 0u {
        let w = view.grid_w;
        let a = image[j * w + i].xyz + image[j * w + i + 1u].xyz;
        let b = image[(j + 1u) * w + i].xyz + image[(j + 1u) * w + i + 1u].xyz;
        c = (a + b) * 0.25;
    } else {
        let b = max(view.block, 1u);
        c = image[(j / b) * view.grid_w + i / b].xyz / f32(view.samples);
    }
    // tonemap() maps NaN (which fails every comparison) and negative values to 0 first.
    c = tonemap(c * view.exposure, view.tonemap);
    if view.encode == ENCODE_SRGB {
        c = vec3<f32>(srgb(c.x), srgb(c.y), srgb(c.z));
    } else if view.encode == ENCODE_LINEARIZE {
        c = vec3<f32>(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
    }
    return vec4<f32>(c, 1.0);
}
