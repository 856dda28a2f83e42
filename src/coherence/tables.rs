//! The candidate tables of a scene: [`build`] makes the direction cubes the scene's effects
//! call for (the eye, the positional lights), in parallel (rayon), and flattens them,
//! coarser where a buffer would outgrow a binding; [`Tables::rebuild_eye`] replaces only the
//! eye's table after the camera moved. Rays leaving surfaces have no table: the GPU walks
//! the BVH for them ([`traces_surface_rays`] says whether a render has any).

use std::time::Instant;

use rayon::prelude::*;

use super::context::Ctx;
use super::defs::{eye_def, light_def, OriginDef};
use super::flat::{FlatTables, OriginKind, MAX_BINDING_BYTES};
use super::flatten::flatten;
use super::hierarchy::SphereTree;
use super::lists::OriginTable;
use super::origin::build_origin;
use super::params::BuildParams;
use super::reach::WalkBounds;
use super::targets::Target;
use super::walk::OriginKey;
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
    /// The image size the eye table covers.
    pub eye_image: (u32, u32),
    /// The per-origin tables `flat` was flattened from (kept so that the eye's table alone
    /// can be replaced, [`Tables::rebuild_eye`]).
    pub built: Vec<OriginTable>,
    /// How long a walk of `flat` can be, for the render's effects.
    pub walks: WalkBounds,
}

/// A full rebuild for a moved eye inflates the origins by this much more than needed.
const EYE_SLACK: f64 = 1.5;

/// The scene's targets, in their hierarchy's leaf order ([`Ctx::targets`]), and the
/// hierarchy.
fn targets(scene: &Scene) -> (Vec<Target>, SphereTree) {
    let targets: Vec<Target> = scene.primitives.par_iter().map(|p| Target::of(p, scene)).collect();
    let bvh = SphereTree::build(&targets);
    let ordered = bvh.order.par_iter().map(|&i| targets[i as usize]).collect();
    (ordered, bvh)
}

/// Flattens `built` (origins `defs`) for the scene's camera, and checks every buffer
/// against wgpu's binding limit and the walkers' invariants.
fn flat_tables(built: &[OriginTable], defs: &[OriginDef], scene: &Scene, ctx: &Ctx) -> Result<FlatTables> {
    let (n, lights) = (ctx.targets.len(), scene.lights.len());
    let flat = flatten(built, defs, n, lights);
    if flat.largest_buffer_bytes() > MAX_BINDING_BYTES {
        return Err(Error::TablesTooLarge { bytes: flat.largest_buffer_bytes(), limit: MAX_BINDING_BYTES });
    }
    flat.check(n)?;
    Ok(flat)
}

impl Tables {
    /// Replaces the eye's table after `scene.camera` moved, keeping the light tables (the
    /// interactive preview). Those depend on the eye only through the spawn offset, which
    /// grows with the distance from the eye to the scene; when the offset grew, everything is
    /// rebuilt. Returns whether the eye table alone was rebuilt.
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
        self.flat = flat_tables(&self.built, &self.defs, scene, &ctx)?;
        self.walks = WalkBounds::of(scene, &self.flat, traces_surface_rays(scene, params));
        self.eye_image = params.eye_image(scene);
        self.build_s = start.elapsed().as_secs_f64();
        Ok(true)
    }
}

/// Whether a render the tables of `params` are for traces rays leaving surfaces, which the
/// BVH takes: reflection or refraction rays from mirrors and glass (with the reflection
/// effect), pass-through rays from blended surfaces (with the blend effect), shadow rays
/// towards a light without a table (a directional one, or one `params` leave untabled), or
/// eye rays where `params` leave the eye untabled.
pub fn traces_surface_rays(scene: &Scene, params: &BuildParams) -> bool {
    let effects = params.effects.unwrap_or_else(|| scene.effects());
    if scene.primitives.is_empty() {
        return false;
    }
    if !params.tables(OriginKey::Eye) || (effects.shadows && untabled_lights(scene, params)) {
        return true;
    }
    let blend = |m: &crate::scene::Material| effects.blend && m.alpha == crate::scene::Alpha::Blend;
    (effects.reflection || effects.blend)
        && scene.primitives.iter().any(|p| {
            let m = &scene.materials[p.material() as usize];
            (effects.reflection && (m.reflects() || m.transmits())) || blend(m)
        })
}

/// Whether some light of `scene` has no table with `params`: a directional light, or one
/// left untabled; its shadow rays walk the BVH.
pub fn untabled_lights(scene: &Scene, params: &BuildParams) -> bool {
    scene
        .lights
        .iter()
        .enumerate()
        .any(|(i, l)| l.kind == LightKind::Directional || !params.tables(OriginKey::Light(i)))
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
    if !targets.is_empty() && params.tables(OriginKey::Eye) {
        defs.push(eye_def(scene, params, eps));
    }
    if effects.shadows {
        for (i, l) in scene.lights.iter().enumerate() {
            if l.kind != LightKind::Directional && params.tables(OriginKey::Light(i)) {
                defs.push(light_def(i, l.position, params, eps, &ctx));
            }
        }
    }
    let built: Vec<OriginTable> = defs.par_iter().map(|d| build_origin(d, &ctx)).collect();
    crate::interrupt::check()?;
    let flat = flat_tables(&built, &defs, scene, &ctx)?;
    Ok(Tables {
        walks: WalkBounds::of(scene, &flat, traces_surface_rays(scene, params)),
        flat,
        defs,
        build_s: start.elapsed().as_secs_f64(),
        spawn: params.spawn,
        eps,
        eye_image: params.eye_image(scene),
        built,
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
