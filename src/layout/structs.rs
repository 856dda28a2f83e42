//! The Rust twins of the structs and constants in `shaders/shared/layout.wgsl` and
//! `shaders/shared/wavefront.wgsl` (keep them in sync): one `#[repr(C)]` bytemuck struct per
//! WGSL struct, with the same name and fields, and one constant per WGSL constant.
//! `tests/it/twins.rs` reads the WGSL through naga and compares every layout and value. The
//! table structs (`GpuOrigin`, `GpuFace`, `GpuEntry`, `GpuGroup`) are twinned in
//! [`crate::coherence::flat`].

use bytemuck::{Pod, Zeroable};

/// Kernel parameters (WGSL `Params`, in a read-only storage buffer; keep in sync with
/// `shaders/shared/layout.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Params {
    pub cam_forward: [f32; 3],
    pub cam_scale: f32,
    pub cam_right: [f32; 3],
    pub half_w: f32,
    pub cam_up: [f32; 3],
    pub half_h: f32,
    pub background: [f32; 3],
    pub ortho: u32,
    pub ambient: [f32; 3],
    pub prim_count: u32,
    pub grid_w: u32,
    pub grid_h: u32,
    pub first_point: u32,
    pub point_count: u32,
    pub spp: u32,
    pub lattice_g: u32,
    pub seed_hash: u32,
    pub corners: u32,
    pub max_depth: u32,
    pub light_count: u32,
    /// 0 depth, 1 normal, 2 object id (the `aov` entry point).
    pub aov: u32,
    /// The samples a tile runs, `sample_first..sample_end` of the `spp`-sample lattice, one
    /// wave each (read by the schedule; a wave's passes get their sample in `PassDesc::sample`).
    pub sample_first: u32,
    pub sample_end: u32,
    /// `--accel cube`: the eye's origin and the fallback origin (every primitive).
    pub eye_origin: u32,
    pub fallback_origin: u32,
    /// Shadow walks of at most this many entries are traced by the `shade` invocation of the
    /// hit; longer ones become jobs of the shadow queue ([`super::budget::shadow_inline`]).
    pub shadow_inline: u32,
    /// The spawn offset is `scale·spawn_rel + spawn_abs` ([`crate::arith::spawn`]).
    pub spawn_rel: f32,
    pub spawn_abs: f32,
    /// The grid points traced (`--tile`, `--crop`): `win_w` points a row from grid point
    /// (`win_x`, `win_y`); those with local coordinates below (`own_w`, `own_h`) are counted
    /// ([`crate::job::GridRegion`]). `grid_w` stays the whole image's, for the sample hash.
    pub win_x: u32,
    pub win_y: u32,
    pub win_w: u32,
    pub own_w: u32,
    pub own_h: u32,
    /// The BVH's nodes (0: none; [`crate::layout::bvh`]), with `--accel bvh` and for the rays
    /// leaving surfaces.
    pub bvh_node_count: u32,
    /// The wavefront's queues: jobs each ray queue and each shadow queue holds
    /// ([`crate::gpu::schedule`]).
    pub ray_queue: u32,
    pub shadow_queue: u32,
    /// `--accel cube`: 1 when rays leaving surfaces take the surface walk, the BVH's or ray
    /// queries' (the render traces some; `shaders/shared/walk.wgsl`).
    pub surface_walk: u32,
    /// The BVH's shadow walks traced inline at a hit: a budget of loop iterations (nodes and
    /// primitives, [`super::budget::bvh_shadow_inline`]).
    pub bvh_inline: u32,
    /// The environment map's frame (`ENVIRONMENT`; [`crate::scene::Environment`]): a
    /// direction's local coordinates are its dot products with `env_x` (the map's front),
    /// `env_y` (its up) and `env_z` (its side); its texels are texture `env_texture − 1`
    /// (shared-exponent RGB), scaled by `env_intensity`.
    pub env_x: [f32; 3],
    pub env_texture: u32,
    pub env_y: [f32; 3],
    pub env_intensity: f32,
    pub env_z: [f32; 3],
    /// `SPLIT_PRIMS`: primitives in each binding they are split over
    /// (`gpu::buffers`); unused otherwise.
    pub prims_per_binding: u32,
}

/// One primitive (WGSL `Prim`, keep in sync with `shaders/shared/layout.wgsl`): sphere `a` =
/// (centre, radius); triangle `a`, `b`, `c` = vertices; cylinder `a` = (base, base radius), `b`
/// = (apex, apex radius). `kind` is a `KIND_*` code, `flags` a set of `FLAG_*` bits, `attr`
/// indexes the [`TriAttr`]s.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Prim {
    pub a: [f32; 4],
    pub b: [f32; 4],
    pub c: [f32; 4],
    pub kind: u32,
    pub material: u32,
    pub flags: u32,
    pub attr: u32,
}

/// [`Prim`] in the F64 kernel variant (`--precision f64`; WGSL `Prim64`): the coordinates in
/// f64, and the 32-byte alignment of a `vec4<f64>` spelt out as `pad`. 128 bytes, against
/// [`Prim`]'s 64.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Prim64 {
    pub a: [f64; 4],
    pub b: [f64; 4],
    pub c: [f64; 4],
    pub kind: u32,
    pub material: u32,
    pub flags: u32,
    pub attr: u32,
    pub pad: [u32; 4],
}

/// One entry of a triangle's per-vertex attributes (WGSL `TriAttr`, keep in sync with
/// `shaders/shared/layout.wgsl`, which says what each of a triangle's one to three
/// consecutive entries holds: normals and set 0; tangents and set 1; colours).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct TriAttr {
    pub n0: [f32; 4],
    pub n1: [f32; 4],
    pub n2: [f32; 4],
    /// Set 0: vertices 0 and 1 (entry 1: set 1, vertices 1 and 2).
    pub uv01: [f32; 4],
    /// Set 0: vertex 2 (xy); set 1: vertex 0 (zw).
    pub uv2_1: [f32; 4],
}

/// A material's texture (WGSL `TexRef`): index + 1 (0 = none), TEXCOORD set, and the
/// KHR_texture_transform's two rows.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct TexRef {
    pub row0: [f32; 3],
    pub texture: u32,
    pub row1: [f32; 3],
    pub texcoord: u32,
}

/// A material (WGSL `Material`, keep in sync with `shaders/shared/layout.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Material {
    pub color: [f32; 3],
    pub kd: f32,
    pub mirror: [f32; 3],
    pub ks: f32,
    pub emission: [f32; 3],
    pub shine: f32,
    pub transmittance: f32,
    pub ior: f32,
    /// [`MATERIAL_TINTED_TRANSMISSION`], [`MATERIAL_MAPS`], [`MATERIAL_BLEND`].
    pub flags: u32,
    pub opacity: f32,
    pub metallic: f32,
    pub roughness: f32,
    pub transmission: f32,
    /// Hits below this alpha are no hits (−1: every hit counts).
    pub alpha_cutoff: f32,
    pub emission_factor: [f32; 3],
    /// The cutoff for shadow rays.
    pub shadow_cutoff: f32,
    pub normal_scale: f32,
    /// KHR_materials_clearcoat's strength (0: no coat), roughness and normal map scale.
    pub clearcoat: f32,
    pub clearcoat_roughness: f32,
    pub clearcoat_normal_scale: f32,
    pub base: TexRef,
    pub metallic_roughness: TexRef,
    pub emissive: TexRef,
    pub transmission_map: TexRef,
    pub normal: TexRef,
    /// Beer–Lambert coefficient per unit length inside the body (KHR_materials_volume).
    pub attenuation: [f32; 3],
    /// KHR_materials_specular's weight and colour (a per-hit material's; 1 without).
    pub specular: f32,
    pub specular_color: [f32; 3],
    pub pad0: u32,
    pub clearcoat_map: TexRef,
    pub clearcoat_roughness_map: TexRef,
    pub clearcoat_normal: TexRef,
    pub specular_map: TexRef,
    pub specular_color_map: TexRef,
}

/// A light (WGSL `Light`, keep in sync with `shaders/shared/layout.wgsl`); positions relative
/// to the eye.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Light {
    pub position: [f32; 3],
    /// `LIGHT_POINT`, `LIGHT_SPOT` or `LIGHT_DIRECTIONAL`.
    pub kind: u32,
    pub direction: [f32; 3],
    /// 0 = unlimited.
    pub range: f32,
    /// Colour × intensity.
    pub radiance: [f32; 3],
    pub inverse_square: u32,
    pub cos_outer: f32,
    pub span: f32,
    pub pad0: u32,
    pub pad1: u32,
}

/// Where a texture's texels are and how it is sampled (WGSL `TextureInfo`, keep in sync with
/// `shaders/shared/layout.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct TextureInfo {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    /// wrap_s (bits 0-1), wrap_t (bits 2-3), each a `WRAP_*` code, and [`TEX_BILINEAR`].
    pub flags: u32,
}

/// A ray of a grid point's ray tree (WGSL `Pending`, keep in sync with
/// `shaders/shared/wavefront.wgsl`). `kind` is a `RAY_*` kind, with [`RAY_SKIP_FROM`] set when
/// `from_prim` need not be tested, and the ray's depth from bit [`RAY_DEPTH_SHIFT`] on (a
/// shadow ray: its light, with what the light adds unless blocked in `weight`). `spawn` is
/// how far the origin was moved off the surface it leaves (0 for the eye).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Pending {
    pub o: [f32; 3],
    pub kind: u32,
    pub d: [f32; 3],
    pub spawn: f32,
    pub weight: [f32; 3],
    pub from_prim: u32,
}

/// [`Pending`] in the F64 kernel variant (WGSL `Pending64`): the origin in f64, so that a
/// ray leaving a surface starts where the f64 arithmetic put it; `pad0` is where WGSL's
/// `vec3<f32>` alignment puts `d`. 64 bytes, against [`Pending`]'s 48.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Pending64 {
    pub o: [f64; 3],
    pub kind: u32,
    pub pad0: u32,
    pub d: [f32; 3],
    pub spawn: f32,
    pub weight: [f32; 3],
    pub from_prim: u32,
}

/// The deepest ray tree the kernels trace (WGSL `MAX_DEPTH`).
pub const MAX_DEPTH: u32 = 16;

/// The `tree` kernel's private stack of pending rays (WGSL `TREE_STACK`, `shaders/tree.wgsl`):
/// a ray spawns at most three rays one depth deeper (a pass-through, a refraction, a
/// reflection), so a depth-first walk of a tree of at most [`MAX_DEPTH`] depths keeps at most
/// two unexplored siblings of each depth above the ray traced, and three of the deepest.
pub const TREE_STACK: u32 = 2 * MAX_DEPTH + 1;

/// A walk interrupted between passes (WGSL `WalkState`, keep in sync with
/// `shaders/shared/wavefront.wgsl`): where the walk stands, and for a nearest-hit walk the
/// winner so far with the tie rule's window and least t ([`crate::arith::closest`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct WalkState {
    pub i: u32,
    pub iend: u32,
    pub j: u32,
    pub jend: u32,
    pub prim: u32,
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
    pub window: f32,
    pub t_min: f32,
}

/// A job's walk not started (WGSL `WALK_START`).
pub const WALK_START: u32 = 0;
/// A job's walk resumed (WGSL `WALK_RESUME`).
pub const WALK_RESUME: u32 = 1;
/// A job's walk resumed after the tie rule lost its winner: run again once over (WGSL
/// `WALK_RESUME_LOST`).
pub const WALK_RESUME_LOST: u32 = 2;

/// A ray in a queue of the wavefront kernels (WGSL `Job`, keep in sync with
/// `shaders/shared/wavefront.wgsl`): the ray, the tile point it adds to (with
/// [`POINT_UNOWNED`]), and its walk when a pass ended it unfinished (`walking` not
/// [`WALK_START`]). 96 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Job {
    pub ray: Pending,
    pub point: u32,
    pub walking: u32,
    pub walk: WalkState,
}

/// [`Job`] in the F64 kernel variant (WGSL `Job64`), with the 32-byte alignment of
/// [`Pending64`] spelt out as `pad`. 128 bytes, against [`Job`]'s 96.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Job64 {
    pub ray: Pending64,
    pub point: u32,
    pub walking: u32,
    pub walk: WalkState,
    pub pad: [u32; 4],
}

/// One pass of the wavefront kernels (WGSL `PassDesc`, keep in sync with
/// `shaders/shared/wavefront.wgsl`): the queue it works through ([`SRC_EYE`]: the tile's eye
/// rays, made by the pass itself), the queues the jobs it makes go to (`hit`: traced rays to
/// shade; `next`: secondary rays; `shadow`: shadow rays; `retry`: walks that go on), the
/// sample the wave traces and the depth of its rays.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PassDesc {
    pub src: u32,
    pub next: u32,
    pub shadow: u32,
    pub retry: u32,
    pub sample: u32,
    pub hit: u32,
    /// The depth of the rays the pass works on (the eye's: 1), for the lane counters.
    pub depth: u32,
    pub pad1: u32,
}

/// The wavefront's queues (WGSL `QUEUE_*`): rays to trace by depth in turn, rays whose walk
/// goes on (in turn), rays whose nearest hit is found (to shade), shadow rays, shadow rays
/// whose walk goes on (in turn). The queues before [`QUEUE_SHADOW`] hold
/// [`Params::ray_queue`] jobs each, the others [`Params::shadow_queue`].
pub const QUEUE_RAY0: u32 = 0;
pub const QUEUE_RAY1: u32 = 1;
pub const QUEUE_RETRY0: u32 = 2;
pub const QUEUE_RETRY1: u32 = 3;
pub const QUEUE_HIT: u32 = 4;
pub const QUEUE_SHADOW: u32 = 5;
pub const QUEUE_SRETRY0: u32 = 6;
pub const QUEUE_SRETRY1: u32 = 7;
pub const QUEUE_COUNT: u32 = 8;
/// [`PassDesc::src`] of the first pass of a wave: it traces the tile's eye rays, which it
/// makes itself, instead of a queue's jobs (WGSL `SRC_EYE`).
pub const SRC_EYE: u32 = u32::MAX;
/// Words of the `queues` buffer: the lengths, from [`QUEUE_ARGS`] each queue's indirect
/// dispatch arguments (x, y, z), and the overflow flag at [`QUEUE_OVERFLOW`].
pub const QUEUE_ARGS: u32 = 8;
pub const QUEUE_OVERFLOW: u32 = 32;
pub const QUEUE_WORDS: u32 = 36;
/// Bits of the overflow word: a push found its queue full; a walk went on past the last
/// pass of its depth (a push to a queue numbered [`QUEUE_COUNT`] or more).
pub const OVERFLOW_FULL: u32 = 1;
pub const OVERFLOW_UNFINISHED: u32 = 2;

/// Set in [`Job::point`] for a point the window does not own: its rays are not counted.
pub const POINT_UNOWNED: u32 = 0x8000_0000;

/// Fixed-point units per unit of radiance in the `accum` buffer (WGSL `ACCUM_ONE`).
pub const ACCUM_ONE: f32 = 4_294_967_296.0;

/// Invocations per workgroup of the wavefront and `aov` kernels (WGSL `WORKGROUP`).
pub const WORKGROUP: u32 = 64;

/// [`Prim::kind`] codes (WGSL `KIND_*`); they also index the test counters.
pub const KIND_SPHERE: u32 = 0;
pub const KIND_TRIANGLE: u32 = 1;
pub const KIND_CYLINDER: u32 = 2;

/// [`Prim::flags`] bits (WGSL `FLAG_*`): a sphere or cylinder seen only from inside, a
/// triangle with shading normals, with texture coordinates.
pub const FLAG_INSIDE_ONLY: u32 = 1;
pub const FLAG_NORMALS: u32 = 2;
pub const FLAG_UVS: u32 = 4;
pub const FLAG_COLORS: u32 = 8;
pub const FLAG_UV1: u32 = 16;
pub const FLAG_TANGENTS: u32 = 32;
/// The primitive's material is alpha-masked: every walk tests alpha (WGSL `FLAG_CUTOUT`).
pub const FLAG_CUTOUT: u32 = 64;
/// The primitive's material is masked or blended: shadow walks test alpha (WGSL
/// `FLAG_CUTOUT_SHADOW`).
pub const FLAG_CUTOUT_SHADOW: u32 = 128;

/// [`Material::flags`] bit (WGSL `MATERIAL_TINTED_TRANSMISSION`): the refracted ray is
/// weighted by the base colour at the hit too (`scene::Material::tinted_transmission`).
pub const MATERIAL_TINTED_TRANSMISSION: u32 = 1;
/// [`Material::flags`] bit (WGSL `MATERIAL_MAPS`): the Whitted terms are evaluated per hit.
pub const MATERIAL_MAPS: u32 = 2;
/// [`Material::flags`] bit (WGSL `MATERIAL_BLEND`): hits let `1 − alpha` straight through.
pub const MATERIAL_BLEND: u32 = 4;

/// [`Light::kind`] codes (WGSL `LIGHT_*`).
pub const LIGHT_POINT: u32 = 0;
pub const LIGHT_SPOT: u32 = 1;
pub const LIGHT_DIRECTIONAL: u32 = 2;

/// Texture wrap modes in [`TextureInfo::flags`] (WGSL `WRAP_*`), and the bilinear bit.
pub const WRAP_REPEAT: u32 = 0;
pub const WRAP_MIRRORED_REPEAT: u32 = 1;
pub const WRAP_CLAMP_TO_EDGE: u32 = 2;
pub const TEX_BILINEAR: u32 = 16;
/// [`TextureInfo::flags`] bit (WGSL `TEX_SRGB`): colour channels are sRGB-encoded.
pub const TEX_SRGB: u32 = 32;

/// [`Params::aov`] codes (WGSL `AOV_*`): what the `aov` kernel writes.
pub const AOV_DEPTH: u32 = 0;
pub const AOV_NORMAL: u32 = 1;
pub const AOV_ID: u32 = 2;

/// Ray kinds (WGSL `RAY_*`): [`Pending::kind`] and the counter slots' order.
pub const RAY_EYE: u32 = 0;
pub const RAY_SHADOW: u32 = 1;
pub const RAY_REFLECT: u32 = 2;
pub const RAY_REFRACT: u32 = 3;
/// The kind bits of [`Pending::kind`].
pub const RAY_KIND_MASK: u32 = 3;
/// Set in [`Pending::kind`] when the ray need not test the primitive it leaves.
pub const RAY_SKIP_FROM: u32 = 4;
/// Where the depth starts in [`Pending::kind`].
pub const RAY_DEPTH_SHIFT: u32 = 8;
/// A spawned ray whose nearest hit (a shadow ray: the blocker that answered it) lies within
/// this many spawn offsets of its origin is a self-hit (`rays.self_hits`).
pub const SELF_HIT_SPAWNS: f32 = 4.0;

/// The `queues` words a tile starts from: every queue empty, dispatch arguments (0, 1, 1).
pub fn fresh_queues() -> [u32; QUEUE_WORDS as usize] {
    let mut w = [0u32; QUEUE_WORDS as usize];
    for q in 0..QUEUE_COUNT {
        let a = (QUEUE_ARGS + 3 * q) as usize;
        w[a + 1] = 1;
        w[a + 2] = 1;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresh_queues_are_empty_with_dispatch_arguments_x_1_1() {
        let w = fresh_queues();
        for q in 0..QUEUE_COUNT {
            assert_eq!(w[q as usize], 0);
            let a = (QUEUE_ARGS + 3 * q) as usize;
            assert_eq!(&w[a..a + 3], &[0, 1, 1]);
        }
        assert_eq!(w[QUEUE_OVERFLOW as usize], 0);
        const { assert!(QUEUE_ARGS + 3 * QUEUE_COUNT <= QUEUE_OVERFLOW) };
    }
}
