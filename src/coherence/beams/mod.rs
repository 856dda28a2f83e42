//! Ray classification (Arvo and Kirk, "Fast ray tracing by ray classification", 1987) for
//! the rays that leave surfaces: reflection and refraction rays, and shadow rays towards
//! lights without a table of their own. Built only when asked for ([`BuildParams::beams`],
//! `--accel beams`); by default those rays walk the BVH.
//!
//! [`BuildParams::beams`]: crate::coherence::BuildParams::beams
//!
//! Such rays have no single origin point, so a direction cube around one entity serves them
//! badly. A *beam* is a box of origins × a rectangle of directions on one face of the
//! direction cube: every ray starting in the box with its direction in the rectangle. The
//! beams form a tree ([`BeamTree`]): the box of all the points such rays leave from (the
//! surfaces that spawn them, widened by the spawn offset) is split into clusters of a few
//! spawning primitives, each cluster by face into six beams, and a beam splits its box at a
//! plane or its rectangle at a cell boundary of a [`BEAM_CELLS`]-cube. A leaf lists every
//! primitive a ray of its beam can hit, sorted by a lower bound on the distance, cut off
//! where one primitive covers the whole beam ([`build`]). Only the beams that rays use are
//! subdivided below the clusters: a pilot pass ([`pilot`]) traces a lattice of the whole
//! image's rays through the tree as it grows, generation by generation, and splits the
//! leaves whose rays test too many candidates. A beam the pilot never refined keeps its
//! parent's list, which is conservative too: the tables never depend on which rays went
//! where, only on how fast they are.
//!
//! A ray finds its leaf by descending the tree (WGSL `beam_range` in
//! `shaders/shared/tables.wgsl`, twin of [`beam_range`]); its origin's comparisons are made
//! in the kernels' f32 frame around the eye, so the tree keeps its origin splits in the world
//! frame and converts them for each eye ([`BeamTree::frame`]). The leaf's list is then walked
//! by the one walker ([`super::walk`]), as a cell list without an always list.

pub mod build;
pub mod pilot;

use glam::{DVec3, Vec3};

use super::cube::cube_face_cell;
use super::flat::{FlatTables, GpuBeamNode, GpuEntry, BEAM_CELLS, BEAM_FACE, BEAM_LEAF};
use crate::bvh::{f32_down, f32_up};

/// A node of the beam tree as built, in the world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BeamNode {
    /// Split by the origin: `o[axis] >= split` (world) goes to `left + 1`.
    Origin { axis: u8, split: f64, left: u32 },
    /// Split by the direction's cell: `iu` (`axis` 0) or `iv` (1) `>= split` goes to `left + 1`.
    Dir { axis: u8, split: u32, left: u32 },
    /// Split by the direction's face `f`: goes to `first + f`.
    Face { first: u32 },
    /// A beam and its list (index into [`BeamTree::lists`]).
    Leaf { list: u32 },
}

/// The beam tree of a scene, as built (see the module documentation).
#[derive(Clone, Debug, Default)]
pub struct BeamTree {
    /// Node 0 is the root; children follow their parents.
    pub nodes: Vec<BeamNode>,
    /// Per leaf: its candidates, `d_min` stored as the walker reads it, sorted, long lists
    /// naming groups.
    pub lists: Vec<Vec<GpuEntry>>,
    /// The box of the origins the tree classifies (world).
    pub lo: DVec3,
    pub hi: DVec3,
    /// Per primitive: whether the rays leaving it are classified.
    pub spawners: Vec<bool>,
    /// What the build did (for statistics).
    pub stats: BeamStats,
}

/// What building the beam tree did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct BeamStats {
    /// Rays the pilot traced through the beams, and how many of those it refined for.
    pub pilot_rays: u64,
    /// Clusters of the origin tree, leaves, and the deepest node.
    pub clusters: usize,
    pub leaves: usize,
    pub depth: u32,
    /// Entries in all leaf lists, and the longest list.
    pub entries: usize,
    pub max_list: usize,
    /// The mean estimated tests per pilot ray at the end (entries before its hit).
    pub pilot_cost: f64,
    /// Seconds in the pilot's tracing and in splitting.
    pub trace_s: f64,
    pub split_s: f64,
    /// Whether the memory budget stopped the refinement.
    pub over_budget: bool,
}

impl BeamTree {
    /// Appends the tree to `flat` for a camera at `eye`: leaf lists into `entries`, the
    /// nodes, the per-primitive flags and the box.
    pub fn append_to(&self, flat: &mut FlatTables, eye: DVec3) {
        let mut ranges = Vec::with_capacity(self.lists.len());
        for list in &self.lists {
            let a = flat.entries.len() as u32;
            flat.entries.extend_from_slice(list);
            ranges.push((a, flat.entries.len() as u32));
        }
        flat.beam_nodes = self
            .nodes
            .iter()
            .map(|n| match *n {
                BeamNode::Origin { axis, left, .. } => {
                    GpuBeamNode { axis: axis as u32, split: 0, a: left, b: 0 }
                }
                BeamNode::Dir { axis, split, left } => {
                    GpuBeamNode { axis: 3 + axis as u32, split, a: left, b: 0 }
                }
                BeamNode::Face { first } => GpuBeamNode { axis: BEAM_FACE, split: 0, a: first, b: 0 },
                BeamNode::Leaf { list } => {
                    let (a, b) = ranges[list as usize];
                    GpuBeamNode { axis: BEAM_LEAF, split: 0, a, b }
                }
            })
            .collect();
        flat.prim_beams = self.spawners.iter().map(|&s| s as u32).collect();
        self.frame(flat, eye);
    }

    /// Sets the origin splits and the box of `flat`'s copy of the tree for a camera at `eye`.
    /// A split rounds to the nearest f32, so it may move by half an f32 step of the
    /// coordinates; the build widens every box by the spawn-offset bound, which is larger.
    pub fn frame(&self, flat: &mut FlatTables, eye: DVec3) {
        for (g, n) in flat.beam_nodes.iter_mut().zip(&self.nodes) {
            if let BeamNode::Origin { axis, split, .. } = *n {
                g.split = ((split - eye[axis as usize]) as f32).to_bits();
            }
        }
        if self.nodes.is_empty() {
            flat.beam_lo = [f32::MAX; 3];
            flat.beam_hi = [-f32::MAX; 3];
        } else {
            let (lo, hi) = (self.lo - eye, self.hi - eye);
            flat.beam_lo = [f32_down(lo.x), f32_down(lo.y), f32_down(lo.z)];
            flat.beam_hi = [f32_up(hi.x), f32_up(hi.y), f32_up(hi.z)];
        }
    }
}

/// Whether `at` (camera-relative f32) lies in the beams' box (WGSL `in_beams`).
pub fn in_beams(t: &FlatTables, at: Vec3) -> bool {
    !t.beam_nodes.is_empty() && (0..3).all(|k| at[k] >= t.beam_lo[k] && at[k] <= t.beam_hi[k])
}

/// The range of `t.entries` listing the beam of the ray from `at` along `d` (not zero), which
/// must lie in the beams' box ([`in_beams`]): the twin of WGSL `beam_range` (keep them in
/// sync).
pub fn beam_range(t: &FlatTables, at: Vec3, d: Vec3) -> [u32; 2] {
    let fc = cube_face_cell(d, BEAM_CELLS);
    let mut k = 0;
    loop {
        let n = t.beam_nodes[k as usize];
        k = match n.axis {
            BEAM_LEAF => return [n.a, n.b],
            BEAM_FACE => n.a + fc[0],
            0..=2 => n.a + (at[n.axis as usize] >= f32::from_bits(n.split)) as u32,
            _ => n.a + (fc[n.axis as usize - 2] >= n.split) as u32,
        };
    }
}
