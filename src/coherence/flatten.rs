//! Flattening: the built direction cubes become the buffers the walkers read
//! ([`FlatTables`]): the cubes' cell lists in order, then their always-test lists, the
//! fallback origin (the last origin) and its list of every primitive, and the per-light
//! origin indices.

use super::defs::OriginDef;
use super::flat::{FlatTables, GpuEntry, GpuFace, GpuOrigin, OriginKind};
use super::lists::OriginTable;

/// Flattens built direction cubes and the fallback origin into the GPU buffers.
pub fn flatten(tables: &[OriginTable], defs: &[OriginDef], primitives: usize, lights: usize) -> FlatTables {
    let mut flat =
        FlatTables { light_origin: vec![u32::MAX; lights], eye_origin: u32::MAX, ..FlatTables::default() };
    let cells: usize = tables.iter().map(|t| t.starts.len() - 1).sum();
    let entries: usize = tables.iter().map(|t| t.entries.len() + t.always.len()).sum();
    flat.cell_start.reserve(cells + 1);
    flat.entries.reserve(entries);
    // Cell lists first, all origins in order, so that cell ranges tile the array; the
    // always-test lists follow them.
    for (o, (t, def)) in tables.iter().zip(defs).enumerate() {
        flat.origins.push(GpuOrigin {
            n: t.n,
            always_start: 0,
            always_count: t.always.len() as u32,
            kind: def.kind as u32,
        });
        let base = flat.entries.len() as u32;
        let mut cell_base = flat.cell_start.len() as u32;
        for w in &t.faces {
            flat.faces.push(GpuFace {
                iu0: w[0],
                iv0: w[1],
                width: w[2],
                height: w[3],
                cell_base: if w[2] == 0 { 0 } else { cell_base },
                ..GpuFace::default()
            });
            cell_base += w[2] * w[3];
        }
        flat.cell_start.extend(t.starts[..t.starts.len() - 1].iter().map(|s| base + s));
        flat.entries.extend_from_slice(&t.entries);
        match def.kind {
            OriginKind::Eye => flat.eye_origin = o as u32,
            OriginKind::Light => flat.light_origin[def.light.unwrap()] = o as u32,
            // Appended last (`append_fallback`), never built.
            OriginKind::Fallback => {}
        }
    }
    flat.cell_start.push(flat.entries.len() as u32);
    for (o, t) in tables.iter().enumerate() {
        flat.origins[o].always_start = flat.entries.len() as u32;
        flat.entries.extend_from_slice(&t.always);
    }
    append_fallback(&mut flat, primitives);
    flat
}

/// Appends the fallback origin: every primitive in its always-test list (`d_min` 0,
/// ascending ids) and empty faces. A ray whose origin entity has no table walks it, which is
/// brute force with the walker's own code and tie rule.
pub fn append_fallback(flat: &mut FlatTables, primitives: usize) {
    let n = primitives as u32;
    flat.fallback_origin = flat.origins.len() as u32;
    let always_start = flat.entries.len() as u32;
    flat.entries.extend((0..n).map(|id| GpuEntry { id, d_min: 0.0 }));
    flat.origins.push(GpuOrigin { n: 1, always_start, always_count: n, kind: OriginKind::Fallback as u32 });
    flat.faces.extend([GpuFace::default(); 6]);
}
