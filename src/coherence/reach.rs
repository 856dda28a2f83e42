//! How long a walk of the flattened tables can be: the longest merged list (cell + always) a
//! nearest-hit walk, an eye ray's walk and a shadow walk may meet, in loop iterations (an
//! entry each), and whether any ray of a render falls back to walking every primitive. The
//! GPU's loop budget and tile size are set from these.

use super::flat::{FlatTables, OriginKind, NO_ORIGIN};
use crate::scene::Scene;

/// Bounds on the walks of one set of tables.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WalkBounds {
    /// Loop iterations of the longest walk of a nearest-hit query, of an eye ray, of a
    /// shadow ray.
    pub worst_closest: u64,
    pub worst_eye: u64,
    pub worst_shadow: u64,
    /// Mean entries per stored cell (a rough cost of one walk, for the tile size).
    pub mean_list: f64,
    /// Loop iterations a wave's passes are planned for
    /// ([`crate::layout::budget::retry_passes`]): the longest walk where it is known (the
    /// tables' longest list), a typical one where the worst is far out of reach (a BVH's,
    /// every node). A walk that outlasts the plan makes its tile run again with another
    /// pass per depth; every planned pass costs a dispatch even when its queue is empty.
    pub planned: u64,
    /// Whether some ray of the render walks the fallback origin (every primitive).
    pub fallback_reachable: bool,
    /// Whether the eye rays walk what rays leaving surfaces walk (the eye has no table and
    /// the render has a BVH or ray queries: `--accel auto`).
    pub eye_untabled: bool,
    /// Whether a pass may walk the tables and the BVH (rays leaving surfaces) side by side:
    /// the shadow jobs of a light with a table and of one without.
    pub mixed: bool,
}

/// Whether the eye of a non-empty scene has no table in `flat`.
fn eye_untabled(scene: &Scene, flat: &FlatTables) -> bool {
    flat.eye_origin == NO_ORIGIN && !scene.primitives.is_empty()
}

impl WalkBounds {
    /// The bounds of walks that may take either `self`'s or `other`'s: the tables' for eye
    /// rays, and for rays leaving surfaces the BVH's.
    pub fn or(&self, other: &WalkBounds) -> WalkBounds {
        WalkBounds {
            worst_closest: self.worst_closest.max(other.worst_closest),
            worst_eye: if self.eye_untabled { other.worst_eye } else { self.worst_eye },
            worst_shadow: self.worst_shadow.max(other.worst_shadow),
            mean_list: self.mean_list.max(other.mean_list),
            planned: self.planned.max(other.planned),
            fallback_reachable: self.fallback_reachable,
            eye_untabled: self.eye_untabled,
            mixed: true,
        }
    }

    /// The bounds of `flat`, built for `scene`, for a render that has a walk for rays
    /// leaving surfaces (`surface_walk`: the BVH or ray queries, which the eye's rays take
    /// where it has no table) or not (they walk the fallback origin).
    pub fn of(scene: &Scene, flat: &FlatTables, surface_walk: bool) -> WalkBounds {
        let untabled = eye_untabled(scene, flat);
        let mut b = WalkBounds {
            fallback_reachable: untabled && !surface_walk,
            eye_untabled: untabled && surface_walk,
            ..Default::default()
        };
        for (o, org) in flat.origins.iter().enumerate() {
            if org.kind == OriginKind::Fallback as u32 {
                continue;
            }
            let mut longest = 0u64;
            for f in &flat.faces[o * 6..o * 6 + 6] {
                for c in f.cell_base..f.cell_base + f.width * f.height {
                    let len = (flat.cell_start[c as usize + 1] - flat.cell_start[c as usize]) as u64;
                    longest = longest.max(len);
                }
            }
            let list = longest + org.always_count as u64;
            if org.kind == OriginKind::Eye as u32 {
                b.worst_eye = b.worst_eye.max(list);
            }
            if org.kind == OriginKind::Light as u32 {
                b.worst_shadow = b.worst_shadow.max(list);
            } else {
                b.worst_closest = b.worst_closest.max(list);
            }
        }
        let n = scene.primitives.len() as u64;
        if b.fallback_reachable {
            b.worst_closest = b.worst_closest.max(n);
            b.worst_eye = b.worst_eye.max(n);
            b.worst_shadow = b.worst_shadow.max(n);
        }
        let fallback = flat.origins.get(flat.fallback_origin as usize).map_or(0, |o| o.always_count as usize);
        b.mean_list = (flat.entries.len() - fallback) as f64 / flat.cells().max(1) as f64;
        b.planned = b.worst_closest.max(b.worst_shadow);
        b
    }
}
