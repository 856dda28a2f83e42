//! The kernels' statistics counters: 64-bit slots in the `counters` buffer (low word first),
//! and decoding them into [`Counters`]. The slot numbers are twins of the `C_*` constants in
//! `shaders/shared/layout.wgsl` (keep them in sync).

use crate::stats::Counters;

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
/// Slots in all.
pub const COUNTER_COUNT: u32 = 23;

/// Bytes of the `counters` buffer.
pub const COUNTER_BYTES: u64 = COUNTER_COUNT as u64 * 8;

/// The counters from the bytes of the kernels' `counters` buffer.
pub fn decode_counters(raw: &[u8]) -> Counters {
    let words: &[u32] = bytemuck::cast_slice(raw);
    let slot = |i: u32| words[2 * i as usize] as u64 | (words[2 * i as usize + 1] as u64) << 32;
    let mut c = Counters::default();
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
