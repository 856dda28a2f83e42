//! What a render asks of the GPU before anything runs, from the scene and the render
//! options alone (no device): the kernel variant and the candidate tables' parameters (the
//! one place that derives them), the checks that refuse what the kernels cannot trace
//! (depth, size, numbers beyond f32), the queues' sizes, and how packed params point at the
//! tables and the BVH.

use super::buffers::QueueSizes;
use super::shaders::{Queries, Variant};
use super::GpuRenderer;
use crate::coherence::reach::WalkBounds;
use crate::coherence::{self, BuildParams, FlatTables};
use crate::error::{Error, Result};
use crate::job::{AccelKind, Precision, RenderOptions, SurfaceWalk};
use crate::layout::budget::{table_params, MAX_DEPTH};
use crate::layout::Packed;
use crate::scene::{Effects, LightKind, Scene};

impl GpuRenderer {
    /// The kernels' variant for a job with `effects` at `max_depth`.
    pub fn variant(effects: Effects, max_depth: u32, accel: AccelKind) -> Variant {
        Variant::for_effects(effects, max_depth).with_queries(queries(accel))
    }

    /// The variant of a render (`aov`: the AOV pass, which traces eye rays only, so its
    /// kernel and tables have no effects).
    pub fn job_variant(scene: &Scene, opts: &RenderOptions, aov: bool) -> Variant {
        let effects = if aov { Effects::default() } else { scene.effects() };
        let depth = if aov { 1 } else { opts.max_depth };
        let v = Self::variant(effects, depth, opts.accel)
            .with_f64(opts.precision_for(scene) == Precision::F64)
            .with_surface_rq(opts.surface == SurfaceWalk::RayQuery);
        Self::for_scene(scene, opts, v)
    }

    /// `variant` narrowed to what `scene` holds and traces, counted if `opts` ask for the
    /// counts: the intersection code of its kinds of primitive only, and the walk of rays
    /// leaving surfaces only if the render traces such rays
    /// (`coherence::traces_surface_rays`: mirrors or glass, or shadow rays towards a
    /// directional light), so that a scene lit by point lights alone, without mirrors, gets
    /// table kernels without a BVH loop; and the BVH's shadow walk only where a directional
    /// light's shadow rays take it.
    pub fn for_scene(scene: &Scene, opts: &RenderOptions, variant: Variant) -> Variant {
        let variant = variant.with_shapes(scene.shapes()).with_counters(opts.count);
        let params = Self::variant_build_params(scene, opts, variant);
        let directional = scene.lights.iter().any(|l| l.kind == LightKind::Directional);
        variant
            .with_surface_rays(coherence::traces_surface_rays(scene, &params))
            .with_bvh_shadows(directional)
    }

    /// The parameters the render of `scene` with `opts` builds its tables with (`aov`: the
    /// AOV pass), or `None` when it traces none: what `cuberay tables` builds, and what a
    /// stored table file must have been built with.
    pub fn build_params(scene: &Scene, opts: &RenderOptions, aov: bool) -> Option<BuildParams> {
        let variant = Self::job_variant(scene, opts, aov);
        variant.tables().then(|| Self::variant_build_params(scene, opts, variant))
    }

    /// The parameters of the tables for the kernels of `variant` (all its effects) with
    /// `opts`: the one place that turns render options into a table build.
    pub fn variant_build_params(scene: &Scene, opts: &RenderOptions, variant: Variant) -> BuildParams {
        let p = table_params(scene, opts.width, opts.height, variant.effects(), opts.spawn);
        BuildParams { eye_n: opts.eye_cells, ..p }
    }
}

/// The wavefront's queues per point of a tile for `scene` with `variant`: one ray per depth
/// and point without glass or blended surfaces (reflection does not branch), four with them
/// (a tile whose rays branch further overflows and runs again in halves), and a shadow ray
/// per light.
pub fn queue_sizes(scene: &Scene, variant: Variant) -> QueueSizes {
    QueueSizes {
        rays_per_point: if variant.refraction || variant.blend { 4 } else { 1 },
        shadows_per_ray: if variant.shadows { scene.lights.len().max(1) as u32 } else { 0 },
    }
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
        packed.params.surface_walk = 1;
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

/// Points the params at the tables' eye and fallback origins.
pub fn point_at(params: &mut crate::layout::Params, flat: &FlatTables) {
    params.eye_origin = flat.eye_origin;
    params.fallback_origin = flat.fallback_origin;
}

/// The queries the GPU traces rays with for `accel`: `cube` and `auto` the candidate tables.
pub fn queries(accel: AccelKind) -> Queries {
    match accel {
        AccelKind::Auto | AccelKind::Cube => Queries::Tables,
        AccelKind::Bvh => Queries::Bvh,
        AccelKind::Brute => Queries::Brute,
        AccelKind::RayQuery => Queries::RayQuery,
    }
}

/// Whether rays leaving surfaces go to ray queries by default on the adapter of `ctx`
/// (which has them): everywhere but on lavapipe, whose software walk of its structure took
/// 0.98–3.5× the wide BVH's time for those rays on Mesa 25.0 (docs/performance.md, "ray
/// queries"). A GPU walks it in hardware, which is what ray queries are for.
fn ray_queries_measured_faster(ctx: &super::GpuContext) -> bool {
    !ctx.is_lavapipe()
}

/// `opts` with [`SurfaceWalk::Auto`] resolved for the adapter of `ctx`, or the refusal of
/// ray queries asked of an adapter without them (`--accel rayquery`, `--surface-walk
/// rayquery`), naming the adapter and what would provide them.
pub fn resolve_surface(ctx: &super::GpuContext, opts: &RenderOptions) -> Result<RenderOptions> {
    let asked = if opts.accel == AccelKind::RayQuery {
        Some("--accel rayquery")
    } else if uses_tables(opts.accel) && opts.surface == SurfaceWalk::RayQuery {
        Some("--surface-walk rayquery")
    } else {
        None
    };
    if let (Some(flag), false) = (asked, ctx.ray_queries) {
        return Err(Error::Options(format!(
            "{flag} needs the GPU's ray queries (Vulkan's VK_KHR_ray_query), which {} ({}) does not offer: a GPU \
             with ray tracing has them, and so has Mesa's lavapipe from 24.1 on (Debian 12: mesa-vulkan-drivers \
             from bookworm-backports; docs/drivers-and-faults.md says how to use it beside the system's)",
            ctx.info.name, ctx.info.driver_info
        )));
    }
    let surface = match opts.surface {
        SurfaceWalk::Auto if ctx.ray_queries && ray_queries_measured_faster(ctx) => SurfaceWalk::RayQuery,
        SurfaceWalk::Auto => SurfaceWalk::Bvh,
        given => given,
    };
    Ok(RenderOptions { surface, ..opts.clone() })
}

/// Whether the GPU traces the candidate tables for `accel`.
pub fn uses_tables(accel: AccelKind) -> bool {
    queries(accel) == Queries::Tables
}

/// Checks that the adapter of `ctx` has the 64-bit floats an f64 render of `opts` (resolved:
/// [`RenderOptions::resolved`]) needs; the error says why `auto` chose f64 where it did.
pub fn check_f64(ctx: &super::GpuContext, opts: &RenderOptions) -> Result<()> {
    if opts.precision != Precision::F64 || ctx.f64 {
        return Ok(());
    }
    let why = match &opts.auto_precision {
        Some(need) => format!(
            "this scene needs f64 ({}), and f64 kernels need 64-bit floats in shaders (SHADER_F64), which {} does \
             not offer; --precision f32 renders it in f32 anyway",
            need.reason(),
            ctx.info.name
        ),
        None => format!(
            "--precision f64 needs 64-bit floats in shaders (SHADER_F64), which {} does not offer",
            ctx.info.name
        ),
    };
    Err(Error::Options(why))
}

/// Checks that the GPU backend can render `scene` with `opts`.
pub fn check(scene: &Scene, opts: &RenderOptions) -> Result<()> {
    opts.validate()?;
    scene.validate()?;
    if opts.max_depth > MAX_DEPTH {
        return Err(Error::Options(format!(
            "--max-depth {} is deeper than the GPU backend traces ({MAX_DEPTH}); use --backend cpu",
            opts.max_depth
        )));
    }
    if scene.primitives.len() >= u32::MAX as usize {
        return Err(Error::Scene("too many primitives for the GPU backend".into()));
    }
    check_f32_range(scene)?;
    Ok(())
}

/// How far from the camera (where the packed scene is centred) a coordinate may lie on the
/// GPU: the kernels square coordinates and radii in f32, whose largest value is 3.4·10³⁸.
pub const F32_REACH: f64 = (1u64 << 60) as f64;

/// Refuses a scene that the kernels' f32 arithmetic would overflow: a finite f64 value that
/// turns to Inf in f32, or squares to it, so that no Inf reaches a kernel.
fn check_f32_range(scene: &Scene) -> Result<()> {
    let eye = scene.camera.eye;
    let reach_of = |b: crate::scene::Aabb| (b.min - eye).abs().max((b.max - eye).abs()).max_element();
    let too_far = |what: String, reach: f64| {
        Error::Scene(format!(
            "{what} reaches {reach:.3e} from the camera, beyond what the GPU's f32 arithmetic can \
             square ({F32_REACH:.3e}); render it with --backend cpu"
        ))
    };
    for (id, p) in scene.primitives.iter().enumerate() {
        let r = reach_of(p.bounds());
        if r > F32_REACH {
            return Err(too_far(format!("primitive {id}"), r));
        }
    }
    for (i, l) in scene.lights.iter().enumerate() {
        let r = (l.position - eye).abs().max_element();
        if !matches!(l.kind, crate::scene::LightKind::Directional) && r > F32_REACH {
            return Err(too_far(format!("light {i}"), r));
        }
    }
    // The other numbers the kernels get as f32: finite in f64, they must stay finite there.
    let beyond = |what: String, x: f64| {
        Error::Scene(format!(
            "{what} is {x:.3e}, beyond f32's range ({:.3e}), which the GPU holds it in; render it \
             with --backend cpu",
            f32::MAX
        ))
    };
    let fits = |x: f64| x.abs() <= f32::MAX as f64;
    for (i, m) in scene.materials.iter().enumerate() {
        let values = [
            ("colour", m.color.abs().max_element()),
            ("diffuse weight", m.kd),
            ("highlight weight", m.ks),
            ("Phong exponent", m.shine),
            ("mirror weight", m.mirror.abs().max_element()),
            ("transmittance", m.transmittance),
            ("index of refraction", m.ior),
            ("emission", m.emission.abs().max_element()),
        ];
        if let Some((what, x)) = values.into_iter().find(|&(_, x)| !fits(x)) {
            let named = m.name.as_ref().map(|n| format!(" ({n})")).unwrap_or_default();
            return Err(beyond(format!("material {i}{named}: its {what}"), x));
        }
    }
    for (i, l) in scene.lights.iter().enumerate() {
        let radiance = (l.color * l.intensity).abs().max_element();
        if !fits(radiance) {
            return Err(beyond(format!("light {i}: its colour times intensity"), radiance));
        }
        if let Some(r) = l.range.filter(|&r| !fits(r)) {
            return Err(beyond(format!("light {i}: its range"), r));
        }
    }
    for (name, v) in [("the ambient light", scene.ambient), ("the background", scene.background)] {
        if !fits(v.abs().max_element()) {
            return Err(beyond(name.into(), v.abs().max_element()));
        }
    }
    Ok(())
}
