//! The cut-offs of one origin's build: per cell, the distance beyond which its list is cut
//! off (lowered when a target certainly covers the cell), and per pyramid block the largest
//! cut of its cells, so that a bound lying beyond every cut of a block skips the block.
//!
//! The threads building one origin share them. Cuts are non-negative or +∞, so their bits
//! order as their values: a cut is lowered with one atomic `fetch_min`. A block's maximum
//! is recomputed from its children after a lowering; two threads may race there, and the
//! loser may leave a maximum above the true one (never below: every value read only falls
//! afterwards). That only skips fewer blocks; [`Cuts::settle`] makes every maximum exact
//! once the lowering is over.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};

/// A distance shared between threads (non-negative or +∞).
struct Dist(AtomicU64);

impl Dist {
    fn far() -> Dist {
        Dist(AtomicU64::new(f64::INFINITY.to_bits()))
    }

    #[inline]
    fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Relaxed))
    }

    #[inline]
    fn set(&self, x: f64) {
        self.0.store(x.to_bits(), Relaxed)
    }

    /// Lowers the distance to `x` (non-negative) when nearer; returns the old one.
    #[inline]
    fn lower(&self, x: f64) -> f64 {
        f64::from_bits(self.0.fetch_min(x.to_bits(), Relaxed))
    }
}

/// The cut-offs of the cells of an origin's windows, with their block maxima.
pub struct Cuts {
    /// Per local cell (window-major, then row-major).
    cut: Vec<Dist>,
    /// Per face and level `k ≥ 1` of its pyramid, the largest cut of each block.
    max: [Vec<Vec<Dist>>; 6],
    /// Per face: the first local cell, and the blocks per row and column at each level.
    base: [usize; 6],
    dims: [Vec<[u32; 2]>; 6],
    any: AtomicBool,
}

impl Cuts {
    /// All cuts at +∞, for windows whose cells start at `base[f]` and whose pyramids have
    /// `dims[f]` blocks per level (level 0: the cells).
    pub fn new(total: usize, base: [usize; 6], dims: [Vec<[u32; 2]>; 6]) -> Cuts {
        let max = std::array::from_fn(|f| {
            let d = &dims[f];
            (1..d.len()).map(|k| (0..d[k][0] * d[k][1]).map(|_| Dist::far()).collect()).collect()
        });
        let cut = (0..total).map(|_| Dist::far()).collect();
        Cuts { cut, max, base, dims, any: AtomicBool::new(false) }
    }

    /// The cut-off distance of local cell `i`.
    #[inline]
    pub fn get(&self, i: usize) -> f64 {
        self.cut[i].get()
    }

    /// Whether some cell's cut-off is finite (before that, no bound is hidden anywhere).
    #[inline]
    pub fn any(&self) -> bool {
        self.any.load(Relaxed)
    }

    /// Lowers the cut-off of local cell `i`, cell `(x, y)` of face `f`'s window, to `t`
    /// (when nearer), keeping the block maxima at or above the true ones.
    pub fn lower(&self, i: usize, f: usize, x: u32, y: u32, t: f64) {
        if t.is_nan() {
            return;
        }
        // Cut-offs are upper bounds on hit distances, so never negative.
        let t = t.max(0.0);
        let old = self.cut[i].lower(t);
        if t >= old {
            return;
        }
        self.any.store(true, Relaxed);
        let dims = &self.dims[f];
        for (k, dim) in dims.iter().enumerate().skip(1) {
            let slot = &self.max[f][k - 1][((y >> k) * dim[0] + (x >> k)) as usize];
            // Cuts only fall: the block's maximum changes only if the old cut was it.
            if old < slot.get() {
                break;
            }
            let m = self.children_max(f, k, x >> k, y >> k);
            if m == slot.get() {
                break;
            }
            slot.set(m);
        }
    }

    /// The largest cut of the children (at `level − 1`) of block `(bx, by)` at `level`.
    #[inline]
    fn children_max(&self, f: usize, level: usize, bx: u32, by: u32) -> f64 {
        let d = self.dims[f][level - 1];
        let mut m = f64::NEG_INFINITY;
        for yy in 2 * by..(2 * by + 2).min(d[1]) {
            for xx in 2 * bx..(2 * bx + 2).min(d[0]) {
                m = m.max(self.block_max(f, level - 1, xx, yy));
            }
        }
        m
    }

    /// The largest cut (or a bound above it) of block `(bx, by)` at `level` of face `f`.
    #[inline]
    pub fn block_max(&self, f: usize, level: usize, bx: u32, by: u32) -> f64 {
        if level == 0 {
            self.cut[self.base[f] + (by * self.dims[f][0][0] + bx) as usize].get()
        } else {
            self.max[f][level - 1][(by * self.dims[f][level][0] + bx) as usize].get()
        }
    }

    /// Makes every block maximum exact (after the lowering threads are done).
    pub fn settle(&self) {
        for f in 0..6 {
            for k in 1..self.dims[f].len() {
                let [w, h] = self.dims[f][k];
                for by in 0..h {
                    for bx in 0..w {
                        let m = self.children_max(f, k, bx, by);
                        self.max[f][k - 1][(by * w + bx) as usize].set(m);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coherence::testutil::rng;

    /// Threads lowering cuts at once leave every block maximum at or above its cells'
    /// largest cut, and `settle` makes it exact; the cuts are the smallest values lowered.
    #[test]
    fn lowering_in_parallel_keeps_maxima_safe() {
        use rayon::prelude::*;
        let (w, h) = (37u32, 21u32);
        let mut dims = vec![[w, h]];
        while dims.last().is_some_and(|d| d[0] > 1 || d[1] > 1) {
            let d = *dims.last().unwrap();
            dims.push([d[0].div_ceil(2), d[1].div_ceil(2)]);
        }
        let total = (w * h) as usize;
        let cuts =
            Cuts::new(total, [0; 6], std::array::from_fn(|f| if f == 0 { dims.clone() } else { vec![] }));
        let lowered: Vec<Vec<(usize, f64)>> = (0..4u64)
            .into_par_iter()
            .map(|t| {
                let mut s = 0x9e37 + t * 7919;
                (0..3000)
                    .map(|_| {
                        let i = (rng(&mut s) * total as f64) as usize % total;
                        let x = rng(&mut s) * 100.0;
                        cuts.lower(i, 0, i as u32 % w, i as u32 / w, x);
                        (i, x)
                    })
                    .collect()
            })
            .collect();
        let mut want = vec![f64::INFINITY; total];
        for (i, x) in lowered.into_iter().flatten() {
            want[i] = want[i].min(x);
        }
        let check = |exact: bool| {
            for (k, d) in dims.iter().enumerate() {
                for by in 0..d[1] {
                    for bx in 0..d[0] {
                        let mut m = f64::NEG_INFINITY;
                        for y in (by << k)..((by + 1) << k).min(h) {
                            for x in (bx << k)..((bx + 1) << k).min(w) {
                                m = m.max(want[(y * w + x) as usize]);
                            }
                        }
                        let got = cuts.block_max(0, k, bx, by);
                        assert!(
                            if exact { got == m } else { got >= m },
                            "level {k} ({bx}, {by}): {got} vs {m}"
                        );
                    }
                }
            }
        };
        check(false);
        cuts.settle();
        check(true);
        assert!(cuts.any());
    }
}
