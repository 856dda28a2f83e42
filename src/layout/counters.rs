//! The kernels' statistics counters: 64-bit slots in the `counters` buffer (low word first),
//! and decoding them into [`crate::stats::Counters`] and the lane coherence ([`LaneStats`]). The slot
//! numbers are twins of the `C_*` and `LANE_*` constants in `shaders/shared/counters.wgsl`
//! (keep them in sync).

use super::structs::MAX_DEPTH;
use crate::stats::{LaneStats, Lanes};

/// Rays by kind: slot `C_RAYS + kind` (kinds `RAY_EYE` ... `RAY_REFRACT`).
pub const C_RAYS: u32 = 0;
/// Primitive tests by ray kind and primitive kind: slot `C_TESTS + 3·ray_kind + prim_kind`.
pub const C_TESTS: u32 = 4;
/// Eye rays that hit something.
pub const C_EYE_HIT: u32 = 16;
/// Shadow rays that were blocked.
pub const C_SHADOW_BLOCKED: u32 = 17;
/// Group bounding-sphere tests by ray kind: slot `C_BOUNDS + ray_kind`.
pub const C_BOUNDS: u32 = 18;
/// Spawned rays that hit within [`SELF_HIT_SPAWNS`](super::structs::SELF_HIT_SPAWNS) spawn
/// offsets of their origin.
pub const C_SELF_HITS: u32 = 22;
/// Slots of the counters proper.
pub const COUNTER_COUNT: u32 = 23;

/// Lane coherence by kernel ([`LANE_NEAREST`], [`LANE_SHADE`], [`LANE_SHADOW`]) and depth:
/// from slot `LANE_BASE + (kernel·MAX_DEPTH + depth − 1)·LANE_WORDS`, invocations with a
/// job, their loop iterations, groups of 8 with a job and the sum of their largest counts,
/// the same for groups of 32.
pub const LANE_NEAREST: u32 = 0;
pub const LANE_SHADE: u32 = 1;
pub const LANE_SHADOW: u32 = 2;
pub const LANE_BASE: u32 = COUNTER_COUNT;
pub const LANE_WORDS: u32 = 6;
pub const LANE_SLOTS: u32 = 3 * MAX_DEPTH * LANE_WORDS;

/// Bytes of the `counters` buffer.
pub const COUNTER_BYTES: u64 = (LANE_BASE + LANE_SLOTS) as u64 * 8;

fn slot(words: &[u32], i: u32) -> u64 {
    words[2 * i as usize] as u64 | (words[2 * i as usize + 1] as u64) << 32
}

/// The lane coherence from the bytes of the `counters` buffer: per kernel, the depths whose
/// passes had work.
pub fn decode_lanes(raw: &[u8]) -> LaneStats {
    let words: &[u32] = bytemuck::cast_slice(raw);
    let of = |kernel: u32| -> Vec<Lanes> {
        (1..=MAX_DEPTH)
            .filter_map(|depth| {
                let base = LANE_BASE + (kernel * MAX_DEPTH + depth - 1) * LANE_WORDS;
                let v: Vec<u64> = (0..LANE_WORDS).map(|k| slot(words, base + k)).collect();
                let mean = |sum: u64, n: u64| if n == 0 { 0.0 } else { sum as f64 / n as f64 };
                (v[0] > 0).then(|| Lanes {
                    depth,
                    invocations: v[0],
                    steps: mean(v[1], v[0]),
                    max8: mean(v[3], v[2]),
                    max32: mean(v[5], v[4]),
                })
            })
            .collect()
    };
    LaneStats { nearest: of(LANE_NEAREST), shade: of(LANE_SHADE), shadow: of(LANE_SHADOW) }
}

/// The counters from the bytes of the kernels' `counters` buffer.
pub fn decode_counters(raw: &[u8]) -> crate::stats::Counters {
    let words: &[u32] = bytemuck::cast_slice(raw);
    let slot = |i: u32| slot(words, i);
    let mut c = crate::stats::Counters::default();
    for k in 0..4 {
        c.rays[k as usize] = slot(C_RAYS + k);
        c.tests[k as usize].sphere = slot(C_TESTS + 3 * k);
        c.tests[k as usize].triangle = slot(C_TESTS + 3 * k + 1);
        c.tests[k as usize].cylinder = slot(C_TESTS + 3 * k + 2);
        c.tests[k as usize].bound = slot(C_BOUNDS + k);
    }
    c.eye_hit = slot(C_EYE_HIT);
    c.shadow_blocked = slot(C_SHADOW_BLOCKED);
    c.self_hits = slot(C_SELF_HITS);
    c
}
