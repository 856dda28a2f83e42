//! The pilot pass: which beams rays use, found by tracing a lattice of the whole image's ray
//! trees through the tree as it grows (Arvo and Kirk subdivided lazily, as rays arrived; a
//! GPU cannot, so the pilot does it before the render).
//!
//! The eye rays of every `step`-th pixel of the whole image (the same for every tile, crop
//! or part of a render) are traced through the eye's table; the rays their hits spawn (the
//! kernels' ray trees, [`crate::coherence::raytree`]) are the next generation. Each
//! generation of rays leaving surfaces first splits the leaves whose lists it would walk to
//! the end past [`COARSE`] candidates, then finds its nearest hits among its leaves'
//! candidates (conservative lists hold the true nearest hit), then splits again where the
//! candidates before each ray's hit average more than the cost target
//! ([`crate::coherence::BuildParams::beam_target`]). Their hits spawn the next generation,
//! down to the render's maximum depth (at most [`GENERATION`] rays per eye ray each). Shadow
//! rays towards lights without a table of their own join their generation with their
//! segment's length as the distance.

use glam::DVec3;
use rayon::prelude::*;

use super::build::{Builder, PilotRay};
use super::BeamTree;
use crate::arith::closest::{brute_nearest, consider, no_closest, test_prim, Closest};
use crate::arith::geometry::PrimHit;
use crate::arith::{FAR, NO_ID};
use crate::coherence::context::Ctx;
use crate::coherence::cube::cube_face_cell;
use crate::coherence::flat::{FlatTables, BEAM_CELLS};
use crate::coherence::params::BuildParams;
use crate::coherence::raytree::{RayTree, TreeRay, TreeShadow};
use crate::coherence::walk::{table_nearest, OriginKey, WalkCount};
use crate::scene::Scene;

/// Leaves whose rays would walk more candidates than this to the end are split before the
/// rays are traced.
pub const COARSE: f64 = 32.0;

/// A generation keeps at most this many rays per eye ray (every k-th, in order): glass
/// doubles the rays at each depth, and the leaves they refine are shared anyway.
pub const GENERATION: usize = 2;

/// The nearest hit of a surface ray among its leaf's candidates (every primitive when the
/// ray is not classified).
fn nearest(b: &Builder, tree: &RayTree, r: &TreeRay) -> Closest<f32, PrimHit> {
    let ray = &r.ray;
    if !b.inside(ray.o) || ray.d.abs().max_element() == 0.0 {
        return brute_nearest(&tree.prims, ray, FAR, r.skip);
    }
    let leaf = b.leaf_of(ray.o, cube_face_cell(ray.d, BEAM_CELLS));
    let mut best = no_closest();
    let mut best_t = FAR;
    for c in b.list(leaf) {
        if c.dmin > best_t as f64 {
            break;
        }
        if c.id != r.skip {
            best_t = consider(&mut best, c.id, test_prim(&tree.prims[c.id as usize], ray, FAR), best_t);
        }
    }
    best
}

/// Keeps every k-th of `v`, at most `cap` of them.
fn thin<T: Copy>(v: &mut Vec<T>, cap: usize) {
    if v.len() > cap {
        let k = v.len().div_ceil(cap);
        *v = v.iter().step_by(k).copied().collect();
    }
}

/// What the hits of `rays` spawn: the next generation and the shadow queries.
fn spawn_all(
    tree: &RayTree,
    rays: &[TreeRay],
    hits: &[Closest<f32, PrimHit>],
    max_depth: u32,
) -> (Vec<TreeRay>, Vec<TreeShadow>) {
    let (mut next, mut shadows) = (Vec::new(), Vec::new());
    for (r, h) in rays.iter().zip(hits) {
        tree.spawn(r, h, max_depth, &mut shadows, &mut next);
    }
    (next, shadows)
}

/// Builds the beams for the rays leaving `spawners`, piloted by the ray trees of a lattice
/// of the image `params` builds for; `cube` holds the eye's and the lights' tables.
pub fn build_beams(
    scene: &Scene,
    cube: &FlatTables,
    ctx: &Ctx,
    spawners: &[u32],
    params: &BuildParams,
    shadows: bool,
    budget_bytes: usize,
) -> BeamTree {
    let boxes: Vec<(DVec3, DVec3)> = scene
        .primitives
        .iter()
        .map(|p| {
            let b = p.bounds();
            (b.min, b.max)
        })
        .collect();
    let mut b = Builder::new(ctx, scene.camera.eye, &boxes, spawners, budget_bytes);
    if spawners.is_empty() || params.pilot_rays == 0 {
        return b.finish();
    }
    let start = std::time::Instant::now();
    let tree = RayTree::new(scene, params.spawn, shadows);
    let (w, h) = params.eye_image(scene);
    let step = ((w as f64 * h as f64 / params.pilot_rays as f64).sqrt().ceil() as u32).max(1);
    let rays: Vec<TreeRay> = (0..h)
        .step_by(step as usize)
        .flat_map(|j| (0..w).step_by(step as usize).map(move |i| (i, j)))
        .map(|(i, j)| tree.eye_ray(i as f64 + 0.5, j as f64 + 0.5, w, h))
        .collect();
    let hits: Vec<Closest<f32, PrimHit>> = rays
        .par_iter()
        .map(|r| {
            let ray = &r.ray;
            let mut count = WalkCount::default();
            table_nearest(cube, r.key(), ray.o, ray.d, FAR, NO_ID, &mut count, |id| {
                test_prim(&tree.prims[id as usize], ray, FAR)
            })
        })
        .collect();
    let cap = GENERATION * rays.len();
    let (mut rays, mut queries) = spawn_all(&tree, &rays, &hits, params.max_depth);
    let mut split_s = b.stats.split_s;
    let mut piloted: Vec<PilotRay> = Vec::new();
    while !rays.is_empty() || !queries.is_empty() {
        if crate::interrupt::requested().is_some() {
            break;
        }
        thin(&mut rays, cap);
        thin(&mut queries, cap);
        // Shadow rays from surfaces towards lights without a table.
        let mut generation: Vec<PilotRay> = queries
            .iter()
            .filter(|s| cube.cube_of(OriginKey::Light(s.light)).is_none())
            .filter_map(|s| tree.shadow_ray(s, false))
            .map(|(_, ray, t)| PilotRay { o: ray.o, d: ray.d, t })
            .collect();
        let first = generation.len();
        generation.extend(rays.iter().map(|r| PilotRay { o: r.ray.o, d: r.ray.d, t: FAR }));
        b.refine(&generation, COARSE);
        let hits: Vec<Closest<f32, PrimHit>> = rays.par_iter().map(|r| nearest(&b, &tree, r)).collect();
        for (p, h) in generation[first..].iter_mut().zip(&hits) {
            p.t = h.best_t(FAR);
        }
        b.refine(&generation, params.beam_target);
        piloted.extend_from_slice(&generation);
        (rays, queries) = spawn_all(&tree, &rays, &hits, params.max_depth);
        split_s = b.stats.split_s;
    }
    b.stats.pilot_rays = piloted.len() as u64;
    b.stats.pilot_cost = b.mean_cost(&piloted);
    b.stats.trace_s = start.elapsed().as_secs_f64() - split_s;
    b.finish()
}
