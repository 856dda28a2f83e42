// Bilinear filtering between texel centres, the one lookup of the materials' textures
// (texture.wgsl) and the environment map (environment.wgsl), which differ only in how they
// fetch a texel (twin: `bilinear` in src/scene/material.rs; keep in sync).

// Where the four texels around texel-space point (`x`, `y`) are (texel `i`'s centre at
// `i + 0.5`): the first at (`i`, `j`), and the point's fraction `f` past its centre.
struct Footprint {
    i: i32,
    j: i32,
    f: vec2<f32>,
}

fn footprint(x: f32, y: f32) -> Footprint {
    let xs = x - 0.5;
    let ys = y - 0.5;
    let x0 = floor(xs);
    let y0 = floor(ys);
    return Footprint(i32(x0), i32(y0), vec2<f32>(xs - x0, ys - y0));
}

// The blend at fraction `f` of texels `a` at (i, j), `b` at (i + 1, j), `c` at (i, j + 1) and
// `d` at (i + 1, j + 1).
fn bilinear(a: vec4<f32>, b: vec4<f32>, c: vec4<f32>, d: vec4<f32>, f: vec2<f32>) -> vec4<f32> {
    let top = a * (1.0 - f.x) + b * f.x;
    let bottom = c * (1.0 - f.x) + d * f.x;
    return top * (1.0 - f.y) + bottom * f.y;
}
