// The statistics counters: their slots, the lane coherence's slots, the buffer they are
// summed into, and the functions the kernels count with. Keep in sync with
// src/layout/counters.rs: each constant here has one Rust twin of the same name, and
// tests/it/twins.rs compares them.

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

@group(0) @binding(8) var<storage, read_write> counters: array<atomic<u32>>;

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
