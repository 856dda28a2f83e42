//! Finishing one origin's table: records sorted into per-cell lists by `d_min` (ties by
//! id), and each face's window cropped to its non-empty cells.

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

/// Sorts the records into lists and crops each face's window to its non-empty cells.
pub fn finish(def: &OriginDef, cells: &Cells, recs: Vec<Rec>, eps: f64) -> OriginTable {
    let mut stored: Vec<(u32, GpuEntry)> =
        recs.iter().map(|x| (x.cell, GpuEntry { id: x.id, d_min: store_dmin(x.dmin, eps) })).collect();
    stored.sort_unstable_by(|a, b| {
        a.0.cmp(&b.0).then(a.1.d_min.total_cmp(&b.1.d_min)).then(a.1.id.cmp(&b.1.id))
    });

    // Crop windows to the bounding box of non-empty cells.
    let mut faces = [[0u32; 4]; 6];
    let mut bbox = [[u32::MAX, u32::MAX, 0, 0]; 6]; // min u, min v, max u, max v
    let mut locs = Vec::with_capacity(stored.len());
    for (cell, _) in &stored {
        let (f, iu, iv) = cells.locate(*cell as usize);
        let b = &mut bbox[f];
        b[0] = b[0].min(iu);
        b[1] = b[1].min(iv);
        b[2] = b[2].max(iu);
        b[3] = b[3].max(iv);
        locs.push((f, iu, iv));
    }
    let mut base = [0usize; 6];
    let mut total = 0usize;
    for f in 0..6 {
        base[f] = total;
        let b = bbox[f];
        if b[0] != u32::MAX {
            faces[f] = [b[0], b[1], b[2] - b[0] + 1, b[3] - b[1] + 1];
            total += (faces[f][2] * faces[f][3]) as usize;
        }
    }
    let mut counts = vec![0u32; total + 1];
    let mut new_cell = Vec::with_capacity(stored.len());
    for &(f, iu, iv) in &locs {
        let w = faces[f];
        let c = base[f] + ((iv - w[1]) * w[2] + (iu - w[0])) as usize;
        counts[c + 1] += 1;
        new_cell.push(c);
    }
    for i in 0..total {
        counts[i + 1] += counts[i];
    }
    // The cell order of `stored` maps monotonically to the new order within a face, and faces
    // keep their order, so a stable placement by the new index keeps each list sorted.
    let mut entries = vec![GpuEntry::default(); stored.len()];
    let mut fill = counts.clone();
    for (k, (_, e)) in stored.iter().enumerate() {
        let c = new_cell[k];
        entries[fill[c] as usize] = *e;
        fill[c] += 1;
    }
    OriginTable { kind: Some(def.kind), n: def.n, faces, starts: counts, entries, always: Vec::new() }
}
