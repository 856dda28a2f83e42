//! The candidate tables of a scene: [`build`] makes the direction cubes the scene's effects
//! call for (the eye, the positional lights), in parallel (rayon), then the beams of the
//! rays leaving surfaces (piloted by the eye's table), and flattens the result, coarser
//! where a buffer would outgrow a binding;
//! [`Tables::rebuild_eye`] replaces only the eye's table after the camera moved.

use std::time::Instant;

use rayon::prelude::*;

use super::beams::{pilot::build_beams, BeamTree};
use super::context::Ctx;
use super::defs::{eye_def, light_def, OriginDef};
use super::flat::{FlatTables, OriginKind, MAX_BINDING_BYTES};
use super::flatten::flatten;
use super::hierarchy::SphereTree;
use super::lists::OriginTable;
use super::origin::build_origin;
use super::params::{BuildParams, ShadowMode};
use super::reach::WalkBounds;
use super::targets::Target;
use crate::arith::spawn::SpawnPolicy;
use crate::error::{Error, Result};
use crate::scene::{LightKind, Scene};

/// The candidate tables of a scene, flattened, with what was built and how long it took.
#[derive(Clone, Debug)]
pub struct Tables {
    pub flat: FlatTables,
    /// The direction cubes as built (kind, sphere, resolution).
    pub defs: Vec<OriginDef>,
    /// Wall-clock build time in seconds.
    pub build_s: f64,
    /// The spawn-offset policy the tables are conservative for, and the offset bound (origin
    /// inflation) used.
    pub spawn: SpawnPolicy,
    pub eps: f64,
    pub shadow_mode: ShadowMode,
    /// The image size the eye table covers.
    pub eye_image: (u32, u32),
    /// The per-origin tables `flat` was flattened from (kept so that the eye's table alone
    /// can be replaced, [`Tables::rebuild_eye`]).
    pub built: Vec<OriginTable>,
    /// The beams of the rays leaving surfaces, in the world frame (`None`: no such rays).
    pub beams: Option<BeamTree>,
    /// How long a walk of `flat` can be, for the render's effects.
    pub walks: WalkBounds,
}

/// A full rebuild for a moved eye inflates the origins by this much more than needed.
const EYE_SLACK: f64 = 1.5;

/// The scene's targets and their hierarchy.
fn targets(scene: &Scene) -> (Vec<Target>, SphereTree) {
    let targets: Vec<Target> = scene.primitives.iter().map(|p| Target::of(p, scene)).collect();
    let bvh = SphereTree::build(&targets);
    (targets, bvh)
}

/// Flattens `built` (origins `defs`) and `beams` for the scene's camera, and checks every
/// buffer against wgpu's binding limit and the walkers' invariants.
fn flat_tables(
    built: &[OriginTable],
    defs: &[OriginDef],
    beams: Option<&BeamTree>,
    scene: &Scene,
    ctx: &Ctx,
) -> Result<FlatTables> {
    let (n, lights) = (ctx.targets.len(), scene.lights.len());
    let flat = flatten(built, defs, beams, n, lights, &ctx.groups, scene.camera.eye);
    if flat.largest_buffer_bytes() > MAX_BINDING_BYTES {
        return Err(Error::TablesTooLarge { bytes: flat.largest_buffer_bytes(), limit: MAX_BINDING_BYTES });
    }
    flat.check(n)?;
    Ok(flat)
}

impl Tables {
    /// Replaces the eye's table after `scene.camera` moved, keeping the light tables and the
    /// beams (the interactive preview). Those depend on the eye only through the spawn
    /// offset, which grows with the distance from the eye to the scene (and through the
    /// pilot, which only makes them faster for the rays it saw); when the offset grew,
    /// everything is rebuilt. Returns whether the eye table alone was rebuilt.
    pub fn rebuild_eye(&mut self, scene: &Scene, params: &BuildParams) -> Result<bool> {
        let start = Instant::now();
        let eps = params.spawn_offset(scene);
        let (targets, bvh) = targets(scene);
        let has_eye = self.defs.first().is_some_and(|d| d.kind == OriginKind::Eye);
        if eps > self.eps || !has_eye {
            // With room for the eye to move farther before the next full rebuild.
            let p = BuildParams { spawn_offset: Some(eps * EYE_SLACK), ..params.clone() };
            *self = build(scene, &p)?;
            return Ok(false);
        }
        let ctx = Ctx::new(&targets, &bvh, self.eps, params);
        let def = eye_def(scene, params, self.eps);
        self.built[0] = build_origin(&def, &ctx);
        crate::interrupt::check()?;
        self.defs[0] = def;
        self.flat = flat_tables(&self.built, &self.defs, self.beams.as_ref(), scene, &ctx)?;
        self.walks = WalkBounds::of(scene, &self.flat, params.effects.unwrap_or_else(|| scene.effects()));
        self.eye_image = params.eye_image(scene);
        self.build_s = start.elapsed().as_secs_f64();
        Ok(true)
    }
}

/// The primitives whose rays the beams classify: those that reflect or transmit (with the
/// reflection effect), and every primitive when shadow rays leave surfaces (hit-object mode,
/// or a directional light, which has no table).
fn spawners(scene: &Scene, params: &BuildParams) -> Vec<u32> {
    let effects = params.effects.unwrap_or_else(|| scene.effects());
    let directional = scene.lights.iter().any(|l| l.kind == LightKind::Directional);
    let all = effects.shadows && (params.shadow_mode == ShadowMode::HitObject || directional);
    scene
        .primitives
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            let m = &scene.materials[p.material() as usize];
            all || (effects.reflection && (m.reflects() || m.transmits()))
        })
        .map(|(i, _)| i as u32)
        .collect()
}

/// Whether a render the tables of `params` are for traces rays leaving surfaces: the rays
/// the beams classify when they are built, and the BVH walks when they are not.
pub fn traces_surface_rays(scene: &Scene, params: &BuildParams) -> bool {
    !spawners(scene, params).is_empty()
}

/// Builds the candidate tables a scene calls for.
pub fn build(scene: &Scene, params: &BuildParams) -> Result<Tables> {
    let start = Instant::now();
    let mut params = params.clone();
    let mut coarser = 0;
    loop {
        match build_once(scene, &params) {
            Err(Error::TablesTooLarge { bytes, .. }) if coarser < MAX_COARSER && coarsen(&mut params) => {
                coarser += 1;
                log::info!(
                    "the tables need {bytes} bytes in one buffer: again with half the cells per face edge"
                );
            }
            Ok(mut tables) => {
                tables.build_s = start.elapsed().as_secs_f64();
                return Ok(tables);
            }
            Err(e) => return Err(e),
        }
    }
}

/// How many times [`build`] halves the resolutions it chose before giving up on tables that
/// outgrow a binding (64× fewer cells per face edge).
const MAX_COARSER: u32 = 6;

/// Halves the cells per face edge of the eye's and the lights' cubes where `params` left
/// them to the build: their lists grow with the origins' inflation (a large fixed spawn
/// offset), and fewer cells hold the same candidates in less memory, for the same hits.
/// `false` when the caller fixed both.
fn coarsen(params: &mut BuildParams) -> bool {
    let mut changed = false;
    if params.eye_n.is_none() {
        params.eye_pixels_per_cell *= 2.0;
        changed = true;
    }
    if params.light_n.is_none() && params.light_cells > 64 {
        params.light_cells /= 4;
        changed = true;
    }
    changed
}

fn build_once(scene: &Scene, params: &BuildParams) -> Result<Tables> {
    let start = Instant::now();
    let eps = params.spawn_offset(scene);
    let (targets, bvh) = targets(scene);
    let ctx = Ctx::new(&targets, &bvh, eps, params);
    let effects = params.effects.unwrap_or_else(|| scene.effects());

    // The eye and the lights: one direction cube each.
    let mut defs: Vec<OriginDef> = Vec::new();
    if !targets.is_empty() {
        defs.push(eye_def(scene, params, eps));
    }
    if effects.shadows && params.shadow_mode == ShadowMode::LightBuffer {
        for (i, l) in scene.lights.iter().enumerate() {
            if l.kind != LightKind::Directional {
                defs.push(light_def(i, l.position, params, eps, &ctx));
            }
        }
    }
    let built: Vec<OriginTable> = defs.par_iter().map(|d| build_origin(d, &ctx)).collect();
    crate::interrupt::check()?;
    let mut flat = flat_tables(&built, &defs, None, scene, &ctx)?;

    // The beams, piloted through the eye's table, in what the budget leaves.
    let spawners = if params.beams { spawners(scene, params) } else { Vec::new() };
    let beams = (!spawners.is_empty()).then(|| {
        // What the groups' buffers take, should a list name them.
        let groups =
            4 * targets.len() + std::mem::size_of::<super::flat::GpuGroup>() * ctx.groups.spans.len();
        let left = params.budget_bytes.saturating_sub(flat.bytes() + groups);
        build_beams(scene, &flat, &ctx, &spawners, params, effects.shadows, left)
    });
    crate::interrupt::check()?;
    if beams.is_some() {
        flat = flat_tables(&built, &defs, beams.as_ref(), scene, &ctx)?;
    }
    Ok(Tables {
        walks: WalkBounds::of(scene, &flat, effects),
        flat,
        defs,
        build_s: start.elapsed().as_secs_f64(),
        spawn: params.spawn,
        eps,
        shadow_mode: params.shadow_mode,
        eye_image: params.eye_image(scene),
        built,
        beams,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A build that outgrows a binding halves only the resolutions it chose itself, and
    /// gives up when the caller fixed them all.
    #[test]
    fn coarsening_leaves_fixed_resolutions_alone() {
        let mut p = BuildParams::default();
        let (eye, light) = (p.eye_pixels_per_cell, p.light_cells);
        assert!(coarsen(&mut p));
        assert_eq!((p.eye_pixels_per_cell, p.light_cells), (2.0 * eye, light / 4));

        let mut fixed = BuildParams { eye_n: Some(64), light_n: Some(32), ..BuildParams::default() };
        assert!(!coarsen(&mut fixed));
        assert_eq!((fixed.eye_n, fixed.light_n), (Some(64), Some(32)));
        assert_eq!((fixed.eye_pixels_per_cell, fixed.light_cells), (eye, light));
    }
}
