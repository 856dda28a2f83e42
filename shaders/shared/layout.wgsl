// Shared declarations of every kernel: the structs, constants and bindings shared with the
// host, and the per-invocation counters. Coordinates are re-centred on the camera.
// Keep in sync with src/layout/structs.rs and src/layout/counters.rs: each struct and
// constant here has one Rust twin of the same name, and tests/it/twins.rs compares them.

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
    // --accel bvh: the nodes of one threaded order of the BVH (bvh.wgsl).
    bvh_stride: u32,
    // The wavefront's queues: jobs each ray queue and each shadow queue holds.
    ray_queue: u32,
    shadow_queue: u32,
    // --accel cube: 1 when rays leaving surfaces walk the BVH (the render traces some).
    surface_bvh: u32,
    // The BVH's inline shadow walks: a budget of loop iterations (nodes and primitives).
    bvh_inline: u32,
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
    pad0: u32,
    pad1: u32,
    pad2: u32,
    base: TexRef,
    metallic_roughness: TexRef,
    emissive: TexRef,
    transmission_map: TexRef,
    normal: TexRef,
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

// A ray of a grid point's ray tree, with the weight its radiance counts with. A shadow ray
// (kind RAY_SHADOW) keeps its light's index in place of the depth and, in `weight`, what
// the light adds unless blocked. Fields: `kind`: the ray kind (bits 0-1, RAY_KIND_MASK);
// RAY_SKIP_FROM: `from_prim` need not be tested (the ray leaves a triangle, or a sphere
// outwards); from bit RAY_DEPTH_SHIFT on, the ray's depth (the eye ray: 1), or a shadow
// job's light (`job_depth`). `spawn`: how far `o` was moved off the surface it leaves (0 for
// the eye): a hit nearer than SELF_HIT_SPAWNS of these is counted as a self-hit.
// `from_prim`: the primitive the ray leaves (the eye: 0xffffffff).
#if F64
struct Pending64 {
    o: vec3<f64>,
    kind: u32,
    pad0: u32,
    d: vec3<f32>,
    spawn: f32,
    weight: vec3<f32>,
    from_prim: u32,
}
alias Pending = Pending64;
#else
struct Pending {
    o: vec3<f32>,
    kind: u32,
    d: vec3<f32>,
    spawn: f32,
    weight: vec3<f32>,
    from_prim: u32,
}
#endif

// A new pending ray.
fn new_pending(o: vec3r, kind: u32, d: vec3<f32>, spawn: f32, weight: vec3<f32>, from_prim: u32) -> Pending {
#if F64
    return Pending64(o, kind, 0u, d, spawn, weight, from_prim);
#else
    return Pending(o, kind, d, spawn, weight, from_prim);
#endif
}

// The deepest ray tree the kernels trace (--max-depth, checked on the CPU).
const MAX_DEPTH: u32 = 16u;

// Loop iterations a pass spends on one walk, at most: lavapipe ends an invocation's loops after 65535 iterations in all, so a long
// candidate list (or brute force's every primitive) is walked over several passes, its
// position kept in the job (`Job::walk`). Twin: src/coherence/walk.rs.
const WALK_CHUNK: u32 = 8192u;

// The budget of a walk that runs to its end in one go (the `aov` kernel, inline shadow
// walks).
const UNBOUNDED: u32 = 0xffffffffu;

// Answers of a bounded any-hit walk (coherence::walk::AnyHit).
const ANY_CLEAR: u32 = 0u;
const ANY_BLOCKED: u32 = 1u;
const ANY_UNFINISHED: u32 = 2u;

// A walk interrupted at the end of a pass: the merged lists' positions (`--accel cube`;
// brute force: `i` the next primitive; the BVH: `i` the node, `j..jend` a leaf's primitives
// left) and, for a nearest-hit walk, the winner so far (prim NO_ID: none yet) with the tie
// rule's window and least t (closest.wgsl `Closest`). A job in the hit queue keeps its hit
// here.
struct WalkState {
    i: u32,
    iend: u32,
    j: u32,
    jend: u32,
    prim: u32,
    t: f32,
    b1: f32,
    b2: f32,
    window: f32,
    t_min: f32,
}

// A job's `walking`: its walk not started, resumed, or resumed after the tie rule lost the
// winner (the walk is run again once over: query.wgsl).
const WALK_START: u32 = 0u;
const WALK_RESUME: u32 = 1u;
const WALK_RESUME_LOST: u32 = 2u;

// A ray in a queue of the wavefront kernels (src/gpu/schedule.rs): the ray, the tile point
// whose radiance it adds to (bit POINT_UNOWNED set: the point lies outside the part of the
// image the window owns, and its rays are not counted), and its walk when a pass ended it
// unfinished (`walking` not WALK_START).
#if F64
struct Job64 {
    ray: Pending64,
    point: u32,
    walking: u32,
    walk: WalkState,
    // Pending64 aligns the struct to 32 bytes: the padding, spelt out for the twin.
    pad: array<u32, 4>,
}
alias Job = Job64;
#else
struct Job {
    ray: Pending,
    point: u32,
    walking: u32,
    walk: WalkState,
}
#endif

// What one pass of the wavefront kernels does, copied into `pass_desc` before its dispatch:
// the queue it works through (`src`), where the jobs it makes go (`hit`: rays whose nearest
// hit was found, to be shaded; `next`: secondary rays; `shadow`: shadow rays whose walks are
// too long to trace inline; `retry`: rays whose walk goes on in a later pass), the sample
// the wave traces and the depth of the rays it works on (the eye's: 1; the lane counters
// are kept by depth). A `src` of SRC_EYE names the tile's eye rays of that sample, made by
// the pass itself (the first pass of a wave).
struct PassDesc {
    src: u32,
    next: u32,
    shadow: u32,
    retry: u32,
    sample: u32,
    hit: u32,
    depth: u32,
    pad1: u32,
}

// The queues (QUEUE_* slots of `queues`): two of rays to trace, by depth in turn; two of
// rays whose walk goes on, in turn; rays whose nearest hit is found (the hit in the job's
// walk state), to shade; shadow rays; two of shadow rays whose walk goes on.
// Queue q holds its jobs at jobs[queue_base(q) ..], at most queue_cap(q) of them.
const QUEUE_RAY0: u32 = 0u;
const QUEUE_RAY1: u32 = 1u;
const QUEUE_RETRY0: u32 = 2u;
const QUEUE_RETRY1: u32 = 3u;
const QUEUE_HIT: u32 = 4u;
const QUEUE_SHADOW: u32 = 5u;
const QUEUE_SRETRY0: u32 = 6u;
const QUEUE_SRETRY1: u32 = 7u;
const QUEUE_COUNT: u32 = 8u;
const SRC_EYE: u32 = 0xffffffffu;
// `queues` holds the queues' lengths (words 0..QUEUE_COUNT), then each queue's indirect
// dispatch arguments (x, y, z) from word QUEUE_ARGS + 3q, then the overflow word
// (QUEUE_OVERFLOW): OVERFLOW_FULL when a push found its queue full (the host then runs the
// tile again with smaller waves), OVERFLOW_UNFINISHED when a walk went on past the last pass
// of its depth (a push to a queue numbered QUEUE_COUNT or more: again, with more passes).
const QUEUE_ARGS: u32 = 8u;
const QUEUE_OVERFLOW: u32 = 32u;
const QUEUE_WORDS: u32 = 36u;
const OVERFLOW_FULL: u32 = 1u;
const OVERFLOW_UNFINISHED: u32 = 2u;

// Set in Job::point for a point the window does not own.
const POINT_UNOWNED: u32 = 0x80000000u;

// `params` is a read-only storage buffer, not a uniform: lavapipe specialises a shader on
// the values of uniforms that steer its control flow ("inlined uniforms") and compiles a
// new variant for every new set of values. The tile's first point changes with every tile,
// so a uniform `params` made one compiled variant per tile, each kept until the device goes:
// memory grew with every tile (gears_s4 by brute force at 64x64: 0.2 to 5.6 GB in two
// minutes) and every tile paid a compile or a cache load.
@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> prims: array<Prim>;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> tri_attrs: array<TriAttr>;
@group(0) @binding(5) var<storage, read> texture_infos: array<TextureInfo>;
@group(0) @binding(6) var<storage, read> texels: array<u32>;
@group(0) @binding(7) var<storage, read_write> out_color: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> counters: array<atomic<u32>>;
// The queues' jobs, and their lengths and dispatch arguments.
@group(0) @binding(9) var<storage, read_write> jobs: array<Job>;
@group(0) @binding(10) var<storage, read_write> queues: array<atomic<u32>, QUEUE_WORDS>;
// The current pass.
@group(0) @binding(22) var<storage, read> pass_desc: PassDesc;
// Each tile point's radiance, summed exactly in 64-bit fixed point: per channel a low and
// a high word (add_radiance), turned into `out_color` by the `resolve` kernel.
@group(0) @binding(23) var<storage, read_write> accum: array<atomic<u32>>;

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

const RAY_EYE: u32 = 0u;
const RAY_SHADOW: u32 = 1u;
const RAY_REFLECT: u32 = 2u;
const RAY_REFRACT: u32 = 3u;
const RAY_KIND_MASK: u32 = 3u;
const RAY_SKIP_FROM: u32 = 4u;
const RAY_DEPTH_SHIFT: u32 = 8u;

// The depth of a pending ray (a shadow job: its light).
fn job_depth(job: Pending) -> u32 {
    return job.kind >> RAY_DEPTH_SHIFT;
}

// A spawned ray whose nearest hit (a shadow ray: the blocker that answered it) lies within
// this many spawn offsets of its origin is a self-hit (C_SELF_HITS): acne on the surface it
// leaves or on a neighbour. A ray refracted through a shell thinner than this counts too.
const SELF_HIT_SPAWNS: f32 = 4.0;

// Counter slots: rays by kind (C_RAYS + kind), tests by ray kind x primitive kind
// (C_TESTS + 3 * ray kind + primitive kind), eye hits, blocked shadow rays, bound tests
// (the BVH's nodes) by ray kind (C_BOUNDS + kind), self-hits of spawned rays. Each is 64-bit in
// `counters` (low, high word).
const C_RAYS: u32 = 0u;
const C_TESTS: u32 = 4u;
const C_EYE_HIT: u32 = 16u;
const C_SHADOW_BLOCKED: u32 = 17u;
const C_BOUNDS: u32 = 18u;
const C_SELF_HITS: u32 = 22u;
const COUNTER_COUNT: u32 = 23u;

// Lane coherence, by wavefront kernel (LANE_NEAREST, LANE_SHADE, LANE_SHADOW) and depth
// (1..=MAX_DEPTH): from slot LANE_BASE + (kernel · MAX_DEPTH + depth − 1) · LANE_WORDS, the
// invocations that had work, their loop iterations (walk steps; in `shade`, light
// iterations and inline shadow-walk steps), then for groups of 8 and of 32 neighbouring
// invocations (lavapipe's SIMD width, a real GPU's warp) the groups with work and the sum
// of each group's largest count: what a group pays when its lanes run in lockstep.
const LANE_NEAREST: u32 = 0u;
const LANE_SHADE: u32 = 1u;
const LANE_SHADOW: u32 = 2u;
const LANE_BASE: u32 = 23u;
const LANE_WORDS: u32 = 6u;
const LANE_SLOTS: u32 = 288u;

// The largest finite f32: the open end of an unbounded ray (no infinity is used).
const FAR: f32 = 3.4028235e38;

// "No primitive".
const NO_ID: u32 = 0xffffffffu;

// Shadow rays of a positional light, traced from the light, end this relative distance
// before the point they are cast for (f32; `shadow_ray`, geometry.wgsl).
const SHADOW_END_REL: f32 = 9.5367431640625e-7;


// The statistics counters (`COUNTERS`; `--stats`). Without them the functions below do
// nothing: on lavapipe the private array, indexed per lane at every test, and the flush's
// workgroup atomics cost a kernel 5-22 % of its time.
#if COUNTERS
var<private> local_counts: array<u32, COUNTER_COUNT>;
var<workgroup> group_counts: array<atomic<u32>, COUNTER_COUNT>;
// This invocation's loop iterations, and each group's largest (8 groups of 8, 2 of 32).
var<private> lane_steps: u32;
var<workgroup> lane_max: array<atomic<u32>, 10>;
#endif

fn count(slot: u32) {
#if COUNTERS
    local_counts[slot] += 1u;
#endif
}

fn count_test(ray_kind: u32, prim_kind: u32) {
#if COUNTERS
    local_counts[C_TESTS + ray_kind * 3u + prim_kind] += 1u;
#endif
}

fn count_bound(ray_kind: u32) {
#if COUNTERS
    local_counts[C_BOUNDS + ray_kind] += 1u;
#endif
}

// One loop iteration of this invocation (lane coherence).
fn count_step() {
#if COUNTERS
    lane_steps += 1u;
#endif
}

// Adds `v` to the 64-bit counter slot `slot`.
fn add_slot(slot: u32, v: u32) {
#if COUNTERS
    if v != 0u {
        let old = atomicAdd(&counters[2u * slot], v);
        if old + v < old {
            atomicAdd(&counters[2u * slot + 1u], 1u);
        }
    }
#endif
}

// Adds this workgroup's lane coherence to kernel `kernel`'s slots at the pass's depth;
// `busy`: the invocation had a job. Called once by every invocation, in uniform control
// flow. The invocations with work are a prefix of the dispatch, so a group has work when
// its first lane has.
fn flush_lanes(lid: u32, busy: bool, kernel: u32) {
#if COUNTERS
    if lid < 10u {
        atomicStore(&lane_max[lid], 0u);
    }
    workgroupBarrier();
    if busy {
        atomicMax(&lane_max[lid / 8u], lane_steps);
        atomicMax(&lane_max[8u + lid / 32u], lane_steps);
    }
    workgroupBarrier();
    let base = LANE_BASE + (kernel * MAX_DEPTH + min(max(pass_desc.depth, 1u), MAX_DEPTH) - 1u) * LANE_WORDS;
    if busy {
        add_slot(base, 1u);
        add_slot(base + 1u, lane_steps);
        if lid % 8u == 0u {
            add_slot(base + 2u, 1u);
            add_slot(base + 3u, atomicLoad(&lane_max[lid / 8u]));
        }
        if lid % 32u == 0u {
            add_slot(base + 4u, 1u);
            add_slot(base + 5u, atomicLoad(&lane_max[8u + lid / 32u]));
        }
    }
#endif
}

// The grid point of window point `point` (row-major in the window), and whether the window
// owns it (counts its rays: the corners on a window's far edges belong to its neighbour).
fn window_point(point: u32) -> vec3<u32> {
    let li = point % params.win_w;
    let lj = point / params.win_w;
    return vec3<u32>(params.win_x + li, params.win_y + lj, u32(li < params.own_w && lj < params.own_h));
}

// Forgets what this invocation counted (a point its window does not own).
fn drop_counts() {
#if COUNTERS
    for (var i = 0u; i < COUNTER_COUNT; i++) {
        local_counts[i] = 0u;
    }
#endif
}

// Sums the invocations' counters per workgroup, then adds them to the 64-bit totals.
// Called once by every invocation, in uniform control flow.
fn flush_counters(lid: u32) {
#if COUNTERS
    if lid < COUNTER_COUNT {
        atomicStore(&group_counts[lid], 0u);
    }
    workgroupBarrier();
    for (var i = 0u; i < COUNTER_COUNT; i++) {
        if local_counts[i] != 0u {
            atomicAdd(&group_counts[i], local_counts[i]);
        }
    }
    workgroupBarrier();
    if lid < COUNTER_COUNT {
        add_slot(lid, atomicLoad(&group_counts[lid]));
    }
#endif
}


// Where queue `q`'s jobs start in `jobs`, and how many it holds at most: the ray queues
// (and the hit queue) take params.ray_queue each, the shadow queues params.shadow_queue.
fn queue_base(q: u32) -> u32 {
    if q < QUEUE_SHADOW {
        return q * params.ray_queue;
    }
    return QUEUE_SHADOW * params.ray_queue + (q - QUEUE_SHADOW) * params.shadow_queue;
}

fn queue_cap(q: u32) -> u32 {
    return select(params.shadow_queue, params.ray_queue, q < QUEUE_SHADOW);
}

// How many jobs queue `q` holds.
fn queue_len(q: u32) -> u32 {
    return min(atomicLoad(&queues[q]), queue_cap(q));
}

// Appends `job` to queue `q` and widens its dispatch to cover it. A full queue drops the
// job and raises OVERFLOW_FULL; no queue (`q` QUEUE_COUNT or more: the last pass of a
// depth has no retry queue) drops it and raises OVERFLOW_UNFINISHED.
fn push_job(q: u32, job: Job) {
    if q >= QUEUE_COUNT {
        atomicOr(&queues[QUEUE_OVERFLOW], OVERFLOW_UNFINISHED);
        return;
    }
    let i = atomicAdd(&queues[q], 1u);
    if i >= queue_cap(q) {
        atomicOr(&queues[QUEUE_OVERFLOW], OVERFLOW_FULL);
        return;
    }
    jobs[queue_base(q) + i] = job;
    atomicMax(&queues[QUEUE_ARGS + 3u * q], i / WORKGROUP + 1u);
}

// A new job for ray `ray` of tile point `point` (its walk not started).
fn new_job(ray: Pending, point: u32) -> Job {
    let walk = WalkState(0u, 0u, 0u, 0u, NO_ID, 0.0, 0.0, 0.0, 0.0, 0.0);
#if F64
    return Job64(ray, point, WALK_START, walk, array<u32, 4>(0u, 0u, 0u, 0u));
#else
    return Job(ray, point, WALK_START, walk);
#endif
}

// The radiance scale of `accum`: 2^32 fixed-point units per unit.
const ACCUM_ONE: f32 = 4294967296.0;

// Adds `v` to channel `c` of tile point `point`'s radiance, in 64-bit fixed point with 32
// fractional bits: exact, so the sum does not depend on the order of the additions (the
// wavefront's order is not the ray trees'). `v` is split into whole and fractional parts,
// both exact in f32; values under 2^-8 lose their bits below 2^-32.
fn add_channel(point: u32, c: u32, v: f32) {
    let whole = floor(v);
    let hi = bitcast<u32>(i32(whole));
    let lo = u32((v - whole) * ACCUM_ONE);
    let w = 6u * (point & ~POINT_UNOWNED) + 2u * c;
    let old = atomicAdd(&accum[w], lo);
    atomicAdd(&accum[w + 1u], hi + select(0u, 1u, old + lo < old));
}

fn add_radiance(point: u32, v: vec3<f32>) {
    for (var c = 0u; c < 3u; c++) {
        if v[c] != 0.0 {
            add_channel(point, c, v[c]);
        }
    }
}
