//! Finishing one origin's table: the records within their cells' final cuts sorted into
//! per-cell lists by `d_min` (ties by id), written once at their place, and each face's
//! window cropped to its non-empty cells.

use rayon::prelude::*;

use super::defs::OriginDef;
use super::flat::{GpuEntry, OriginKind};
use super::raster::Cells;

/// A distance as a heap key (`BinaryHeap<Reverse<DistKey>>` pops the nearest first), ordered
/// by `f64::total_cmp`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistKey(pub f64);

impl Eq for DistKey {}

impl PartialOrd for DistKey {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for DistKey {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// One origin's built table, before flattening.
#[derive(Clone, Debug, Default)]
pub struct OriginTable {
    pub kind: Option<OriginKind>,
    pub n: u32,
    /// Per face, the stored window `[iu0, iv0, width, height]` (width 0: nothing stored).
    pub faces: [[u32; 4]; 6],
    /// Local CSR: the list of stored cell `c` is `entries[starts[c]..starts[c+1]]`.
    pub starts: Vec<u32>,
    pub entries: Vec<GpuEntry>,
    pub always: Vec<GpuEntry>,
}

/// One candidate record of the build: a target seen through a cell, with its bound.
#[derive(Clone, Copy)]
pub struct Rec {
    /// Local cell index (see [`Cells`]).
    pub cell: u32,
    pub id: u32,
    pub dmin: f64,
}

/// `x` lowered for f32 rounding and stored as the largest f32 not above it.
pub fn store_dmin(x: f64, eps: f64) -> f32 {
    let x = ((x - 2.0 * eps) * (1.0 - 1e-5)).max(0.0);
    let f = x as f32;
    if f as f64 > x {
        f32::from_bits(f.to_bits() - 1)
    } else {
        f
    }
}

/// Sorts the records that lie within their cells' final cuts (`parts`, as the threads
/// gathered them) into lists, and crops each face's window to its non-empty cells. The
/// records are written once, at their place in the table, and each list is sorted by
/// `(d_min, id)` (in parallel): the table does not depend on how the records were split.
pub fn finish(def: &OriginDef, cells: &Cells, parts: &[Vec<Rec>], eps: f64) -> OriginTable {
    let kept = |x: &&Rec| x.dmin <= cells.cut(x.cell as usize);
    // Bucket the records by cell (a counting sort), then order each short list.
    let mut starts = vec![0u32; cells.total + 1];
    for x in parts.iter().flatten().filter(kept) {
        starts[x.cell as usize + 1] += 1;
    }
    for i in 0..cells.total {
        starts[i + 1] += starts[i];
    }
    let mut entries = vec![GpuEntry::default(); starts[cells.total] as usize];
    let mut fill = starts.clone();
    for x in parts.iter().flatten().filter(kept) {
        let slot = &mut fill[x.cell as usize];
        entries[*slot as usize] = GpuEntry { id: x.id, d_min: store_dmin(x.dmin, eps) };
        *slot += 1;
    }
    drop(fill);
    sort_lists(&mut entries, &starts);

    // Crop each face's window to the bounding box of its non-empty cells, keeping the
    // row-major cell order. The cells cropped away are empty, so the entries stay as they
    // are and only the list starts of the cells kept are written.
    let mut faces = [[0u32; 4]; 6];
    let mut out_starts = vec![0u32];
    for (f, face) in faces.iter_mut().enumerate() {
        let Some(w) = cells.win[f] else { continue };
        let local = |iu: u32, iv: u32| cells.base[f] + (iv * w[2] + iu) as usize;
        let mut b = [u32::MAX, u32::MAX, 0, 0]; // min u, min v, max u, max v (window-local)
        for iv in 0..w[3] {
            for iu in 0..w[2] {
                let c = local(iu, iv);
                if starts[c + 1] > starts[c] {
                    b = [b[0].min(iu), b[1].min(iv), b[2].max(iu), b[3].max(iv)];
                }
            }
        }
        if b[0] == u32::MAX {
            continue;
        }
        *face = [w[0] + b[0], w[1] + b[1], b[2] - b[0] + 1, b[3] - b[1] + 1];
        for iv in b[1]..=b[3] {
            out_starts.extend((b[0]..=b[2]).map(|iu| starts[local(iu, iv) + 1]));
        }
    }
    OriginTable { kind: Some(def.kind), n: def.n, faces, starts: out_starts, entries, always: Vec::new() }
}

/// Sorts each list `entries[starts[c]..starts[c + 1]]` by `(d_min, id)`, in parallel over
/// runs of cells.
fn sort_lists(entries: &mut [GpuEntry], starts: &[u32]) {
    const RUN: usize = 4096;
    let cells = starts.len() - 1;
    let mut runs = Vec::with_capacity(cells.div_ceil(RUN));
    let mut rest = entries;
    for c0 in (0..cells).step_by(RUN) {
        let c1 = (c0 + RUN).min(cells);
        let (run, tail) = std::mem::take(&mut rest).split_at_mut((starts[c1] - starts[c0]) as usize);
        rest = tail;
        runs.push((run, &starts[c0..=c1]));
    }
    runs.into_par_iter().for_each(|(run, st)| {
        let base = st[0];
        for w in st.windows(2) {
            run[(w[0] - base) as usize..(w[1] - base) as usize]
                .sort_unstable_by(|a, b| a.d_min.total_cmp(&b.d_min).then(a.id.cmp(&b.id)));
        }
    });
}
