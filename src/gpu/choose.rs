//! The choices a render's options leave to `auto`, made once, without a device, for the
//! adapter [`Capabilities`] describe: [`resolve`] checks what the kernels cannot trace
//! ([`check`]: f32's reach, non-finite values, f64 without the adapter's support) and
//! resolves the precision, the accelerator (`--accel auto`: the tables of the origins whose
//! build pays, by [`crate::cost`]) and what rays leaving surfaces take; [`table_params`]
//! turns resolved options into a table build. `cuberay info` prints what [`choose`] chose.

use crate::arith::precision::f32_need;
use crate::coherence::BuildParams;
use crate::cost::AutoAccel;
use crate::error::{Error, Result};
use crate::job::{Accel, KernelForm, Precision, RenderOptions, SurfaceWalk};
use crate::layout::budget::MAX_DEPTH;
use crate::sampling::Sampling;
use crate::scene::{Effects, LightKind, Scene};

/// What an adapter offers that a render's choices depend on: plain data, so that the
/// choices are made, and tested, without a device ([`super::GpuContext::capabilities`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Capabilities {
    /// The adapter's name and driver, for messages.
    pub adapter: String,
    /// Mesa's lavapipe (llvmpipe): its loop limit applies, and its software ray queries
    /// measured slower than the BVH.
    pub lavapipe: bool,
    /// The platform's ray queries (`EXPERIMENTAL_RAY_QUERY`).
    pub ray_queries: bool,
    /// 64-bit floats in shaders (`SHADER_F64`).
    pub f64: bool,
    /// The largest storage buffer one binding may hold, in bytes.
    pub max_binding: u64,
}

/// `opts` with every choice `auto` leaves resolved for `scene`, once: the precision
/// ([`crate::arith::precision`], the reason kept in `auto_precision`), the accelerator
/// (`auto`: the candidate tables), and, on the adapter `caps` describes, what rays leaving
/// surfaces take (ray queries where the adapter has them and they measured faster, else the
/// BVH). Refuses what the kernels cannot trace, an f64 render on an adapter without f64, and
/// ray queries asked of an adapter without them. `caps` `None`: without an adapter (`cuberay
/// tables`), the choices that depend on one stay as given.
pub fn resolve(scene: &Scene, opts: &RenderOptions, caps: Option<&Capabilities>) -> Result<RenderOptions> {
    check(scene, opts)?;
    choose(scene, opts, caps)
}

/// The choices of [`resolve`] without its checks of the scene and options (`cuberay info`
/// shows them for a scene the GPU refuses too).
pub fn choose(scene: &Scene, opts: &RenderOptions, caps: Option<&Capabilities>) -> Result<RenderOptions> {
    let mut o = opts.clone();
    if o.precision == Precision::Auto {
        let need = f32_need(scene, o.height);
        o.precision = if need.needs_f64() { Precision::F64 } else { Precision::F32 };
        log::info!("precision {}: {}", o.precision.name(), need.reason());
        o.auto_precision = Some(need);
    }
    if o.accel == Accel::Auto {
        o.accel = Accel::Cube;
        // Without an adapter (`cuberay tables`) every origin gets its table: a stored file
        // is for renders that share one build.
        if caps.is_some() {
            let effects = scene.effects();
            let params = table_params(scene, &o, effects);
            let threads = rayon::current_num_threads();
            let auto = AutoAccel::predict(scene, eye_rays(&o), o.max_depth, effects, &params, threads);
            log::info!("accelerator: {}", auto.reason());
            if auto.any() {
                o.untabled = auto.untabled();
            } else {
                o.accel = Accel::Bvh;
            }
            o.auto_accel = Some(auto);
        }
    }
    let Some(caps) = caps else { return Ok(o) };
    check_f64(caps, &o)?;
    let asked = match (o.accel, o.surface) {
        (Accel::RayQuery, _) => Some("--accel rayquery"),
        (Accel::Cube, SurfaceWalk::RayQuery) => Some("--surface-walk rayquery"),
        _ => None,
    };
    if let (Some(flag), false) = (asked, caps.ray_queries) {
        return Err(Error::Options(format!(
            "{flag} needs the GPU's ray queries (Vulkan's VK_KHR_ray_query), which {} does not offer: a GPU \
             with ray tracing has them, and so has Mesa's lavapipe from 24.1 on (Debian 12: mesa-vulkan-drivers \
             from bookworm-backports; docs/drivers-and-faults.md says how to use it beside the system's)",
            caps.adapter
        )));
    }
    if o.surface == SurfaceWalk::Auto {
        o.surface = if caps.ray_queries && ray_queries_measured_faster(caps) {
            SurfaceWalk::RayQuery
        } else {
            SurfaceWalk::Bvh
        };
    }
    let limited = loop_limited(caps);
    if o.form == KernelForm::Tree && limited {
        return Err(Error::Options(format!(
            "--kernel-form tree traces each ray tree in one go, which {} cannot: its driver (lavapipe before \
             Mesa 24) ends every loop after 65535 iterations; use --kernel-form wavefront, or a newer \
             lavapipe (docs/drivers-and-faults.md)",
            caps.adapter
        )));
    }
    if o.form == KernelForm::Auto {
        o.form = if limited { KernelForm::Wavefront } else { KernelForm::Tree };
    }
    Ok(o)
}

/// Whether the adapter's driver ends loops after a number of iterations: lavapipe before
/// Mesa 24 (65535 per group of lanes, `layout::budget`). Ray queries came to lavapipe in
/// 24.1, after the limit went, so a lavapipe with them has none.
pub fn loop_limited(caps: &Capabilities) -> bool {
    caps.lavapipe && !caps.ray_queries
}

/// The eye rays a render with `opts` traces over its whole image (a ray per grid point and
/// sample): a part (`--tile`, `--crop`) chooses as the whole does, so that every part of an
/// image is traced alike.
fn eye_rays(opts: &RenderOptions) -> u64 {
    let samples = match opts.sampling {
        Sampling::Pixels => opts.spp.max(1) as u64,
        Sampling::Corners => 1,
    };
    let (w, h) = opts.grid();
    w as u64 * h as u64 * samples
}

/// Whether rays leaving surfaces go to ray queries by default on an adapter that has them:
/// everywhere but on lavapipe, whose software walk of its structure took 0.98–3.5× the wide
/// BVH's time for those rays on Mesa 25.0 (docs/performance.md, "ray queries"). A GPU walks
/// it in hardware, which is what ray queries are for.
fn ray_queries_measured_faster(caps: &Capabilities) -> bool {
    !caps.lavapipe
}

/// How the tables of a render with `opts` whose kernels simulate `effects` are built: for
/// its image, eye cells and spawn policy, and only for the rays those kernels trace (the
/// one place that turns render options into a table build).
pub fn table_params(scene: &Scene, opts: &RenderOptions, effects: Effects) -> BuildParams {
    let effects = Effects {
        shadows: effects.shadows,
        reflection: effects.reflection,
        refraction: effects.refraction,
        ..scene.effects()
    };
    BuildParams {
        image: Some((opts.width, opts.height)),
        spawn: opts.spawn,
        effects: Some(effects),
        eye_n: opts.eye_cells,
        untabled: opts.untabled.clone(),
        ..BuildParams::default()
    }
}

/// Checks that an adapter with `caps` has the 64-bit floats an f64 render of `opts`
/// (resolved) needs; the error says why `auto` chose f64 where it did.
fn check_f64(caps: &Capabilities, opts: &RenderOptions) -> Result<()> {
    if opts.precision != Precision::F64 || caps.f64 {
        return Ok(());
    }
    let why = match &opts.auto_precision {
        Some(need) => format!(
            "this scene needs f64 ({}), and f64 kernels need 64-bit floats in shaders (SHADER_F64), which {} does \
             not offer; --precision f32 renders it in f32 anyway",
            need.reason(),
            caps.adapter
        ),
        None => format!(
            "--precision f64 needs 64-bit floats in shaders (SHADER_F64), which {} does not offer",
            caps.adapter
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
        if !matches!(l.kind, LightKind::Directional) && r > F32_REACH {
            return Err(too_far(format!("light {i}"), r));
        }
    }
    check_f32_values(scene)
}

/// Refuses material, light and colour values beyond f32's range: finite in f64, they must
/// stay finite in the f32 the GPU holds them in.
fn check_f32_values(scene: &Scene) -> Result<()> {
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
