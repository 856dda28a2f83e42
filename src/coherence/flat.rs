//! The flattened tables: plain `#[repr(C)]` buffers for the GPU, and their layout.
//!
//! Five storage buffers, each at most 128 MiB (wgpu's default
//! `max_storage_buffer_binding_size`):
//!
//! ```text
//! origins:      array<GpuOrigin>    one per direction cube (the eye, each light with a table,
//!                                   and the fallback origin last)
//! faces:        array<GpuFace>      six per origin, at origin·6 + face
//! cell_start:   array<u32>          one per stored cell, plus one: cell c lists
//!                                   entries[cell_start[c] .. cell_start[c+1]]
//! entries:      array<GpuEntry>     candidate lists, each sorted by increasing d_min: the
//!                                   cells', then the always lists, then the fallback origin's
//! light_origin: array<u32>          per light: the origin of its shadow rays, or 0xffffffff
//! ```
//!
//! The last origin is the fallback ([`OriginKind::Fallback`]): every primitive in its
//! always-test list with `d_min` 0, walked by rays whose origin entity has no table.
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

/// One candidate: a primitive id and the lower bound of its hit distance. Keep in sync with `GpuEntry` in `shaders/shared/tables.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEntry {
    pub id: u32,
    pub d_min: f32,
}

/// wgpu's default (and lavapipe's) limit on one storage buffer binding.
pub const MAX_BINDING_BYTES: usize = 128 << 20;

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
    /// Per light (index into `Scene::lights`): its light origin, or `u32::MAX` (directional
    /// lights, or no shadow tables).
    pub light_origin: Vec<u32>,
    /// The eye origin, or `u32::MAX` for an empty scene.
    pub eye_origin: u32,
    /// The fallback origin (the last).
    pub fallback_origin: u32,
}

impl FlatTables {
    /// Bytes of all buffers together.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.origins.as_slice())
            + std::mem::size_of_val(self.faces.as_slice())
            + std::mem::size_of_val(self.cell_start.as_slice())
            + std::mem::size_of_val(self.entries.as_slice())
            + std::mem::size_of_val(self.light_origin.as_slice())
    }

    /// The largest single buffer, which must not exceed [`MAX_BINDING_BYTES`].
    pub fn largest_buffer_bytes(&self) -> usize {
        [
            std::mem::size_of_val(self.origins.as_slice()),
            std::mem::size_of_val(self.faces.as_slice()),
            std::mem::size_of_val(self.cell_start.as_slice()),
            std::mem::size_of_val(self.entries.as_slice()),
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

    /// [`FlatTables::check`], and that the per-light indices fit a scene of `primitives`
    /// primitives and `lights` lights: for tables that were not built here (read
    /// from a file), whose every index the kernels will follow.
    pub fn check_scene(&self, primitives: usize, lights: usize) -> crate::error::Result<()> {
        self.check(primitives)?;
        let bad = |m: String| Err(crate::error::Error::TablesInvalid(m));
        let origins = self.origins.len() as u64;
        let fits = |o: u32| o == NO_ORIGIN || (o as u64) < origins;
        if !fits(self.eye_origin) {
            return bad(format!("the eye origin {} is out of range", self.eye_origin));
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
        if let Some(e) = self.entries.iter().find(|e| e.id as usize >= primitives) {
            return Err(format!("entry id {} out of range", e.id));
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
    }
}
