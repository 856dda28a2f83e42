//! One preparation for every GPU render, without a device: from the scene, the options, what
//! the adapter offers ([`Capabilities`](super::choose::Capabilities)) and stored tables if any, [`prepare`] resolves every
//! option once ([`resolve`](super::choose::resolve): precision, accelerator, what rays leaving surfaces take), checks
//! what the kernels cannot trace, derives the kernels' variant ([`variant`], the one place
//! that does), packs the scene with its final [`Params`](crate::layout::Params) (per tile and
//! sample aside), builds the candidate tables or takes stored ones, adds the BVH or the ray
//! queries' boxes, bounds the walks, checks lavapipe's loop budget, and sizes the tiles and
//! queues ([`Prepared`]). `render`, `compare`, `bench`, `tables`, `accuracy` and the preview
//! all start here.

use std::time::Instant;

use super::buffers::{BufferSizes, QueueSizes};
use super::choose::{resolve, table_params, Capabilities};
use super::schedule::whole_groups;
use super::shaders::{Depths, Kernel, Stage, Variant};
use crate::coherence::reach::WalkBounds;
use crate::coherence::{self, BuildParams, FlatTables, OriginKey, Tables};
use crate::error::{Error, Result};
use crate::job::{Accel, KernelForm, Precision, RenderOptions, SurfaceWalk};
use crate::layout::budget::{self, check_loop_budget, MAX_DEPTH, TESTS_PER_DISPATCH};
use crate::layout::{pack, Packed};
use crate::output::Aov;
use crate::sampling::Sampling;
use crate::scene::{Effects, Scene};
use crate::tablefile::StoredTables;

/// What a preparation is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    /// A render of the image.
    Render,
    /// An auxiliary output from the eye ray through each pixel centre.
    Aov(Aov),
    /// The preview, simulating `effects` (the scene's, some switched off): its tables and
    /// queues serve every effect of the scene at any depth, so that switching one back on
    /// or deepening the trees needs none, and its rays leaving surfaces walk the BVH, whose
    /// boxes a camera move rewrites in place.
    Preview { effects: Effects },
}

/// The tables a render traces: built for it, or read from a file (`render --tables`), with
/// the bounds on their walks computed here.
// One per render: the size of its variants does not matter.
#[allow(clippy::large_enum_variant)]
pub enum TableSet {
    Built(Tables),
    Stored(StoredTables, WalkBounds),
}

impl TableSet {
    pub fn flat(&self) -> &FlatTables {
        match self {
            TableSet::Built(t) => &t.flat,
            TableSet::Stored(t, _) => &t.flat,
        }
    }

    pub fn walks(&self) -> &WalkBounds {
        match self {
            TableSet::Built(t) => &t.walks,
            TableSet::Stored(_, w) => w,
        }
    }

    /// The tables as built, when they were built here.
    pub fn built(self) -> Option<Tables> {
        match self {
            TableSet::Built(t) => Some(t),
            TableSet::Stored(..) => None,
        }
    }
}

/// A render prepared for the GPU: everything but the device's own objects.
pub struct Prepared {
    /// The options with every `auto` resolved ([`resolve`]).
    pub opts: RenderOptions,
    /// The kernels' variant, and the kernels with the depths each serves.
    pub variant: Variant,
    pub stages: Vec<Stage>,
    /// The scene packed, with its BVH or ray queries' boxes, and the final params (per tile
    /// and sample aside).
    pub packed: Packed,
    pub tables: Option<TableSet>,
    /// How long the kernels' walks may be (`None`: brute force).
    pub walks: Option<WalkBounds>,
    /// Retry passes planned per depth (see [`budget::retry_passes`]).
    pub retries: u32,
    /// The buffers' tile and queues.
    pub sizes: BufferSizes,
    /// Seconds the preparation took (packing, the tables and the BVH).
    pub preprocess_s: f64,
    /// Of those, the tables' build (0 with stored ones) and the BVH's.
    pub tables_s: f64,
    pub bvh_s: f64,
}

/// The kernels' variant of a render of `scene` with resolved `opts` that simulates `effects`
/// to `max_depth` with `accel` (the one place that derives a variant): the intersection code
/// of the scene's kinds of primitive only; the walk of rays leaving surfaces only if the
/// render traces such rays ([`coherence::traces_surface_rays`]: mirrors or glass, or shadow
/// rays towards a directional light), so that a scene lit by point lights alone, without
/// mirrors, gets table kernels without a BVH loop; the BVH's shadow walk only where a
/// directional light's shadow rays take it; counted if `opts` ask for the counts.
pub fn variant(
    scene: &Scene,
    opts: &RenderOptions,
    effects: Effects,
    max_depth: u32,
    accel: Accel,
) -> Variant {
    debug_assert!(accel != Accel::Auto, "a variant of an unresolved accelerator");
    let v = Variant::for_effects(effects, max_depth)
        .with_accel(accel)
        .with_f64(opts.precision == Precision::F64)
        .with_surface_rq(opts.surface == SurfaceWalk::RayQuery)
        .with_shapes(scene.shapes())
        .with_counters(opts.count);
    let params = table_params(scene, opts, v.effects);
    let bvh_shadows = coherence::untabled_lights(scene, &params);
    let v = v.with_surface_rays(coherence::traces_surface_rays(scene, &params)).with_bvh_shadows(bvh_shadows);
    // An eye without a table sends its rays where rays leaving surfaces go, whatever the
    // effects.
    Variant { surface_rays: v.surface_rays || eye_untabled(scene, opts), ..v }
}

/// Whether the eye of a non-empty `scene` rendered with `opts` has no table (`--accel auto`
/// left it without), its rays walking the BVH.
fn eye_untabled(scene: &Scene, opts: &RenderOptions) -> bool {
    opts.accel == Accel::Cube && opts.untabled.contains(&OriginKey::Eye) && !scene.primitives.is_empty()
}

/// The effects and depth a preparation for `purpose` simulates.
fn simulated(scene: &Scene, opts: &RenderOptions, purpose: Purpose) -> (Effects, u32) {
    match purpose {
        Purpose::Render => (scene.effects(), opts.max_depth),
        Purpose::Aov(_) => (Effects::default(), 1),
        Purpose::Preview { effects } => (effects, opts.max_depth),
    }
}

/// The effects and depth the tables and queues of a preparation for `purpose` serve: what
/// it simulates, or for the preview every effect of the scene at any depth.
fn served(scene: &Scene, opts: &RenderOptions, purpose: Purpose) -> (Effects, u32) {
    match purpose {
        Purpose::Preview { .. } => (scene.effects(), MAX_DEPTH),
        _ => simulated(scene, opts, purpose),
    }
}

/// The parameters the tables of a render of `scene` with `opts` for `purpose` are built
/// with, or `None` when it traces none: what `cuberay tables` builds, and what a stored table
/// file must have been built with. Resolves `opts` without an adapter (the tables do not
/// depend on one).
pub fn build_params(scene: &Scene, opts: &RenderOptions, purpose: Purpose) -> Result<Option<BuildParams>> {
    Ok(tables_of(scene, &resolve(scene, opts, None)?, purpose))
}

/// The variant a render of `scene` with `opts` for `purpose` runs, resolved without an
/// adapter (rays leaving surfaces take the BVH).
pub fn variant_for(scene: &Scene, opts: &RenderOptions, purpose: Purpose) -> Result<Variant> {
    let opts = resolve(scene, opts, None)?;
    let (effects, depth) = simulated(scene, &opts, purpose);
    Ok(variant(scene, &opts, effects, depth, opts.accel))
}

/// [`build_params`] for resolved `opts`.
pub fn tables_of(scene: &Scene, opts: &RenderOptions, purpose: Purpose) -> Option<BuildParams> {
    let (effects, depth) = served(scene, opts, purpose);
    let serves = variant(scene, opts, effects, depth, opts.accel);
    serves.cube().then(|| table_params(scene, opts, serves.effects))
}

/// What a render will run, decided before anything is built: the options resolved, the
/// kernels' variant and stages, and the variant whose tables and queues the buffers hold. The
/// kernels can be made from it while [`build`] builds the rest.
#[derive(Clone, Debug)]
pub struct Plan {
    pub opts: RenderOptions,
    pub purpose: Purpose,
    pub variant: Variant,
    pub stages: Vec<Stage>,
    /// The render's variant, or for the preview every effect of the scene at any depth.
    pub serves: Variant,
}

/// The plan of a render of `scene` with `opts` for `purpose` on the adapter `caps` describes,
/// from `stored` tables or not.
pub fn plan(
    scene: &Scene,
    opts: &RenderOptions,
    caps: &Capabilities,
    purpose: Purpose,
    stored: bool,
) -> Result<Plan> {
    // Stored tables cost no build, and a preview traces frame after frame: for both, every
    // table pays, and `auto` is `cube`.
    let every_table = stored || matches!(purpose, Purpose::Preview { .. });
    let mut opts = match opts.accel {
        Accel::Auto if every_table => {
            resolve(scene, &RenderOptions { accel: Accel::Cube, ..opts.clone() }, Some(caps))?
        }
        _ => resolve(scene, opts, Some(caps))?,
    };
    if matches!(purpose, Purpose::Preview { .. }) {
        opts.surface = SurfaceWalk::Bvh;
    }
    let (effects, depth) = simulated(scene, &opts, purpose);
    let split = prims_per_binding(scene, &opts, caps)?.is_some();
    let variant = Variant { split_prims: split, ..variant(scene, &opts, effects, depth, opts.accel) };
    let serves = match purpose {
        Purpose::Preview { .. } => self::variant(scene, &opts, scene.effects(), MAX_DEPTH, opts.accel),
        _ => variant,
    };
    let stages = match purpose {
        Purpose::Aov(_) => vec![Stage { kernel: Kernel::Aov, depths: Depths::All }],
        _ => Kernel::traced(opts.form, variant, eye_untabled(scene, &opts)),
    };
    Ok(Plan { opts, purpose, variant, stages, serves })
}

/// Prepares a render of `scene` with `opts` for `purpose` on the adapter `caps` describes,
/// building the tables it traces or taking `stored` ones (built with [`build_params`],
/// checked here): [`plan`], then [`build`].
pub fn prepare(
    scene: &Scene,
    opts: &RenderOptions,
    caps: &Capabilities,
    purpose: Purpose,
    stored: Option<StoredTables>,
) -> Result<Prepared> {
    build(scene, plan(scene, opts, caps, purpose, stored.is_some())?, caps, stored)
}

/// Builds what `plan` traces: the scene packed with its final params, the tables (or
/// `stored` ones, checked), the BVH or the ray queries' boxes, the walks' bounds, the loop
/// budget checked, the tiles and queues sized.
pub fn build(
    scene: &Scene,
    plan: Plan,
    caps: &Capabilities,
    stored: Option<StoredTables>,
) -> Result<Prepared> {
    let start = Instant::now();
    let Plan { opts, purpose, variant, stages, serves } = plan;
    let depth = simulated(scene, &opts, purpose).1;
    let mut packed = pack(scene, opts.width, opts.height, opts.spawn);
    if variant.f64 {
        packed.use_f64(scene, opts.spawn);
    }
    packed.params.set_prims_per_binding(prims_per_binding(scene, &opts, caps)?.unwrap_or(0));
    match serves.accel {
        Accel::Bvh => packed.add_bvh(scene),
        Accel::RayQuery => packed.add_rq(scene),
        Accel::Auto | Accel::Cube | Accel::Brute => {}
    }
    let tables = take_tables(scene, &opts, serves, &mut packed, stored)?;
    debug_assert!(
        variant.surface_rays || packed.params.surface_walk == 0,
        "the tables send rays leaving surfaces to kernels without their walk"
    );
    let walks = walk_bounds(tables.as_ref().map(TableSet::walks), &packed);
    // Lavapipe ends loops past its limit silently; one with ray queries (Mesa 24.1 and
    // later) has no such limit: Mesa 25.0 ran loops of 200,000 iterations whole.
    if caps.lavapipe && !variant.ray_queries() {
        let wavefront = (!matches!(purpose, Purpose::Aov(_))).then_some(depth);
        check_loop_budget(scene, walks.as_ref(), wavefront)?;
    }
    let traces = !matches!(purpose, Purpose::Aov(_));
    let queues = traces.then(|| queue_sizes(scene, serves));
    // No larger than the grid it traces: a small image allocates (and zeroes) no queues it
    // cannot fill, which cost a 64² render a third of its time.
    let points = match purpose {
        Purpose::Render => opts.grid_region().points(),
        Purpose::Aov(_) => opts.region().width() as u64 * opts.region().height() as u64,
        Purpose::Preview { .. } => opts.grid().0 as u64 * opts.grid().1 as u64,
    };
    let tile = budget::tile_points(scene, walks.as_ref(), TESTS_PER_DISPATCH).min(whole_groups(points));
    let mut sizes = BufferSizes::fit(tile, queues, traces, packed.job_bytes(), caps.max_binding);
    // The tree form keeps its rays in its invocations: no queues. Its tiles stay as the
    // queues allow: larger ones measured slower (mount_s6 on Mesa 25.0: 1.07×, its longest
    // dispatch 76 ms against 47).
    if opts.form == KernelForm::Tree {
        sizes = sizes.without_queues();
    }
    let job = match purpose {
        Purpose::Aov(_) => RenderOptions { spp: 1, sampling: Sampling::Pixels, max_depth: 1, ..opts.clone() },
        _ => opts.clone(),
    };
    packed.params = packed.params.with_job(&job);
    if let Purpose::Aov(aov) = purpose {
        packed.params.set_aov(aov);
    }
    packed.params.set_queues(sizes.ray_queue, sizes.shadow_queue);
    let tables_s = match &tables {
        Some(TableSet::Built(t)) => t.build_s,
        _ => 0.0,
    };
    Ok(Prepared {
        tables_s,
        bvh_s: packed.bvh_s,
        retries: budget::retry_passes(scene, walks.as_ref()),
        opts,
        variant,
        stages,
        packed,
        tables,
        walks,
        sizes,
        preprocess_s: start.elapsed().as_secs_f64(),
    })
}

/// The tables the kernels of `serves` trace: built here, or `stored` ones checked against
/// the scene (refused where the render traces none); `packed`'s params are pointed at them,
/// and the BVH or the ray queries' boxes are added where rays leaving surfaces take them.
fn take_tables(
    scene: &Scene,
    opts: &RenderOptions,
    serves: Variant,
    packed: &mut Packed,
    stored: Option<StoredTables>,
) -> Result<Option<TableSet>> {
    if !serves.cube() {
        return match stored {
            Some(_) => Err(Error::Options(format!(
                "stored tables are for --accel cube or auto; this render traces none (--accel {})",
                serves.accel.name()
            ))),
            None => Ok(None),
        };
    }
    let params = table_params(scene, opts, serves.effects);
    let set = match stored {
        Some(t) => {
            t.flat.check_scene(scene.primitives.len(), scene.lights.len())?;
            let walks = WalkBounds::of(scene, &t.flat, coherence::traces_surface_rays(scene, &params));
            add_surface_walk(packed, scene, &params, serves.surface_rq);
            TableSet::Stored(t, walks)
        }
        None => {
            // What the rays leaving surfaces walk is built beside the tables, which keep
            // every core busy only while several origins are left.
            let (t, ()) = rayon::join(
                || coherence::build(scene, &params),
                || add_surface_walk(packed, scene, &params, serves.surface_rq),
            );
            let t = t?;
            log::info!(
                "tables: {} origins, {} entries, longest lists {} (nearest) {} (shadow), fallback reachable: {}",
                t.flat.origins.len(),
                t.flat.entries.len(),
                t.walks.worst_closest,
                t.walks.worst_shadow,
                t.walks.fallback_reachable
            );
            TableSet::Built(t)
        }
    };
    packed.params.point_at_tables(set.flat());
    Ok(Some(set))
}

/// The checks a render runs on stored tables before it uploads them, without a device: for
/// tests and the tables file's fuzz target.
pub fn check_stored(scene: &Scene, opts: &RenderOptions, t: &StoredTables) -> Result<()> {
    let opts = resolve(scene, opts, None)?;
    let serves = variant(scene, &opts, scene.effects(), opts.max_depth, opts.accel);
    let mut packed = pack(scene, opts.width, opts.height, opts.spawn);
    take_tables(scene, &opts, serves, &mut packed, Some(t.clone())).map(|_| ())
}

/// Adds what the rays leaving surfaces take, if the render the tables were built for (with
/// `params`) traces such rays: the BVH, or with `rq` the ray queries' boxes; else leaves
/// `packed` alone.
pub fn add_surface_walk(packed: &mut Packed, scene: &Scene, params: &BuildParams, rq: bool) {
    if coherence::traces_surface_rays(scene, params) {
        if rq {
            packed.add_rq(scene);
        } else {
            packed.add_bvh(scene);
        }
        packed.params.set_surface_walk(true);
    }
}

/// How long the walks of a render with `tables` (`None`: none) and `packed`'s BVH or ray
/// queries' boxes (if any) may be: with both, rays leaving surfaces take the latter.
pub fn walk_bounds(tables: Option<&WalkBounds>, packed: &Packed) -> Option<WalkBounds> {
    let surface = match (&packed.bvh, &packed.rq) {
        (Some(b), _) => Some(b.walk_bounds()),
        (None, Some(r)) => Some(crate::layout::rayquery::walk_bounds(r)),
        (None, None) => None,
    };
    match (tables, surface) {
        (Some(t), Some(b)) => Some(t.or(&b)),
        (t, b) => t.copied().or(b),
    }
}

/// The wavefront's queues per point of a tile for `scene` with `variant`: one ray per depth
/// and point without glass or blended surfaces (reflection does not branch), four with them
/// (a tile whose rays branch further overflows and runs again in halves), and a shadow ray
/// per light.
pub fn queue_sizes(scene: &Scene, variant: Variant) -> QueueSizes {
    QueueSizes {
        rays_per_point: if variant.effects.refraction || variant.effects.blend { 4 } else { 1 },
        shadows_per_ray: if variant.effects.shadows { scene.lights.len().max(1) as u32 } else { 0 },
    }
}

/// The most bindings the primitives are split over (`SPLIT_PRIMS`: bindings 1 and 26–28).
const PRIM_BINDINGS: u64 = 4;

/// How many primitives each binding holds where one binding of the adapter `caps` describes
/// cannot hold them all (`None`: it can); refuses, before anything is built, a scene whose
/// primitives need more than [`PRIM_BINDINGS`] bindings.
fn prims_per_binding(scene: &Scene, opts: &RenderOptions, caps: &Capabilities) -> Result<Option<u32>> {
    let size = match opts.precision {
        Precision::F64 => std::mem::size_of::<crate::layout::Prim64>(),
        _ => std::mem::size_of::<crate::layout::Prim>(),
    } as u64;
    let n = scene.primitives.len() as u64;
    if n * size <= caps.max_binding {
        return Ok(None);
    }
    let per = caps.max_binding / size;
    if n > PRIM_BINDINGS * per {
        return Err(Error::Options(format!(
            "the scene's {n} primitives need {} bytes on the GPU ({size} each, {}), more than {PRIM_BINDINGS} \
             bindings of {}'s {} bytes hold; render it with --backend cpu",
            n * size,
            opts.precision.name(),
            caps.adapter,
            caps.max_binding
        )));
    }
    Ok(Some(per.min(u32::MAX as u64) as u32))
}
