// The wavefront kernels' rays, jobs and queues, shared with the host: a ray of a ray tree
// (`Pending`), a job in a queue with its walk's state, the pass descriptor, the queues and
// their bindings, and each tile point's radiance, summed in fixed point. Keep in sync with
// src/layout/structs.rs (the walks' constants: src/coherence/walk.rs): each struct and
// constant here has one Rust twin of the same name, and tests/it/twins.rs compares them.

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

// The queues' jobs, and their lengths and dispatch arguments.
@group(0) @binding(9) var<storage, read_write> jobs: array<Job>;
@group(0) @binding(10) var<storage, read_write> queues: array<atomic<u32>, QUEUE_WORDS>;
// The current pass.
@group(0) @binding(22) var<storage, read> pass_desc: PassDesc;
// Each tile point's radiance, summed exactly in 64-bit fixed point: per channel a low and
// a high word (add_radiance), turned into `out_color` by the `resolve` kernel.
@group(0) @binding(23) var<storage, read_write> accum: array<atomic<u32>>;

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
    // The jobs' slots are handed out densely from 0, so the dispatch covers them all once
    // each job that opens a workgroup widens it: one atomic in WORKGROUP pushes, not each.
    if i % WORKGROUP == 0u {
        atomicMax(&queues[QUEUE_ARGS + 3u * q], i / WORKGROUP + 1u);
    }
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

// Radiance in the accumulator's units, per channel: the 64-bit fixed-point value with 32
// fractional bits as its low and high words. `v` is split into whole and fractional parts,
// both exact in f32; values under 2^-8 lose their bits below 2^-32.
struct Fixed {
    lo: vec3<u32>,
    hi: vec3<u32>,
}

// `v` in the accumulator's units.
fn to_fixed(v: vec3<f32>) -> Fixed {
    let whole = floor(v);
    return Fixed(vec3<u32>((v - whole) * ACCUM_ONE), bitcast<vec3<u32>>(vec3<i32>(whole)));
}

// `a + b`, exact (the 64-bit sums wrap as the accumulator's atomics do, so any order of
// additions gives the same words).
fn fixed_sum(a: Fixed, b: Fixed) -> Fixed {
    let lo = a.lo + b.lo;
    return Fixed(lo, a.hi + b.hi + select(vec3<u32>(0u), vec3<u32>(1u), lo < a.lo));
}

// Adds `f` to tile point `point`'s radiance: two atomics per channel that is not zero. A
// kernel that adds several values to one point sums them first (`fixed_sum`): the
// accumulator's sum is exact, so the result is the same to the bit, for fewer atomics.
fn add_fixed(point: u32, f: Fixed) {
    for (var c = 0u; c < 3u; c++) {
        if f.lo[c] != 0u || f.hi[c] != 0u {
            let w = 6u * (point & ~POINT_UNOWNED) + 2u * c;
            let old = atomicAdd(&accum[w], f.lo[c]);
            atomicAdd(&accum[w + 1u], f.hi[c] + select(0u, 1u, old + f.lo[c] < old));
        }
    }
}

// Adds `v` to tile point `point`'s radiance, in 64-bit fixed point with 32 fractional bits:
// exact, so the sum does not depend on the order of the additions (the wavefront's order is
// not the ray trees').
fn add_radiance(point: u32, v: vec3<f32>) {
    add_fixed(point, to_fixed(v));
}
