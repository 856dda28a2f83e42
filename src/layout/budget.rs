//! What one invocation of a kernel pass may do: lavapipe's software compiler ends every loop
//! of an invocation once all of its loops have run 65535 iterations in total (a safety limit
//! in Mesa's gallivm), and real GPUs kill dispatches that run for seconds. So a pass walks
//! at most [`WALK_CHUNK`] entries of one job's list, traces the short shadow walks of a hit
//! inline ([`shadow_inline`]), and a tile holds a bounded number of grid points
//! ([`tile_points`]). [`check_loop_budget`] refuses a render whose passes could still pass
//! the limit, rather than letting it come out silently wrong.

use crate::arith::spawn::SpawnPolicy;
use crate::coherence::reach::WalkBounds;
use crate::coherence::walk::WALK_CHUNK;
use crate::coherence::BuildParams;
use crate::error::{Error, Result};
use crate::scene::{Effects, Scene};

use super::counters::COUNTER_COUNT;
pub use super::structs::MAX_DEPTH;
use super::structs::WORKGROUP;

/// Mesa's llvmpipe limit on the loop iterations of one invocation (all loops together).
pub const LAVAPIPE_LOOP_LIMIT: u64 = 65535;

/// Rough budget of primitive tests per eye sample and dispatch, which sets the tile size.
pub const TESTS_PER_DISPATCH: u64 = 1 << 24;

/// The most grid points per tile.
pub const MAX_TILE: u64 = 1 << 16;

/// Loop iterations per intersection test: a cylinder test loops over its two roots.
fn per_test(scene: &Scene) -> u64 {
    if scene.counts().cylinders > 0 {
        3
    } else {
        1
    }
}

/// Loop iterations an invocation spends besides its walks: the light loop, the counters'
/// flush, and a margin for the short loops of shading.
fn step_overhead(scene: &Scene) -> u64 {
    scene.lights.len() as u64 + COUNTER_COUNT as u64 + 16
}

/// Loop iterations of one chunk of a walk: [`WALK_CHUNK`] entries.
fn chunk_iterations(scene: &Scene) -> u64 {
    per_test(scene) * WALK_CHUNK as u64
}

/// Shadow walks of at most this many entries are traced by the `shade` invocation of the
/// hit (`Params::shadow_inline`): as many as keep it, with one whole chunk of a walk and
/// every light's inline walk, within lavapipe's loop limit. Longer walks become jobs of the
/// shadow queue.
pub fn shadow_inline(scene: &Scene) -> u32 {
    let lights = scene.lights.len() as u64;
    let step = chunk_iterations(scene) + step_overhead(scene);
    (LAVAPIPE_LOOP_LIMIT.saturating_sub(step) / (lights.max(1) * per_test(scene))) as u32
}

/// The BVH's inline shadow walks (`Params::bvh_inline`, with `--accel bvh` and for the rays
/// leaving surfaces with `--accel cube`): a budget of loop iterations (each a queued
/// primitive and perhaps a node), a quarter of what [`shadow_inline`] entries may take, less
/// the two groups of primitives a walk whose budget runs out tests before it stops. A quarter, because lavapipe ended these walks early
/// at half of it (measured with eight lights, nine thousand triangles and walks of thousands
/// of nodes: `bvh_walks_longer_than_a_step_resume` in `tests/it/gpu/accels.rs`): it counted more
/// iterations than the walk's (measured when each iteration was one box or one primitive;
/// a walk now takes fewer, so the budget has room). A walk that does not end within the
/// budget becomes a job and starts over; a BVH shadow walk takes tens of iterations, so
/// almost none do.
pub fn bvh_shadow_inline(scene: &Scene) -> u32 {
    let iterations = shadow_inline(scene) as u64 / 4;
    iterations.saturating_sub(2 * crate::bvh::WIDE_NODE_PRIMS as u64).min(u32::MAX as u64) as u32
}

/// Checks that no invocation of a kernel pass can pass lavapipe's loop limit; were one to
/// need more, the result would be silently wrong, so it is an error instead.
///
/// `walks`: the tables' bounds, or `None` for brute force. `max_depth`: `Some(_)` for the
/// wavefront kernels, whose invocations walk one job's list for at most [`WALK_CHUNK`]
/// iterations, brute force included, leaving the rest to later passes, plus the shadow walks
/// of at most [`shadow_inline`] entries that a hit traces at once. `None`: the `aov`
/// kernel, which walks an eye ray's whole list in one go.
pub fn check_loop_budget(scene: &Scene, walks: Option<&WalkBounds>, max_depth: Option<u32>) -> Result<()> {
    let c = scene.counts();
    let lights = scene.lights.len() as u64;
    let per_test = per_test(scene);
    let brute = (c.spheres + c.triangles + 3 * c.cylinders) as u64;
    let (closest, shadow, eye) = match walks {
        Some(t) => (per_test * t.worst_closest, per_test * t.worst_shadow, per_test * t.worst_eye),
        None => (brute, brute, brute),
    };
    let what = if walks.is_some() { "the longest candidate lists" } else { "brute force" };
    let steps = match max_depth {
        Some(_) => {
            let chunk = chunk_iterations(scene);
            let inline = lights * shadow.min(per_test * shadow_inline(scene) as u64);
            let pass = closest.max(shadow).min(chunk) + inline;
            // A shadow pass may run a chunk of a table walk and one of a BVH walk (half as
            // many iterations, which lavapipe may count twice) in one SIMD vector.
            if walks.is_some_and(|t| t.mixed) {
                pass.max(2 * chunk)
            } else {
                pass
            }
        }
        None => eye,
    };
    let worst = steps + step_overhead(scene);
    if worst > LAVAPIPE_LOOP_LIMIT {
        return Err(Error::Options(format!(
            "{what} over {} primitives and {lights} lights need up to {worst} loop iterations per \
             ray on lavapipe, which stops at {LAVAPIPE_LOOP_LIMIT}; render this scene with --backend cpu",
            scene.primitives.len()
        )));
    }
    Ok(())
}

/// Passes more than one that a walk of a render with these bounds (`None`: brute force,
/// whose every walk tests every primitive) is planned to need at [`WALK_CHUNK`] loop
/// iterations a pass ([`crate::gpu::schedule::WavePlan`], [`WalkBounds::planned`]); a tile
/// whose walk outlasts them runs again with one more.
pub fn retry_passes(scene: &Scene, walks: Option<&WalkBounds>) -> u32 {
    let worst = match walks {
        Some(t) => t.planned,
        None => scene.primitives.len() as u64,
    };
    worst.div_ceil(WALK_CHUNK as u64).saturating_sub(1) as u32
}

/// Grid points per tile for about `tests` primitive tests per dispatch: one step of a
/// point tests the candidates of its ray and of a shadow ray per light (brute force: every
/// primitive; with the tables, a rough mean).
pub fn tile_points(scene: &Scene, walks: Option<&WalkBounds>, tests: u64) -> u64 {
    let per_ray = match walks {
        Some(t) => t.mean_list.ceil() as u64 + 1,
        None => scene.primitives.len() as u64,
    };
    let work = per_ray * (1 + scene.lights.len() as u64);
    let tile = (tests / work.max(1)).clamp(256, MAX_TILE);
    tile.div_ceil(WORKGROUP as u64) * WORKGROUP as u64
}

/// How the kernels' tables are built: for the render's image and spawn policy, and only for
/// the rays kernels with `effects` trace.
pub fn table_params(
    scene: &Scene,
    width: u32,
    height: u32,
    effects: Effects,
    spawn: SpawnPolicy,
) -> BuildParams {
    let effects = Effects {
        shadows: effects.shadows,
        reflection: effects.reflection,
        refraction: effects.refraction,
        ..scene.effects()
    };
    BuildParams { image: Some((width, height)), spawn, effects: Some(effects), ..BuildParams::default() }
}
