//! The candidate tables of a scene: [`build`] makes every origin the scene's effects call
//! for (the eye, the positional lights, the surfaces that spawn secondary rays), builds them
//! in parallel (rayon), chooses the surface resolution under the memory budget, and
//! flattens the result; [`Tables::rebuild_eye`] replaces only the eye's table after the
//! camera moved.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::budget::{surface_tables, table_bytes};
use super::context::Ctx;
use super::defs::{eye_def, light_def, OriginDef};
use super::flat::{FlatTables, OriginKind, MAX_BINDING_BYTES};
use super::flatten::{append_fallback, flatten, frames};
use super::groups::Groups;
use super::hierarchy::{mark_enclosing, Bvh};
use super::lists::OriginTable;
use super::origin::build_origin;
use super::params::{BuildParams, ShadowMode};
use super::patches::patch_counts;
use super::reach::WalkBounds;
use super::targets::{Shape, Target};
use crate::error::{Error, Result};
use crate::kernel::spawn::SpawnPolicy;
use crate::scene::{LightKind, Scene};

/// The candidate tables of a scene, flattened, with what was built and how long it took.
#[derive(Clone, Debug)]
pub struct Tables {
    pub flat: FlatTables,
    /// The origins as built (kind, sphere, members, resolution).
    pub defs: Vec<OriginDef>,
    /// Wall-clock build time in seconds.
    pub build_s: f64,
    /// The spawn-offset policy the tables are conservative for, and the offset bound (origin
    /// inflation) used.
    pub spawn: SpawnPolicy,
    pub eps: f64,
    /// Surface resolution and cluster size chosen (0 when there are no surface origins).
    pub surface_n: u32,
    pub cluster_size: usize,
    pub shadow_mode: ShadowMode,
    /// The image size the eye table covers.
    pub eye_image: (u32, u32),
    /// The per-origin tables `flat` was flattened from (kept so that the eye's table alone
    /// can be replaced, [`Tables::rebuild_eye`]).
    pub built: Vec<OriginTable>,
    /// The spheres the eye is inside (they list themselves in their own tables).
    pub eye_inside: Vec<u32>,
    /// How long a walk of `flat` can be, for the render's effects.
    pub walks: WalkBounds,
}

/// A full rebuild for a moved eye inflates the origins by this much more than needed.
const EYE_SLACK: f64 = 1.5;

/// The spheres whose inside holds `p` (as [`mark_enclosing`] decides it).
fn spheres_around(p: DVec3, targets: &[Target]) -> Vec<u32> {
    (0..targets.len() as u32)
        .filter(|&i| match targets[i as usize].shape {
            Shape::Sphere { c, r } => (p - c).length() < r * (1.0 - 1e-6),
            _ => false,
        })
        .collect()
}

/// The scene's targets (with the spheres the eye, a light or another primitive is inside
/// marked self-listing) and their hierarchy.
fn targets(scene: &Scene) -> (Vec<Target>, Bvh) {
    let mut targets: Vec<Target> = scene.primitives.iter().map(|p| Target::of(p, scene)).collect();
    let bvh = Bvh::build(&targets);
    let mut points = vec![scene.camera.eye];
    points.extend(scene.lights.iter().filter(|l| l.kind != LightKind::Directional).map(|l| l.position));
    mark_enclosing(&mut targets, &bvh, &points);
    (targets, bvh)
}

/// Flattens `built` (origins `defs`) with the eye-relative data and the fallback origin, and
/// checks every buffer against wgpu's binding limit.
fn flat_tables(
    built: &[OriginTable],
    defs: &[OriginDef],
    scene: &Scene,
    targets: &[Target],
    groups: &Groups,
) -> Result<FlatTables> {
    let mut flat = flatten(built, defs, targets.len(), scene.lights.len(), groups);
    frames(&mut flat, targets, groups, scene.camera.eye);
    append_fallback(&mut flat, targets.len());
    if flat.largest_buffer_bytes() > MAX_BINDING_BYTES {
        return Err(Error::TablesTooLarge { bytes: flat.largest_buffer_bytes(), limit: MAX_BINDING_BYTES });
    }
    Ok(flat)
}

impl Tables {
    /// Replaces the eye's table after `scene.camera` moved, keeping the light and surface
    /// tables (the interactive preview). Those depend on the eye only through the spawn
    /// offset (which grows with the distance from the eye to the scene) and through the
    /// spheres the eye is inside; when either changed, everything is rebuilt. Returns
    /// whether the eye table alone was rebuilt.
    pub fn rebuild_eye(&mut self, scene: &Scene, params: &BuildParams) -> Result<bool> {
        let start = Instant::now();
        let eps = params.spawn_offset(scene);
        let (targets, bvh) = targets(scene);
        let has_eye = self.defs.first().is_some_and(|d| d.kind == OriginKind::Eye);
        if eps > self.eps || !has_eye || spheres_around(scene.camera.eye, &targets) != self.eye_inside {
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
        self.flat = flat_tables(&self.built, &self.defs, scene, &targets, &ctx.groups)?;
        self.flat.check(targets.len())?;
        self.walks = WalkBounds::of(scene, &self.flat, params.effects.unwrap_or_else(|| scene.effects()));
        self.eye_image = params.eye_image(scene);
        self.build_s = start.elapsed().as_secs_f64();
        Ok(true)
    }
}

/// Builds the candidate tables a scene calls for.
pub fn build(scene: &Scene, params: &BuildParams) -> Result<Tables> {
    let start = Instant::now();
    let eps = params.spawn_offset(scene);
    let (targets, bvh) = targets(scene);
    let ctx = Ctx::new(&targets, &bvh, eps, params);
    let effects = params.effects.unwrap_or_else(|| scene.effects());

    // The eye and the lights: one table each, whatever the budget.
    let mut defs: Vec<OriginDef> = Vec::new();
    if !targets.is_empty() {
        defs.push(eye_def(scene, params, eps));
    }
    let directional = scene.lights.iter().any(|l| l.kind == LightKind::Directional);
    if effects.shadows && params.shadow_mode == ShadowMode::LightBuffer {
        for (i, l) in scene.lights.iter().enumerate() {
            if l.kind != LightKind::Directional {
                defs.push(light_def(i, l.position, params, eps, &ctx));
            }
        }
    }
    let mut built: Vec<OriginTable> = defs.par_iter().map(|d| build_origin(d, &ctx)).collect();
    crate::interrupt::check()?;
    let fixed_bytes: usize =
        built.iter().map(table_bytes).sum::<usize>() + 4 * (targets.len() + scene.lights.len() + 1);

    // Surface origins: primitives that spawn secondary rays.
    let all_surfaces = effects.shadows && (params.shadow_mode == ShadowMode::HitObject || directional);
    let surface_ids: Vec<u32> = scene
        .primitives
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            let m = &scene.materials[p.material() as usize];
            all_surfaces || (effects.reflection && (m.reflects() || m.transmits()))
        })
        .map(|(i, _)| i as u32)
        .collect();
    let (mut surface_n, mut cluster_size) = (0, 0);
    if !surface_ids.is_empty() {
        let mut patches = patch_counts(&surface_ids, &targets);
        let s = surface_tables(&surface_ids, &mut patches, &built, fixed_bytes, params, &ctx);
        (surface_n, cluster_size) = (s.n, s.cluster_size);
        defs.extend(s.defs);
        built.extend(s.built);
    }
    crate::interrupt::check()?;
    let flat = flat_tables(&built, &defs, scene, &targets, &ctx.groups)?;
    flat.check(targets.len())?;
    Ok(Tables {
        walks: WalkBounds::of(scene, &flat, effects),
        flat,
        defs,
        build_s: start.elapsed().as_secs_f64(),
        spawn: params.spawn,
        eps,
        surface_n,
        cluster_size,
        shadow_mode: params.shadow_mode,
        eye_image: params.eye_image(scene),
        built,
        eye_inside: spheres_around(scene.camera.eye, &targets),
    })
}
