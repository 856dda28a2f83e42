//! The flattened tables: plain `#[repr(C)]` buffers for the GPU, and their layout.
//!
//! Nine storage buffers, each at most 128 MiB (wgpu's default
//! `max_storage_buffer_binding_size`):
//!
//! ```text
//! origins:    array<GpuOrigin>      one per direction cube (the eye, each light with a table,
//!                                   and the fallback origin last)
//! faces:      array<GpuFace>        six per origin, at origin·6 + face
//! cell_start: array<u32>            one per stored cell, plus one: cell c lists
//!                                   entries[cell_start[c] .. cell_start[c+1]]
//! entries:    array<GpuEntry>       candidate lists, each sorted by increasing d_min: the
//!                                   cells', then the always lists, then the beams' leaves,
//!                                   then the fallback origin's
//! prim_beams:   array<u32>          per primitive: 1 when the rays leaving it are classified
//!                                   into the beams, 0 when they walk the fallback origin
//! beam_nodes:   array<GpuBeamNode>  the beam tree (see [`super::beams`]), its root first
//! light_origin: array<u32>          per light: the origin of its shadow rays, or 0xffffffff
//! groups:       array<GpuGroup>     primitive groups (see [`super::groups`]): a camera-relative
//!                                   bounding sphere and group_prims[first .. first + count]
//! group_prims:  array<u32>          the primitives of every group, group after group
//! ```
//!
//! An entry whose id has bit 31 ([`GROUP_BIT`]) set names group `id & 0x7fffffff` (see
//! [`super::groups`]): the walker tests the group's sphere and, if the ray meets it in time,
//! every member. The last origin is the fallback ([`OriginKind::Fallback`]): every primitive
//! in its always-test list with `d_min` 0, walked by rays whose origin entity has no table.
//!
//! The structs are the Rust twins of the WGSL structs of the same names in
//! `shaders/shared/tables.wgsl` (keep them in sync; `tests/it/twins.rs` compares the layouts).
//! Every field is a 4-byte scalar, so WGSL's and C's layouts agree and no implicit padding
//! exists.
//!
//! An origin's direction cube has `n`×`n` cells per face, but only a window of each face is
//! stored: cells `iu0 .. iu0+width` × `iv0 .. iv0+height`, row by row from `cell_base`
//! (`cell = cell_base + (iv − iv0)·width + (iu − iu0)`); directions outside the window have
//! an empty list (no object lies that way). The origin's always-test list is
//! `entries[always_start .. always_start + always_count]`, also sorted by `d_min`: objects
//! that meet most of the origin's cells are stored there once instead of in every cell. The
//! walker merges the two lists by `d_min` (see [`super::walk`]).
//!
//! `d_min` is a lower bound on the distance (unit directions) at which the ray can hit the
//! object, already lowered for f32 rounding; `f32::MAX` is never stored.

use bytemuck::{Pod, Zeroable};
use serde::Serialize;

/// Per-origin record; `kind` is an [`OriginKind`]. Keep in sync with `GpuOrigin` in
/// `shaders/shared/tables.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuOrigin {
    pub n: u32,
    pub always_start: u32,
    pub always_count: u32,
    pub kind: u32,
}

/// The stored window of one face of an origin's cube. Keep in sync with `GpuFace` in
/// `shaders/shared/tables.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuFace {
    pub iu0: u32,
    pub iv0: u32,
    pub width: u32,
    pub height: u32,
    pub cell_base: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// One candidate: a primitive id (or a group, [`GROUP_BIT`]) and the lower bound of its hit
/// distance. Keep in sync with `GpuEntry` in `shaders/shared/tables.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEntry {
    pub id: u32,
    pub d_min: f32,
}

/// A group of primitives: its bounding sphere relative to the camera's eye (f32, widened
/// for rounding) and its members `group_prims[first..first + count]`. Keep in sync with
/// `GpuGroup` in `shaders/shared/tables.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGroup {
    pub cx: f32,
    pub cy: f32,
    pub cz: f32,
    pub radius: f32,
    pub first: u32,
    pub count: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// A node of the beam tree (see [`super::beams`]): an inner node sends a ray to child `a`
/// or `a + 1` by its origin (`axis` 0–2: `o[axis] >= split` as an f32 goes to `a + 1`) or
/// its direction (`axis` 3, 4: the direction's cell `iu`, `iv` on a [`BEAM_CELLS`]-cube,
/// `>= split` goes to `a + 1`), or to child `a + face` by the direction's face (`axis`
/// [`BEAM_FACE`]); a leaf (`axis` [`BEAM_LEAF`]) lists `entries[a..b]`. Keep in sync with
/// `GpuBeamNode` in `shaders/shared/tables.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuBeamNode {
    pub axis: u32,
    pub split: u32,
    pub a: u32,
    pub b: u32,
}

/// [`GpuBeamNode::axis`] of a leaf (WGSL `BEAM_LEAF`, keep them in sync).
pub const BEAM_LEAF: u32 = 5;

/// [`GpuBeamNode::axis`] of a split by face (WGSL `BEAM_FACE`, keep them in sync).
pub const BEAM_FACE: u32 = 6;

/// Cells per face edge of the direction cube whose cells the beams' direction splits name
/// (WGSL `BEAM_CELLS`, keep them in sync).
pub const BEAM_CELLS: u32 = 4096;

/// The deepest beam-tree node, counted from the root at depth 0 (WGSL `BEAM_DEPTH`, keep
/// them in sync): the kernels' descent loop stops there.
pub const BEAM_DEPTH: u32 = 64;

/// wgpu's default (and lavapipe's) limit on one storage buffer binding.
pub const MAX_BINDING_BYTES: usize = 128 << 20;

/// Set in [`GpuEntry::id`] for a group entry: the rest of the id is the group's index (WGSL
/// `GROUP_BIT` in `shaders/shared/tables.wgsl`, keep them in sync).
pub const GROUP_BIT: u32 = 1 << 31;

/// "No origin": a primitive or light without a table (WGSL `NO_ORIGIN`, keep them in sync).
pub const NO_ORIGIN: u32 = u32::MAX;

/// Origin kinds as stored in [`GpuOrigin::kind`] (for statistics and checks; the kernels do
/// not read it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum OriginKind {
    Eye = 0,
    Light = 1,
    /// The origin every ray without a table of its own walks: all primitives.
    Fallback = 2,
}

/// The flattened tables, ready for upload (`bytemuck::cast_slice` each vector).
#[derive(Clone, Debug, Default)]
pub struct FlatTables {
    pub origins: Vec<GpuOrigin>,
    pub faces: Vec<GpuFace>,
    pub cell_start: Vec<u32>,
    pub entries: Vec<GpuEntry>,
    /// Per primitive: 1 when the rays leaving it are classified into the beams, else 0.
    pub prim_beams: Vec<u32>,
    /// The beam tree (empty: no beams), its root first.
    pub beam_nodes: Vec<GpuBeamNode>,
    /// The box of ray origins the beams classify, relative to the camera's eye: rays from
    /// outside it walk the fallback origin. Empty (`lo > hi`) without beams.
    pub beam_lo: [f32; 3],
    pub beam_hi: [f32; 3],
    /// Per light (index into `Scene::lights`): its light origin, or `u32::MAX` (directional
    /// lights, or no shadow tables).
    pub light_origin: Vec<u32>,
    /// The eye origin, or `u32::MAX` for an empty scene.
    pub eye_origin: u32,
    /// The fallback origin (the last).
    pub fallback_origin: u32,
    /// The groups that entries name (empty when no list is grouped).
    pub groups: Vec<GpuGroup>,
    pub group_prims: Vec<u32>,
}

impl FlatTables {
    /// Bytes of all buffers together.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.origins.as_slice())
            + std::mem::size_of_val(self.faces.as_slice())
            + std::mem::size_of_val(self.cell_start.as_slice())
            + std::mem::size_of_val(self.entries.as_slice())
            + std::mem::size_of_val(self.prim_beams.as_slice())
            + std::mem::size_of_val(self.beam_nodes.as_slice())
            + std::mem::size_of_val(self.light_origin.as_slice())
            + std::mem::size_of_val(self.groups.as_slice())
            + std::mem::size_of_val(self.group_prims.as_slice())
    }

    /// The largest single buffer, which must not exceed [`MAX_BINDING_BYTES`].
    pub fn largest_buffer_bytes(&self) -> usize {
        [
            std::mem::size_of_val(self.origins.as_slice()),
            std::mem::size_of_val(self.faces.as_slice()),
            std::mem::size_of_val(self.cell_start.as_slice()),
            std::mem::size_of_val(self.entries.as_slice()),
            std::mem::size_of_val(self.prim_beams.as_slice()),
            std::mem::size_of_val(self.beam_nodes.as_slice()),
        ]
        .into_iter()
        .max()
        .unwrap_or(0)
    }

    /// Number of stored cells.
    pub fn cells(&self) -> usize {
        self.cell_start.len().saturating_sub(1)
    }

    /// Checks the structural invariants the WGSL relies on: ranges in bounds, windows inside
    /// the cube, lists sorted by `d_min`, finite `d_min`, ids in range.
    pub fn check(&self, primitives: usize) -> crate::error::Result<()> {
        self.check_lists(primitives).map_err(crate::error::Error::TablesInvalid)
    }

    /// [`FlatTables::check`], and that the per-primitive and per-light indices fit a scene of
    /// `primitives` primitives and `lights` lights: for tables that were not built here (read
    /// from a file), whose every index the kernels will follow.
    pub fn check_scene(&self, primitives: usize, lights: usize) -> crate::error::Result<()> {
        self.check(primitives)?;
        let bad = |m: String| Err(crate::error::Error::TablesInvalid(m));
        let origins = self.origins.len() as u64;
        let fits = |o: u32| o == NO_ORIGIN || (o as u64) < origins;
        if !fits(self.eye_origin) {
            return bad(format!("the eye origin {} is out of range", self.eye_origin));
        }
        if self.prim_beams.len() != primitives {
            return bad(format!(
                "{} primitive beam flags for {primitives} primitives",
                self.prim_beams.len()
            ));
        }
        if self.light_origin.len() != lights {
            return bad(format!("{} light origins for {lights} lights", self.light_origin.len()));
        }
        if let Some(o) = self.light_origin.iter().find(|&&o| !fits(o)) {
            return bad(format!("light origin {o} is out of range"));
        }
        Ok(())
    }

    fn check_lists(&self, primitives: usize) -> Result<(), String> {
        if self.faces.len() != self.origins.len() * 6 {
            return Err("faces is not six per origin".into());
        }
        let last = self.origins.len().checked_sub(1);
        let fallback = self.origins.get(self.fallback_origin as usize);
        if last != Some(self.fallback_origin as usize)
            || fallback.is_none_or(|o| {
                o.kind != OriginKind::Fallback as u32 || o.always_count as usize != primitives
            })
        {
            return Err("the last origin is not the fallback listing every primitive".into());
        }
        let ncells = self.cells() as u64;
        for (o, org) in self.origins.iter().enumerate() {
            if org.n == 0 {
                return Err(format!("origin {o}: n = 0"));
            }
            let a = org.always_start as usize;
            let b = a + org.always_count as usize;
            if b > self.entries.len() {
                return Err(format!("origin {o}: always list out of range"));
            }
            check_sorted(&self.entries[a..b]).map_err(|e| format!("origin {o} always list: {e}"))?;
            for f in 0..6 {
                let w = self.faces[o * 6 + f];
                if w.width == 0 || w.height == 0 {
                    continue;
                }
                if w.iu0 as u64 + w.width as u64 > org.n as u64
                    || w.iv0 as u64 + w.height as u64 > org.n as u64
                {
                    return Err(format!("origin {o} face {f}: window outside the cube"));
                }
                if w.cell_base as u64 + (w.width as u64) * (w.height as u64) > ncells {
                    return Err(format!("origin {o} face {f}: cells out of range"));
                }
            }
        }
        for c in 0..self.cells() {
            let (a, b) = (self.cell_start[c] as usize, self.cell_start[c + 1] as usize);
            if a > b || b > self.entries.len() {
                return Err(format!("cell {c}: bad range {a}..{b}"));
            }
            check_sorted(&self.entries[a..b])
                .map_err(|e| format!("cell {c}: {e}: {:?}", &self.entries[a..b]))?;
        }
        if let Some(id) = self.prim_beams.iter().position(|&b| b > 1) {
            return Err(format!("primitive {id}: beam flag {} is not 0 or 1", self.prim_beams[id]));
        }
        self.check_beams()?;
        let bit = GROUP_BIT;
        if let Some(e) = self.entries.iter().find(|e| {
            if e.id & bit != 0 {
                (e.id & !bit) as usize >= self.groups.len()
            } else {
                e.id as usize >= primitives
            }
        }) {
            return Err(format!("entry id {:#x} out of range", e.id));
        }
        for (g, grp) in self.groups.iter().enumerate() {
            let end = grp.first as u64 + grp.count as u64;
            if grp.count == 0 || end > self.group_prims.len() as u64 {
                return Err(format!("group {g}: members out of range"));
            }
            if ![grp.cx, grp.cy, grp.cz, grp.radius].iter().all(|x| x.is_finite()) {
                return Err(format!("group {g}: sphere not finite"));
            }
        }
        if let Some(p) = self.group_prims.iter().find(|&&p| p as usize >= primitives) {
            return Err(format!("group member {p} out of range"));
        }
        if self.largest_buffer_bytes() > MAX_BINDING_BYTES {
            return Err(format!(
                "a buffer has {} bytes, over the 128 MiB binding limit",
                self.largest_buffer_bytes()
            ));
        }
        Ok(())
    }
}

impl FlatTables {
    /// The beam tree: every child after its parent (so a descent ends), no node deeper than
    /// [`BEAM_DEPTH`], leaves sorted and in range, finite splits, a finite box.
    fn check_beams(&self) -> Result<(), String> {
        let nodes = &self.beam_nodes;
        if nodes.is_empty() {
            return Ok(());
        }
        if !self.beam_lo.iter().chain(&self.beam_hi).all(|x| x.is_finite()) {
            return Err("the beams' box is not finite".into());
        }
        let mut depth = vec![0u32; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            let children = match n.axis {
                BEAM_LEAF => {
                    if n.a > n.b || n.b as usize > self.entries.len() {
                        return Err(format!("beam leaf {i}: bad range {}..{}", n.a, n.b));
                    }
                    check_sorted(&self.entries[n.a as usize..n.b as usize])
                        .map_err(|e| format!("beam leaf {i}: {e}"))?;
                    continue;
                }
                BEAM_FACE => 6,
                0..=2 if !f32::from_bits(n.split).is_finite() => {
                    return Err(format!("beam node {i}: split is not finite"));
                }
                3 | 4 if n.split >= BEAM_CELLS => {
                    return Err(format!("beam node {i}: split {} past the cells", n.split));
                }
                0..=4 => 2,
                a => return Err(format!("beam node {i}: axis {a}")),
            };
            if (n.a as usize) <= i || n.a as usize + children > nodes.len() {
                return Err(format!("beam node {i}: children {} out of order or range", n.a));
            }
            let d = depth[i] + 1;
            if d > BEAM_DEPTH {
                return Err(format!("beam node {i}: deeper than {BEAM_DEPTH}"));
            }
            depth[n.a as usize..n.a as usize + children].fill(d);
        }
        Ok(())
    }
}

fn check_sorted(list: &[GpuEntry]) -> Result<(), String> {
    for e in list {
        if !(e.d_min.is_finite() && e.d_min >= 0.0) {
            return Err(format!("d_min {} of {} is not finite and non-negative", e.d_min, e.id));
        }
    }
    if list.windows(2).any(|w| w[0].d_min > w[1].d_min) {
        return Err("not sorted by d_min".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_match_the_wgsl_twins() {
        assert_eq!(std::mem::size_of::<GpuOrigin>(), 16);
        assert_eq!(std::mem::size_of::<GpuFace>(), 32);
        assert_eq!(std::mem::size_of::<GpuEntry>(), 8);
        assert_eq!(std::mem::align_of::<GpuEntry>(), 4);
        assert_eq!(std::mem::size_of::<GpuGroup>(), 32);
        assert_eq!(std::mem::size_of::<GpuBeamNode>(), 16);
    }
}
