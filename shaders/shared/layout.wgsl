// Shared declarations of every kernel: the scene's structs, constants and bindings shared
// with the host (the parameters, primitives, materials, lights and textures). Coordinates
// are re-centred on the camera. The wavefront's rays, jobs and queues are in
// wavefront.wgsl, the counters in counters.wgsl. Keep in sync with src/layout/structs.rs:
// each struct and constant here has one Rust twin of the same name, and tests/it/twins.rs
// compares them.

struct Params {
    cam_forward: vec3<f32>,
    cam_scale: f32,
    cam_right: vec3<f32>,
    half_w: f32,
    cam_up: vec3<f32>,
    half_h: f32,
    background: vec3<f32>,
    ortho: u32,
    ambient: vec3<f32>,
    prim_count: u32,
    grid_w: u32,
    grid_h: u32,
    first_point: u32,
    point_count: u32,
    spp: u32,
    lattice_g: u32,
    seed_hash: u32,
    corners: u32,
    max_depth: u32,
    light_count: u32,
    aov: u32,
    // The samples a tile runs, one wave each, are sample_first..sample_end (0..spp for a
    // whole render; the preview renders one sample per pass); the CPU schedule reads them and
    // gives each pass its sample in PassDesc.sample. spp sizes the jitter lattice.
    sample_first: u32,
    sample_end: u32,
    // `--accel cube`: the eye's origin, and the origin listing every primitive that rays
    // from an entity without a table use.
    eye_origin: u32,
    fallback_origin: u32,
    // Shadow walks of at most this many entries are traced within the step that found the
    // hit; longer ones become jobs (shade.wgsl).
    shadow_inline: u32,
    // The spawn offset is scale * spawn_rel + spawn_abs (geometry.wgsl, spawn_origin).
    spawn_rel: f32,
    spawn_abs: f32,
    // The grid points traced (--tile, --crop): win_w points a row from grid point
    // (win_x, win_y); those with local coordinates below (own_w, own_h) are counted.
    // grid_w stays the whole image's, for the sample hash.
    win_x: u32,
    win_y: u32,
    win_w: u32,
    own_w: u32,
    own_h: u32,
    // The BVH's nodes (0: none; bvh.wgsl), with --accel bvh and for the rays leaving surfaces.
    bvh_node_count: u32,
    // The wavefront's queues: jobs each ray queue and each shadow queue holds.
    ray_queue: u32,
    shadow_queue: u32,
    // --accel cube: 1 when rays leaving surfaces take the surface walk (the BVH or ray
    // queries; the render traces some).
    surface_walk: u32,
    // The BVH's inline shadow walks: a budget of loop iterations (nodes and primitives).
    bvh_inline: u32,
    // The environment map's frame (ENVIRONMENT, environment.wgsl): a direction's local
    // coordinates are its dot products with env_x (the map's front), env_y (up) and env_z
    // (side); its texels are texture env_texture - 1, scaled by env_intensity.
    env_x: vec3<f32>,
    env_texture: u32,
    env_y: vec3<f32>,
    env_intensity: f32,
    env_z: vec3<f32>,
    // SPLIT_PRIMS: primitives in each of the bindings they are split over (prim_at()).
    prims_per_binding: u32,
}

// The precision of positions and of the intersection arithmetic: f32, or f64 in the F64
// variant (`--precision f64`), where the primitives' coordinates and the queued rays'
// origins are f64 too, so that nothing on a ray's way from one hit to the next is rounded
// to f32 but its direction. Structs holding `real` have one Rust twin per layout: `Prim`,
// `Pending` and `Job`, and `Prim64`, `Pending64` and `Job64` (named so here, and aliased).
#if F64
alias real = f64;
#else
alias real = f32;
#endif
alias vec3r = vec3<real>;
alias vec4r = vec4<real>;

// One primitive (kind KIND_*). Sphere: a = (centre, radius). Triangle: a, b, c = vertices.
// Cylinder: a = (base, base radius), b = (apex, apex radius). `attr` indexes `tri_attrs`
// (triangles with normals or texture coordinates); `flags` holds FLAG_* bits.
#if F64
struct Prim64 {
    a: vec4<f64>,
    b: vec4<f64>,
    c: vec4<f64>,
    kind: u32,
    material: u32,
    flags: u32,
    attr: u32,
    // A vec4<f64> aligns the struct to 32 bytes: the padding, spelt out for the twin.
    pad: array<u32, 4>,
}
alias Prim = Prim64;
#else
struct Prim {
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
    kind: u32,
    material: u32,
    flags: u32,
    attr: u32,
}
#endif

// A triangle's per-vertex attributes, in one to three consecutive entries from `Prim.attr`,
// so that a triangle pays for what it carries in whole entries (colours alone take three). Entry 0: normals (FLAG_NORMALS) in
// `n0`..`n2`, texture coordinates of set 0 (FLAG_UVS: `uv01` = vertices 0 and 1, `uv2_1.xy` =
// vertex 2) and vertex 0's of set 1 (`uv2_1.zw`). Entry 1, where the triangle has tangents,
// set 1 or colours (src/layout/pack.rs, `tri_attr`): tangents (FLAG_TANGENTS: xyz, the bitangent's sign in w) in
// `n0`..`n2`, set 1 of vertices 1 and 2 (FLAG_UV1) in `uv01`. Entry 2, with colours
// (FLAG_COLORS): their RGB in `n0`..`n2`.
struct TriAttr {
    n0: vec4<f32>,
    n1: vec4<f32>,
    n2: vec4<f32>,
    uv01: vec4<f32>,
    uv2_1: vec4<f32>,
}

// A material's texture: index + 1 (0 = none), the TEXCOORD set it reads, and its
// KHR_texture_transform as two rows: uv' = (dot(row0.xy, uv) + row0.z, dot(row1.xy, uv) + row1.z).
struct TexRef {
    row0: vec3<f32>,
    texture: u32,
    row1: vec3<f32>,
    texcoord: u32,
}

// The scalar Whitted terms (a MATERIAL_MAPS material evaluates `metallic` …
// `emission_factor` and its textures per hit instead; its `mirror`, `transmittance` and
// `emission` bound every hit's, to decide what the scene spawns), the alpha rule
// (`opacity` times the base colour texture's alpha; a hit below `alpha_cutoff`, for shadow
// rays `shadow_cutoff`, is no hit), and the textures.
struct Material {
    color: vec3<f32>,
    kd: f32,
    mirror: vec3<f32>,
    ks: f32,
    emission: vec3<f32>,
    shine: f32,
    transmittance: f32,
    ior: f32,
    // MATERIAL_TINTED_TRANSMISSION, MATERIAL_MAPS, MATERIAL_BLEND.
    flags: u32,
    opacity: f32,
    metallic: f32,
    roughness: f32,
    transmission: f32,
    alpha_cutoff: f32,
    emission_factor: vec3<f32>,
    shadow_cutoff: f32,
    normal_scale: f32,
    // KHR_materials_clearcoat's strength (0: no coat), roughness and normal map scale.
    clearcoat: f32,
    clearcoat_roughness: f32,
    clearcoat_normal_scale: f32,
    base: TexRef,
    metallic_roughness: TexRef,
    emissive: TexRef,
    transmission_map: TexRef,
    normal: TexRef,
    // Beer–Lambert coefficient per unit length inside the body (KHR_materials_volume).
    attenuation: vec3<f32>,
    // KHR_materials_specular's weight and colour (a MATERIAL_MAPS material's).
    specular: f32,
    specular_color: vec3<f32>,
    pad0: u32,
    clearcoat_map: TexRef,
    clearcoat_roughness_map: TexRef,
    clearcoat_normal: TexRef,
    specular_map: TexRef,
    specular_color_map: TexRef,
}

// kind: LIGHT_POINT, LIGHT_SPOT or LIGHT_DIRECTIONAL. `range` 0 = unlimited.
struct Light {
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    range: f32,
    radiance: vec3<f32>,
    inverse_square: u32,
    cos_outer: f32,
    span: f32,
    pad0: u32,
    pad1: u32,
}

// Texel offset into `texels`, size, and flags: wrap_s (bits 0-1) and wrap_t (bits 2-3), each
// a WRAP_* mode, and TEX_BILINEAR.
struct TextureInfo {
    offset: u32,
    width: u32,
    height: u32,
    flags: u32,
}

// `params` is a read-only storage buffer, not a uniform: lavapipe specialises a shader on
// the values of uniforms that steer its control flow ("inlined uniforms") and compiles a
// new variant for every new set of values. The tile's first point changes with every tile,
// so a uniform `params` made one compiled variant per tile, each kept until the device goes:
// memory grew with every tile (gears_s4 by brute force at 64x64: 0.2 to 5.6 GB in two
// minutes) and every tile paid a compile or a cache load.
@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> prims: array<Prim>;
#if SPLIT_PRIMS
// Primitives past what one binding holds (lavapipe: 128 MiB, 2M primitives in f32).
@group(0) @binding(26) var<storage, read> prims_1: array<Prim>;
@group(0) @binding(27) var<storage, read> prims_2: array<Prim>;
@group(0) @binding(28) var<storage, read> prims_3: array<Prim>;
#endif
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> tri_attrs: array<TriAttr>;
@group(0) @binding(5) var<storage, read> texture_infos: array<TextureInfo>;
@group(0) @binding(6) var<storage, read> texels: array<u32>;
@group(0) @binding(7) var<storage, read_write> out_color: array<vec4<f32>>;

// Primitive `id`: with SPLIT_PRIMS, the primitives lie in up to four bindings of
// `params.prims_per_binding` each, in order (twin: gpu::buffers' data_parts).
fn prim_at(id: u32) -> Prim {
#if SPLIT_PRIMS
    let k = id / params.prims_per_binding;
    let i = id - k * params.prims_per_binding;
    var p: Prim;
    switch k {
        case 0u: {
            p = prims[i];
        }
        case 1u: {
            p = prims_1[i];
        }
        case 2u: {
            p = prims_2[i];
        }
        default: {
            p = prims_3[i];
        }
    }
    return p;
#else
    return prims[id];
#endif
}

// Invocations per workgroup of the `render` and `aov` kernels.
const WORKGROUP: u32 = 64u;

const KIND_SPHERE: u32 = 0u;
const KIND_TRIANGLE: u32 = 1u;
const KIND_CYLINDER: u32 = 2u;

const FLAG_INSIDE_ONLY: u32 = 1u;
const FLAG_NORMALS: u32 = 2u;
const FLAG_UVS: u32 = 4u;
const FLAG_COLORS: u32 = 8u;
const FLAG_UV1: u32 = 16u;
const FLAG_TANGENTS: u32 = 32u;
// The primitive's material is alpha-masked: every walk tests alpha at its hits.
const FLAG_CUTOUT: u32 = 64u;
// The primitive's material is masked or blended: shadow walks test alpha at its hits.
const FLAG_CUTOUT_SHADOW: u32 = 128u;

const MATERIAL_TINTED_TRANSMISSION: u32 = 1u;
const MATERIAL_MAPS: u32 = 2u;
const MATERIAL_BLEND: u32 = 4u;

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;

const WRAP_REPEAT: u32 = 0u;
const WRAP_MIRRORED_REPEAT: u32 = 1u;
const WRAP_CLAMP_TO_EDGE: u32 = 2u;
const TEX_BILINEAR: u32 = 16u;
// Colour channels are sRGB-encoded (decoded to linear when read).
const TEX_SRGB: u32 = 32u;

// What the `aov` kernel writes (params.aov).
const AOV_DEPTH: u32 = 0u;
const AOV_NORMAL: u32 = 1u;
const AOV_ID: u32 = 2u;

// The largest finite f32: the open end of an unbounded ray (no infinity is used).
const FAR: f32 = 3.4028235e38;

// "No primitive".
const NO_ID: u32 = 0xffffffffu;

// Shadow rays of a positional light, traced from the light, end this relative distance
// before the point they are cast for (f32; `shadow_ray`, geometry.wgsl).
const SHADOW_END_REL: f32 = 9.5367431640625e-7;

// The grid point of window point `point` (row-major in the window), and whether the window
// owns it (counts its rays: the corners on a window's far edges belong to its neighbour).
fn window_point(point: u32) -> vec3<u32> {
    let li = point % params.win_w;
    let lj = point / params.win_w;
    return vec3<u32>(params.win_x + li, params.win_y + lj, u32(li < params.own_w && lj < params.own_h));
}
