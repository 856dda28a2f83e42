//! The shared, read-only inputs of the per-origin builds: the targets and their hierarchy,
//! the spawn offset and angular widening.

use super::hierarchy::SphereTree;
use super::params::BuildParams;
use super::targets::Target;

/// Shared, read-only inputs of the per-origin builds.
pub struct Ctx<'a> {
    /// The targets in the hierarchy's leaf order: `targets[k]` is primitive `bvh.order[k]`,
    /// so that a walk of the hierarchy reads them in memory order.
    pub targets: &'a [Target],
    pub bvh: &'a SphereTree,
    pub eps: f64,
    pub delta: f64,
}

impl<'a> Ctx<'a> {
    pub fn new(targets: &'a [Target], bvh: &'a SphereTree, eps: f64, params: &BuildParams) -> Self {
        Ctx { targets, bvh, eps, delta: params.delta }
    }
}
