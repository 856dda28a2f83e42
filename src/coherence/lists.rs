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
    // Bucket the records by cell (a counting sort), then order each short list.
    let mut starts = vec![0u32; cells.total + 1];
    for x in &recs {
        starts[x.cell as usize + 1] += 1;
    }
    for i in 0..cells.total {
        starts[i + 1] += starts[i];
    }
    let mut sorted = vec![GpuEntry::default(); recs.len()];
    let mut fill = starts.clone();
    for x in &recs {
        let slot = &mut fill[x.cell as usize];
        sorted[*slot as usize] = GpuEntry { id: x.id, d_min: store_dmin(x.dmin, eps) };
        *slot += 1;
    }
    for c in 0..cells.total {
        sorted[starts[c] as usize..starts[c + 1] as usize]
            .sort_unstable_by(|a, b| a.d_min.total_cmp(&b.d_min).then(a.id.cmp(&b.id)));
    }

    // Crop each face's window to the bounding box of its non-empty cells, keeping the
    // row-major cell order.
    let mut faces = [[0u32; 4]; 6];
    let mut out_starts = vec![0u32];
    let mut entries = Vec::with_capacity(sorted.len());
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
            for iu in b[0]..=b[2] {
                let c = local(iu, iv);
                entries.extend_from_slice(&sorted[starts[c] as usize..starts[c + 1] as usize]);
                out_starts.push(entries.len() as u32);
            }
        }
    }
    OriginTable { kind: Some(def.kind), n: def.n, faces, starts: out_starts, entries, always: Vec::new() }
}
