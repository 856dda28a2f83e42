//! Choosing the surface tables under the memory budget: candidate (cluster size, cells per
//! face) pairs run from fine to coarse, and a bisection over sampled estimates finds the
//! finest that fits; should the real build still overflow wgpu's binding limit, the next
//! coarser candidate is built, and at the coarsest the surface patches are halved.

use rayon::prelude::*;

use super::context::Ctx;
use super::defs::{surface_defs, OriginDef};
use super::flat::{GpuEntry, GpuFace, GpuOrigin, MAX_BINDING_BYTES};
use super::lists::OriginTable;
use super::origin::build_origin;
use super::params::BuildParams;

/// Budget estimates made while bisecting the surface candidates.
const TRIALS: usize = 6;
/// Surface origins built per estimate.
const SAMPLE: usize = 16;

/// Surface cubes finer than N = 8 are tried only for clusters of at most 4 primitives and
/// while all surface origins together have at most this many cells.
const SURFACE_CELLS: usize = 1 << 20;

/// Bytes an origin table adds to the flattened buffers.
pub fn table_bytes(t: &OriginTable) -> usize {
    std::mem::size_of::<GpuOrigin>()
        + 6 * std::mem::size_of::<GpuFace>()
        + 4 * (t.starts.len() - 1)
        + 8 * (t.entries.len() + t.always.len())
}

/// The surface origins built, with the resolution and cluster size chosen.
pub struct SurfaceTables {
    pub n: u32,
    pub cluster_size: usize,
    pub defs: Vec<OriginDef>,
    pub built: Vec<OriginTable>,
}

/// The (cluster size, cells per face) pairs to try, fine to coarse.
fn candidates(surfaces: usize, targets: usize, params: &BuildParams) -> Vec<(usize, u32)> {
    let (k, n) = (params.cluster_size, params.surface_n);
    if let (Some(k), Some(n)) = (k, n) {
        return vec![(k, n)];
    }
    let ks = [1usize, 2, 4, 8, 16, 32, 64, 128, 256];
    let fits = |kk: usize| surfaces.div_ceil(kk) * targets <= params.pair_budget;
    let kmin = ks.iter().copied().find(|&kk| fits(kk)).unwrap_or(256);
    let mut v = Vec::new();
    for &kk in ks.iter().filter(|x| k.map_or(**x >= kmin, |k| k == **x)) {
        // Finer cubes first, but never more than `SURFACE_CELLS` cells in all.
        let origins = surfaces.div_ceil(kk);
        for nn in [64u32, 32, 16, 8, 6, 4, 3, 2] {
            let allowed = nn <= 8 || (kk <= 4 && origins * 6 * (nn * nn) as usize <= SURFACE_CELLS);
            if allowed && n.is_none_or(|n| n == nn) {
                v.push((kk, nn));
            }
        }
    }
    if v.is_empty() {
        v.push((k.unwrap_or(1), n.unwrap_or(4)));
    }
    v
}

/// Builds the tables of the surface origins `surface_ids` (with `patches` per side, halved
/// here if even the coarsest tables overflow) within what the budget leaves after the
/// `fixed` tables, which take `fixed_bytes`.
pub fn surface_tables(
    surface_ids: &[u32],
    patches: &mut [u32],
    fixed: &[OriginTable],
    fixed_bytes: usize,
    params: &BuildParams,
    ctx: &Ctx,
) -> SurfaceTables {
    let candidates = candidates(surface_ids.len(), ctx.targets.len(), params);
    let remaining = params.budget_bytes.saturating_sub(fixed_bytes);
    // A sample that was the whole set, kept to avoid building it twice.
    let mut sampled: Option<(usize, Vec<OriginTable>)> = None;
    // Candidates run from fine to coarse and their bytes shrink roughly along the list:
    // bisect for the finest one whose sampled estimate fits, with at most `TRIALS`
    // estimates (each builds a sample of origins spread over the scene).
    let (mut lo, mut hi) = (0, candidates.len() - 1);
    for _ in 0..TRIALS {
        if lo >= hi {
            break;
        }
        let mid = (lo + hi) / 2;
        let (k, n) = candidates[mid];
        let ds = surface_defs(surface_ids, k, n, ctx, patches);
        let step = (ds.len() / SAMPLE).max(1);
        let sample: Vec<&OriginDef> = ds.iter().step_by(step).collect();
        let built: Vec<OriginTable> = sample.par_iter().map(|d| build_origin(d, ctx)).collect();
        let bytes: usize = built.iter().map(table_bytes).sum();
        let estimate = bytes as f64 / sample.len() as f64 * ds.len() as f64;
        if estimate <= remaining as f64 * 0.9 {
            hi = mid;
            if step == 1 {
                sampled = Some((mid, built));
            }
        } else {
            lo = mid + 1;
        }
    }
    let mut ci = hi;
    // Build; should the estimate have been wrong and a buffer overflow wgpu's binding
    // limit, fall back to the next coarser candidate.
    let fixed_entries: usize = fixed.iter().map(|t| t.entries.len() + t.always.len()).sum();
    let fixed_cells: usize = fixed.iter().map(|t| t.starts.len() - 1).sum();
    loop {
        let (k, n) = candidates[ci];
        let ds = surface_defs(surface_ids, k, n, ctx, patches);
        let built: Vec<OriginTable> = match sampled.take() {
            Some((i, b)) if i == ci => b,
            _ => ds.par_iter().map(|d| build_origin(d, ctx)).collect(),
        };
        let entries = fixed_entries + built.iter().map(|t| t.entries.len() + t.always.len()).sum::<usize>();
        let cells = fixed_cells + built.iter().map(|t| t.starts.len() - 1).sum::<usize>();
        let too_big = entries * std::mem::size_of::<GpuEntry>() > MAX_BINDING_BYTES
            || (cells + 1) * 4 > MAX_BINDING_BYTES;
        if too_big && ci + 1 < candidates.len() {
            ci += 1;
            continue;
        }
        if too_big && patches.iter().any(|&m| m > 1) {
            // Even the coarsest tables overflow: coarsen the surface patches too.
            patches.iter_mut().for_each(|m| *m = (*m / 2).max(1));
            continue;
        }
        return SurfaceTables { n, cluster_size: k, defs: ds, built };
    }
}
