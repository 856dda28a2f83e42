//! The shared, read-only inputs of the per-origin builds: the targets and their hierarchy,
//! the spawn offset and angular widening, the primitive groups, and a cache of cell cones.

use std::sync::Arc;

use super::cells::{cell_cone, CellCone};
use super::groups::{Groups, GROUP_SIZE};
use super::hierarchy::Bvh;
use super::params::BuildParams;
use super::targets::Target;

/// Shared, read-only inputs of the per-origin builds.
pub struct Ctx<'a> {
    pub targets: &'a [Target],
    pub bvh: &'a Bvh,
    pub eps: f64,
    pub delta: f64,
    /// The primitive groups, and the list length from which lists name them.
    pub groups: Groups,
    pub group_min_list: usize,
    cells: std::sync::Mutex<std::collections::HashMap<u32, Arc<Vec<CellCone>>>>,
}

impl<'a> Ctx<'a> {
    pub fn new(targets: &'a [Target], bvh: &'a Bvh, eps: f64, params: &BuildParams) -> Self {
        Ctx {
            targets,
            bvh,
            eps,
            delta: params.delta,
            groups: Groups::of_bvh(bvh, targets.len(), GROUP_SIZE),
            group_min_list: params.group_min_list,
            cells: Default::default(),
        }
    }

    /// All cells of an `n`-cube, cached when the cube is small.
    pub fn cube(&self, n: u32) -> Option<Arc<Vec<CellCone>>> {
        if n > 64 {
            return None;
        }
        let mut map = self.cells.lock().unwrap();
        Some(
            map.entry(n)
                .or_insert_with(|| {
                    let mut v = Vec::with_capacity(6 * (n * n) as usize);
                    for f in 0..6 {
                        for iv in 0..n {
                            for iu in 0..n {
                                v.push(cell_cone(f, iu, iv, n));
                            }
                        }
                    }
                    Arc::new(v)
                })
                .clone(),
        )
    }
}
