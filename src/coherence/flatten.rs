//! Flattening: the built origin tables become the buffers the walkers read
//! ([`FlatTables`]): cell lists of every origin in order, then the always-test lists, the
//! per-primitive and per-light origin indices, the groups, the eye-relative f32 data the
//! lookups need, and the fallback origin last.

use glam::DVec3;

use super::defs::OriginDef;
use super::flat::{FlatTables, GpuEntry, GpuFace, GpuOrigin, OriginKind, GROUP_BIT};
use super::groups::Groups;
use super::lists::OriginTable;
use super::targets::{Shape, Target};

/// Flattens built origin tables into the GPU buffers.
pub fn flatten(
    tables: &[OriginTable],
    defs: &[OriginDef],
    primitives: usize,
    lights: usize,
    groups: &Groups,
) -> FlatTables {
    let mut flat = FlatTables {
        prim_origin: vec![u32::MAX; primitives],
        prim_patches: vec![1; primitives],
        light_origin: vec![u32::MAX; lights],
        eye_origin: u32::MAX,
        ..FlatTables::default()
    };
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
            OriginKind::Surface => match def.patch {
                // Patches are consecutive origins; the first is the primitive's base.
                Some((m, 0)) => {
                    flat.prim_origin[def.members[0] as usize] = o as u32;
                    flat.prim_patches[def.members[0] as usize] = m;
                }
                Some(_) => {}
                None => {
                    for &m in &def.members {
                        flat.prim_origin[m as usize] = o as u32;
                    }
                }
            },
            // Appended after flattening (`append_fallback`), never built.
            OriginKind::Fallback => {}
        }
    }
    flat.cell_start.push(flat.entries.len() as u32);
    for (o, t) in tables.iter().enumerate() {
        flat.origins[o].always_start = flat.entries.len() as u32;
        flat.entries.extend_from_slice(&t.always);
    }
    // The groups go up only when some list names them; their spheres follow the eye
    // ([`frames`]).
    if flat.entries.iter().any(|e| e.id & GROUP_BIT != 0) {
        flat.group_prims = groups.members.clone();
    }
    flat
}

/// The eye-relative f32 data of the flat tables: the vertices of the triangles split into
/// patches and the groups' spheres.
pub fn frames(flat: &mut FlatTables, targets: &[Target], groups: &Groups, eye: DVec3) {
    flat.groups = if flat.group_prims.is_empty() { Vec::new() } else { groups.gpu(eye) };
    flat.patch_tris.clear();
    for (id, _) in flat.prim_patches.iter().enumerate().filter(|(_, m)| **m > 1) {
        if let Shape::Triangle { v } = targets[id].shape {
            flat.patch_tris.insert(id as u32, v.map(|p| (p - eye).as_vec3()));
        }
    }
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
