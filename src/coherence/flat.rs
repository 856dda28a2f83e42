//! The flattened tables: plain `#[repr(C)]` buffers for the GPU, and their layout.
//!
//! Nine storage buffers, each at most 128 MiB (wgpu's default
//! `max_storage_buffer_binding_size`):
//!
//! ```text
//! origins:    array<GpuOrigin>      one per origin entity (eye, light, surface cluster,
//!                                   and the fallback origin last)
//! faces:      array<GpuFace>        six per origin, at origin·6 + face
//! cell_start: array<u32>            one per stored cell, plus one: cell c lists
//!                                   entries[cell_start[c] .. cell_start[c+1]]
//! entries:    array<GpuEntry>       candidate lists, each sorted by increasing d_min
//! prim_origin:  array<u32>          per primitive: the origin its secondary rays use, or 0xffffffff;
//!                                   for a primitive split into m×m surface patches, the first
//!                                   of its m² consecutive origins
//! prim_patches: array<u32>          per primitive: m (1: one origin for the whole primitive);
//!                                   a ray origin's patch is [`super::patches::triangle_patch`]
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
//! `shaders/shared/tables.wgsl` (keep them in sync; `tests/twins.rs` compares the layouts).
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
    Surface = 2,
    /// The origin every ray without a table of its own walks: all primitives.
    Fallback = 3,
}

/// The flattened tables, ready for upload (`bytemuck::cast_slice` each vector).
#[derive(Clone, Debug, Default)]
pub struct FlatTables {
    pub origins: Vec<GpuOrigin>,
    pub faces: Vec<GpuFace>,
    pub cell_start: Vec<u32>,
    pub entries: Vec<GpuEntry>,
    /// Per primitive: its surface origin (the first of its patches), or `u32::MAX`.
    pub prim_origin: Vec<u32>,
    /// Per primitive: patches per side `m` (1: not split).
    pub prim_patches: Vec<u32>,
    /// The f32 vertices of each split triangle relative to the camera's eye (the frame of
    /// the GPU and of the f32 walkers), for the CPU's patch lookup; the GPU uses its own copy
    /// of the primitive. Not uploaded.
    pub patch_tris: std::collections::HashMap<u32, [glam::Vec3; 3]>,
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
            + std::mem::size_of_val(self.prim_origin.as_slice())
            + std::mem::size_of_val(self.prim_patches.as_slice())
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
            std::mem::size_of_val(self.prim_origin.as_slice()),
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
        if self.prim_origin.len() != primitives {
            return bad(format!("{} primitive origins for {primitives} primitives", self.prim_origin.len()));
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
        if self.prim_patches.len() != self.prim_origin.len() {
            return Err("prim_patches and prim_origin differ in length".into());
        }
        for (id, (&o, &m)) in self.prim_origin.iter().zip(&self.prim_patches).enumerate() {
            if m == 0 || (o != u32::MAX && o as u64 + (m as u64) * (m as u64) > self.origins.len() as u64) {
                return Err(format!("primitive {id}: patches {m} from origin {o} out of range"));
            }
        }
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
    }
}
