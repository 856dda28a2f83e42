//! The direction-cube lookup: the face and cell of a direction, and the candidate list of an
//! origin's cell in the flattened tables. Twins of `cube_face_cell` and `cube_cell_range` in
//! `shaders/shared/tables.wgsl` (keep them in sync), in f32 as on the GPU.

use glam::Vec3;

use super::flat::FlatTables;

/// Face and cell of a direction on the direction cube with `n`×`n` cells per face.
///
/// Returns `[face, iu, iv]`: the major axis `ax` is the component of largest magnitude (ties
/// go to x before y before z), `face = 2·ax + (d[ax] < 0)`, `u = d[(ax+1)%3] / |d[ax]|` and
/// `v = d[(ax+2)%3] / |d[ax]|` lie in [−1, 1] and `iu = clamp(floor((u+1)·0.5·n), 0, n−1)`
/// (`iv` likewise). The direction need not be unit length but must not be zero: callers
/// reject a zero direction before the lookup (the indices are clamped anyway, and a NaN
/// would turn into cell 0 here but is undefined in WGSL). −0.0 components are harmless.
///
/// Cell assignment at exact boundaries may differ between this function and the WGSL one
/// (WGSL division is 2.5 ULP): the tables are built for directions within a small angle of
/// the cell, so correctness never depends on these ties.
pub fn cube_face_cell(d: Vec3, n: u32) -> [u32; 3] {
    let a = d.abs();
    let mut ax = 0u32;
    let mut m = a.x;
    if a.y > m {
        ax = 1;
        m = a.y;
    }
    if a.z > m {
        ax = 2;
        m = a.z;
    }
    let major = d[ax as usize];
    let face = 2 * ax + if major < 0.0 { 1 } else { 0 };
    let u = d[((ax + 1) % 3) as usize] / m;
    let v = d[((ax + 2) % 3) as usize] / m;
    let nf = n as f32;
    let iu = ((u + 1.0) * 0.5 * nf).floor().clamp(0.0, nf - 1.0) as u32;
    let iv = ((v + 1.0) * 0.5 * nf).floor().clamp(0.0, nf - 1.0) as u32;
    [face, iu, iv]
}

/// The range `[begin, end)` of `tables.entries` holding the candidate list of the cell that
/// direction `d` falls in, for origin `origin`. Directions outside the origin's stored
/// window of a face have an empty list.
pub fn cube_cell_range(tables: &FlatTables, origin: u32, d: Vec3) -> [u32; 2] {
    let org = tables.origins[origin as usize];
    let fc = cube_face_cell(d, org.n);
    let w = tables.faces[(origin * 6 + fc[0]) as usize];
    // u32 subtraction wraps, so a cell left of or below the window fails the test too.
    let lu = fc[1].wrapping_sub(w.iu0);
    let lv = fc[2].wrapping_sub(w.iv0);
    if lu >= w.width || lv >= w.height {
        return [0, 0];
    }
    let c = w.cell_base + lv * w.width + lu;
    [tables.cell_start[c as usize], tables.cell_start[c as usize + 1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_of_axes_and_signs() {
        let n = 8;
        assert_eq!(cube_face_cell(Vec3::X, n), [0, 4, 4]);
        assert_eq!(cube_face_cell(-Vec3::X, n), [1, 4, 4]);
        assert_eq!(cube_face_cell(Vec3::Y, n), [2, 4, 4]);
        assert_eq!(cube_face_cell(-Vec3::Z, n), [5, 4, 4]);
        // −0.0 components behave like +0.0.
        assert_eq!(cube_face_cell(Vec3::new(-0.0, -0.0, 1.0), n), cube_face_cell(Vec3::Z, n));
        // Ties go to x, then y.
        assert_eq!(cube_face_cell(Vec3::new(1.0, 1.0, 1.0), n)[0], 0);
        assert_eq!(cube_face_cell(Vec3::new(0.0, -1.0, 1.0), n)[0], 3);
        // u = ±1 is clamped into the last cell.
        assert_eq!(cube_face_cell(Vec3::new(1.0, 1.0, -1.0), n), [0, 7, 0]);
    }
}
