//! The cell rasteriser: an origin's work windows (the cells searched per face), their
//! cut-offs, and the hierarchical rasterisation of a direction bound into them.
//!
//! Each face window carries a pyramid of blocks aligned to the window's corner: level `k`
//! holds the bounding cones of its `2^k × 2^k` blocks (clipped to the window), computed once
//! per origin (levels below a memory budget: when asked) so that rasterising a target reads
//! cones instead of computing them. A block's cone and corners contain every direction of
//! its cells, so testing a bound against a block that reaches past the target's rectangle
//! stays conservative: a conservative "meets" on the block never wrongly says no for a cell
//! of it, and "inside" for the block holds for every part of it. The `d_min` and cover of a
//! block emitted whole are those of the whole aligned block, which may reach past the cells
//! emitted: lower, or less often covering, never wrong.
//!
//! The cells also carry the builder's cut-offs ([`Cuts`]), with the largest cut of every
//! pyramid block, so that a bound lying beyond every cut of a block skips the block without
//! testing it. The threads building one origin share them.

use glam::DVec3;

use super::cells::{cell_span, edge_coord, face_dir, region_cone, region_cone_with, CellCone, Cone};
use super::cuts::Cuts;
use super::defs::OriginDef;

/// Cells of an origin's work windows, with the block pyramids of their cones.
pub struct Cells {
    pub n: u32,
    pub win: [Option<[u32; 4]>; 6],
    pub base: [usize; 6],
    pub total: usize,
    pyramids: [Pyramid; 6],
    /// Per local cell, the distance beyond which its list is cut off (the builder lowers it
    /// when a target covers the cell), with the largest cut of every block: a bound farther
    /// than that is hidden in the whole block.
    pub cuts: Cuts,
}

/// The block cones of one face window, level by level from single cells up. Levels below
/// `first` are not stored (their cones are computed when asked), so huge windows keep the
/// cones' memory bounded (the per-cell cuts and the corner lengths, 16 bytes a cell, are
/// always kept). A block's corners are grid vertices of the window, so their
/// lengths are stored once per vertex, and the corners themselves are built from the
/// stored coordinates of the window's grid lines (no division, no root).
#[derive(Default)]
struct Pyramid {
    /// Blocks per row and column at each level.
    dims: Vec<[u32; 2]>,
    /// The lowest stored level.
    first: usize,
    levels: Vec<Vec<Axis>>,
    /// `|face_dir(u, v)|` at the window's `(width + 1) × (height + 1)` cell corners.
    corner_len: Vec<f64>,
    /// The window's grid lines: `us[k]` is [`edge_coord`] of column boundary `iu0 + k`,
    /// `vs[k]` of row boundary `iv0 + k`.
    us: Vec<f64>,
    vs: Vec<f64>,
}

/// The part of a block's cone the cone tests read first: its axis and half-angle.
#[derive(Clone, Copy)]
struct Axis {
    m: DVec3,
    cos_b: f64,
    sin_b: f64,
}

/// The block cones kept per origin while building, in bytes (origins build in parallel,
/// each with its own).
const CACHE_BYTES: usize = 96 << 20;

/// Largest block emitted whole: `2^BULK_LEVEL` cells a side.
const BULK_LEVEL: usize = 2;

/// Rectangles of at most this many cells are tested cell by cell.
const SMALL_RECT: u32 = 16;

impl Cells {
    pub fn new(def: &OriginDef) -> Cells {
        Cells::with_budget(def, CACHE_BYTES)
    }

    /// [`Cells::new`] keeping at most `cache_bytes` of block cones.
    fn with_budget(def: &OriginDef, cache_bytes: usize) -> Cells {
        let mut base = [0; 6];
        let mut total = 0;
        for (b, w) in base.iter_mut().zip(&def.window) {
            *b = total;
            if let Some(w) = w {
                total += (w[2] * w[3]) as usize;
            }
        }
        // A pyramid holds about 4/3 of its window's cells; drop whole low levels (a quarter of
        // what remains each) until the kept ones fit the budget.
        let per_cell = std::mem::size_of::<Axis>() as f64 * 4.0 / 3.0;
        let mut first = 0;
        while first < 32 && total as f64 * per_cell / 4f64.powi(first as i32) > cache_bytes as f64 {
            first += 1;
        }
        let pyramids = std::array::from_fn(|f| match def.window[f] {
            Some(w) => Pyramid::new(f, w, def.n, first),
            None => Pyramid::default(),
        });
        let cuts = Cuts::new(total, base, std::array::from_fn(|f| pyramids[f].dims.clone()));
        Cells { n: def.n, win: def.window, base, total, pyramids, cuts }
    }

    /// The cone of window cell `(iu, iv)` of face `f`.
    #[inline]
    pub fn cone(&self, f: usize, iu: u32, iv: u32) -> CellCone {
        let w = self.win[f].unwrap();
        self.block(f, 0, iu - w[0], iv - w[1], [iu, iv, iu, iv])
    }

    /// The cone of block `(bx, by)` at `level` of face `f`'s window, whose cells are `r`
    /// ([`Cells::block_rect`], which the caller has at hand).
    #[inline]
    fn block(&self, f: usize, level: usize, bx: u32, by: u32, r: [u32; 4]) -> CellCone {
        self.with_corners(f, self.block_axis(f, level, bx, by, r), r)
    }

    /// The axis part of [`Cells::block`]: all that Test A reads.
    #[inline]
    fn block_axis(&self, f: usize, level: usize, bx: u32, by: u32, r: [u32; 4]) -> Axis {
        let p = &self.pyramids[f];
        if level < p.first {
            let c = region_cone(f, r, self.n);
            return Axis { m: c.m, cos_b: c.cos_b, sin_b: c.sin_b };
        }
        p.levels[level - p.first][(by * p.dims[level][0] + bx) as usize]
    }

    /// The whole cone of block `r` of face `f`, from its axis part.
    #[inline]
    fn with_corners(&self, f: usize, a: Axis, r: [u32; 4]) -> CellCone {
        let (p, w) = (&self.pyramids[f], self.win[f].unwrap());
        CellCone {
            m: a.m,
            cos_b: a.cos_b,
            sin_b: a.sin_b,
            corners: p.corners(f, w, r),
            corner_len: p.lens(w, r),
        }
    }

    #[inline]
    fn block_rect(&self, f: usize, level: usize, bx: u32, by: u32) -> [u32; 4] {
        block_rect(self.win[f].unwrap(), level, bx, by)
    }

    /// The cut-off distance of local cell `i`.
    #[inline]
    pub fn cut(&self, i: usize) -> f64 {
        self.cuts.get(i)
    }

    /// Whether some cell's cut-off is finite (before that, no bound is hidden anywhere).
    #[inline]
    pub fn any_cut(&self) -> bool {
        self.cuts.any()
    }

    /// Lowers the cut-off of local cell `i` to `t` (when nearer), keeping the block maxima.
    pub fn lower_cut(&self, i: usize, t: f64) {
        let (f, iu, iv) = self.locate(i);
        let w = self.win[f].unwrap();
        self.cuts.lower(i, f, iu - w[0], iv - w[1], t);
    }

    /// The largest cut of block `(bx, by)` at `level` of face `f`'s window.
    #[inline]
    fn max_cut_at(&self, f: usize, level: usize, bx: u32, by: u32) -> f64 {
        self.cuts.block_max(f, level, bx, by)
    }

    /// The window rectangle `[iu0, iv0, iu1, iv1]` of face `f` inside `cone`'s rectangle (the
    /// whole window for `None`), or `None` when empty.
    fn face_rect(&self, f: usize, cone: Option<&Cone>) -> Option<[u32; 4]> {
        let w = self.win[f]?;
        let (mut u0, mut u1, mut v0, mut v1) = (w[0], w[0] + w[2] - 1, w[1], w[1] + w[3] - 1);
        if let Some(k) = cone {
            let r = k.face_rect(f)?;
            let (a, b) = cell_span(r[0], r[1], self.n);
            let (c, d) = cell_span(r[2], r[3], self.n);
            u0 = u0.max(a);
            u1 = u1.min(b);
            v0 = v0.max(c);
            v1 = v1.min(d);
        }
        (u0 <= u1 && v0 <= v1).then_some([u0, v0, u1, v1])
    }

    #[inline]
    fn index(&self, f: usize, iu: u32, iv: u32) -> usize {
        let w = self.win[f].unwrap();
        self.base[f] + ((iv - w[1]) * w[2] + (iu - w[0])) as usize
    }

    /// Hierarchical rasterisation of a bound into the windows: pyramid blocks the bound
    /// misses are dropped, blocks of at most `2^BULK_LEVEL` cells a side wholly inside it are
    /// emitted at once (one `d_min` and cover test for the block), others are split into their
    /// four children down to single cells. Only cells inside the bound's rectangle are emitted.
    /// `meets` is asked only about blocks `cone` meets (Test A), so it need not test the
    /// cone again.
    /// `emit(cells, block)` receives the local cell indices and the cone of the block they
    /// were emitted from (which may reach past them, and past the rectangle); it
    /// returns false to stop the rasterisation (then `raster` returns false). Cells and blocks
    /// whose every cut lies nearer than `beyond` are skipped: a bound no nearer than `beyond`
    /// is hidden there.
    #[inline]
    pub fn raster(
        &self,
        cone: Option<&Cone>,
        beyond: f64,
        meets: impl Fn(&CellCone) -> bool,
        inside: impl Fn(&CellCone) -> bool,
        mut emit: impl FnMut(&mut dyn Iterator<Item = usize>, &CellCone) -> bool,
    ) -> bool {
        let mut stack: Vec<(usize, u32, u32)> = Vec::new();
        for f in 0..6 {
            let Some(r) = self.face_rect(f, cone) else { continue };
            let w = self.win[f].unwrap();
            let (rw, rh) = (r[2] - r[0] + 1, r[3] - r[1] + 1);
            if rw * rh <= SMALL_RECT {
                // Small rectangles: test the cells one by one.
                for iv in r[1]..=r[3] {
                    for iu in r[0]..=r[2] {
                        let i = self.index(f, iu, iv);
                        if self.cut(i) < beyond {
                            continue;
                        }
                        let r = [iu, iv, iu, iv];
                        let axis = self.block_axis(f, 0, iu - w[0], iv - w[1], r);
                        if cone.is_some_and(|k| !k.meets_axis(axis.m, axis.cos_b, axis.sin_b)) {
                            continue;
                        }
                        let cell = self.with_corners(f, axis, r);
                        if meets(&cell) && !emit(&mut std::iter::once(i), &cell) {
                            return false;
                        }
                    }
                }
                continue;
            }
            // The level whose blocks are at least as large as the rectangle: it meets at most
            // 2×2 of them.
            let top = (32 - (rw.max(rh) - 1).leading_zeros()) as usize;
            let top = top.min(self.pyramids[f].dims.len() - 1);
            let (lu, lv) = (r[0] - w[0], r[1] - w[1]);
            let (hu, hv) = (r[2] - w[0], r[3] - w[1]);
            for by in (lv >> top)..=(hv >> top) {
                for bx in (lu >> top)..=(hu >> top) {
                    stack.push((top, bx, by));
                }
            }
            while let Some((level, bx, by)) = stack.pop() {
                let b = self.block_rect(f, level, bx, by);
                let c = [b[0].max(r[0]), b[1].max(r[1]), b[2].min(r[2]), b[3].min(r[3])];
                if c[0] > c[2] || c[1] > c[3] {
                    continue;
                }
                if self.max_cut_at(f, level, bx, by) < beyond {
                    continue;
                }
                let axis = self.block_axis(f, level, bx, by, b);
                if cone.is_some_and(|k| !k.meets_axis(axis.m, axis.cos_b, axis.sin_b)) {
                    continue;
                }
                let region = self.with_corners(f, axis, b);
                if !meets(&region) {
                    continue;
                }
                if level == 0 || (level <= BULK_LEVEL && inside(&region)) {
                    let mut it = (c[1]..=c[3])
                        .flat_map(|iv| (c[0]..=c[2]).map(move |iu| (iu, iv)))
                        .map(|(iu, iv)| self.index(f, iu, iv));
                    if !emit(&mut it, &region) {
                        return false;
                    }
                    continue;
                }
                for (dx, dy) in [(1, 1), (0, 1), (1, 0), (0, 0)] {
                    stack.push((level - 1, 2 * bx + dx, 2 * by + dy));
                }
            }
        }
        true
    }

    /// The face and cell `(f, iu, iv)` of local cell index `i`.
    pub fn locate(&self, i: usize) -> (usize, u32, u32) {
        let f = (0..6).rev().find(|&f| self.win[f].is_some() && self.base[f] <= i).unwrap();
        let w = self.win[f].unwrap();
        let local = (i - self.base[f]) as u32;
        (f, w[0] + local % w[2], w[1] + local / w[2])
    }

    /// The cell cone of local cell index `i`.
    pub fn cone_at(&self, i: usize) -> CellCone {
        let (f, iu, iv) = self.locate(i);
        self.cone(f, iu, iv)
    }
}

/// The cells `[iu0, iv0, iu1, iv1]` of block `(bx, by)` at `level` of window `w`, clipped to it.
#[inline]
fn block_rect(w: [u32; 4], level: usize, bx: u32, by: u32) -> [u32; 4] {
    let (u0, v0) = (w[0] + (bx << level), w[1] + (by << level));
    let side = 1u32 << level;
    [u0, v0, (u0 + side).min(w[0] + w[2]) - 1, (v0 + side).min(w[1] + w[3]) - 1]
}

impl Pyramid {
    /// The corners of block `r` of window `w` on face `f`, as
    /// [`region_corners`](super::cells::region_corners) computes them.
    #[inline]
    fn corners(&self, f: usize, w: [u32; 4], r: [u32; 4]) -> [DVec3; 4] {
        let (u0, u1) = (self.us[(r[0] - w[0]) as usize], self.us[(r[2] + 1 - w[0]) as usize]);
        let (v0, v1) = (self.vs[(r[1] - w[1]) as usize], self.vs[(r[3] + 1 - w[1]) as usize]);
        [face_dir(f, u0, v0), face_dir(f, u1, v0), face_dir(f, u1, v1), face_dir(f, u0, v1)]
    }

    /// The stored lengths of the corners of block `r` (as
    /// [`region_corners`](super::cells::region_corners) orders them) of window `w`.
    #[inline]
    fn lens(&self, w: [u32; 4], r: [u32; 4]) -> [f64; 4] {
        let len = |iu: u32, iv: u32| self.corner_len[((iv - w[1]) * (w[2] + 1) + iu - w[0]) as usize];
        [len(r[0], r[1]), len(r[2] + 1, r[1]), len(r[2] + 1, r[3] + 1), len(r[0], r[3] + 1)]
    }

    /// The pyramid of window `w = [iu0, iv0, width, height]` on face `f`, storing levels from
    /// `first` up to the one whose single block covers the window.
    fn new(f: usize, w: [u32; 4], n: u32, first: usize) -> Pyramid {
        let mut dims = vec![[w[2], w[3]]];
        while dims.last().is_some_and(|d| d[0] > 1 || d[1] > 1) {
            let d = dims.last().unwrap();
            dims.push([d[0].div_ceil(2), d[1].div_ceil(2)]);
        }
        let first = first.min(dims.len() - 1);
        let us: Vec<f64> = (w[0]..=w[0] + w[2]).map(|iu| edge_coord(iu, n)).collect();
        let vs: Vec<f64> = (w[1]..=w[1] + w[3]).map(|iv| edge_coord(iv, n)).collect();
        let mut corner_len = Vec::with_capacity(us.len() * vs.len());
        for &v in &vs {
            for &u in &us {
                corner_len.push(face_dir(f, u, v).length());
            }
        }
        let mut p = Pyramid { dims, first, levels: Vec::new(), corner_len, us, vs };
        p.levels = (first..p.dims.len())
            .map(|k| {
                let [bw, bh] = p.dims[k];
                let mut v = Vec::with_capacity((bw * bh) as usize);
                for by in 0..bh {
                    for bx in 0..bw {
                        let r = block_rect(w, k, bx, by);
                        let c = region_cone_with(f, r, n, Some(p.lens(w, r)));
                        v.push(Axis { m: c.m, cos_b: c.cos_b, sin_b: c.sin_b });
                    }
                }
                v
            })
            .collect();
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coherence::cells::cell_cone;
    use crate::coherence::flat::OriginKind;
    use crate::coherence::testutil::{rng, unit};

    fn def(n: u32, window: [Option<[u32; 4]>; 6]) -> OriginDef {
        OriginDef { kind: OriginKind::Light, center: DVec3::ZERO, radius: 0.0, light: None, n, window }
    }

    /// Stored cones equal computed ones, and each block's cone bounds its cells' corners.
    #[test]
    fn block_cones_are_the_cells_cones_and_bound_their_cells() {
        let d = def(13, [Some([2, 1, 11, 9]), None, Some([0, 0, 13, 13]), None, None, Some([5, 7, 1, 3])]);
        let cells = Cells::new(&d);
        for i in 0..cells.total {
            let (f, iu, iv) = cells.locate(i);
            let (a, b) = (cells.cone(f, iu, iv), cell_cone(f, iu, iv, d.n));
            assert_eq!(
                (a.m, a.cos_b, a.sin_b, a.corners, a.corner_len),
                (b.m, b.cos_b, b.sin_b, b.corners, b.corner_len)
            );
        }
        for (f, w) in d.window.iter().enumerate() {
            let Some(_) = w else { continue };
            let p = &cells.pyramids[f];
            for level in 1..p.dims.len() {
                for by in 0..p.dims[level][1] {
                    for bx in 0..p.dims[level][0] {
                        let block = cells.block(f, level, bx, by, cells.block_rect(f, level, bx, by));
                        let r = cells.block_rect(f, level, bx, by);
                        for iv in r[1]..=r[3] {
                            for iu in r[0]..=r[2] {
                                for c in cell_cone(f, iu, iv, d.n).corners {
                                    assert!(block.m.dot(c.normalize()) >= block.cos_b - 1e-12);
                                }
                            }
                        }
                    }
                }
            }
        }
    }

    /// At every level, stored or not, a block's whole cone (axis, angle, corners and their
    /// lengths) is the one `region_cone` computes for the block's cells.
    #[test]
    fn blocks_at_every_level_are_region_cones() {
        let d = def(11, [Some([1, 0, 10, 7]), None, None, Some([0, 3, 1, 8]), Some([0, 0, 11, 11]), None]);
        for budget in [CACHE_BYTES, 0] {
            let cells = Cells::with_budget(&d, budget);
            for (f, w) in d.window.iter().enumerate() {
                let Some(_) = w else { continue };
                for (level, dims) in cells.pyramids[f].dims.iter().enumerate() {
                    for by in 0..dims[1] {
                        for bx in 0..dims[0] {
                            let r = cells.block_rect(f, level, bx, by);
                            let (a, b) = (cells.block(f, level, bx, by, r), region_cone(f, r, d.n));
                            assert_eq!(
                                (a.m, a.cos_b, a.sin_b, a.corners, a.corner_len),
                                (b.m, b.cos_b, b.sin_b, b.corners, b.corner_len),
                                "face {f} level {level} block ({bx}, {by})"
                            );
                        }
                    }
                }
            }
        }
    }

    /// Every window cell a cap really meets (the exact test) is emitted, once, with and
    /// without stored block cones.
    #[test]
    fn raster_emits_every_cell_a_cap_meets() {
        let mut s = 0x51ed2701u64;
        let d = def(
            24,
            [
                Some([0, 0, 24, 24]),
                Some([3, 2, 17, 20]),
                Some([0, 5, 24, 9]),
                None,
                Some([0, 0, 24, 24]),
                Some([10, 10, 4, 4]),
            ],
        );
        for budget in [CACHE_BYTES, 0] {
            let cells = Cells::with_budget(&d, budget);
            for _ in 0..200 {
                let k = Cone::new(unit(&mut s), rng(&mut s) * 0.8);
                let mut hits = vec![0u32; cells.total];
                cells.raster(
                    Some(&k),
                    f64::NEG_INFINITY,
                    |c| k.meets(c),
                    |c| k.contains(c),
                    |it, _| {
                        it.for_each(|i| hits[i] += 1);
                        true
                    },
                );
                for (i, &h) in hits.iter().enumerate() {
                    let cell = cells.cone_at(i);
                    assert!(h <= 1, "cell {i} emitted {h} times");
                    if k.meets_exact(&cell) {
                        assert_eq!(h, 1, "cell {i} meets the cap but was not emitted");
                    }
                }
            }
        }
    }

    /// After any sequence of lowered cuts, every block's maximum is its cells' largest cut,
    /// and a raster skips only cells cut off before `beyond`.
    #[test]
    fn block_maxima_follow_lowered_cuts() {
        let mut s = 0x2545f491u64;
        let d = def(20, [Some([1, 2, 19, 13]), None, None, Some([0, 0, 20, 20]), None, Some([4, 4, 3, 1])]);
        let cells = Cells::new(&d);
        for round in 0..4000 {
            let i = (rng(&mut s) * cells.total as f64) as usize % cells.total;
            cells.lower_cut(i, rng(&mut s) * 10.0);
            if round % 500 != 499 {
                continue;
            }
            for (f, w) in d.window.iter().enumerate() {
                let Some(_) = w else { continue };
                let dims = &cells.pyramids[f].dims;
                for (level, d) in dims.iter().enumerate() {
                    for by in 0..d[1] {
                        for bx in 0..d[0] {
                            let r = cells.block_rect(f, level, bx, by);
                            let mut m = f64::NEG_INFINITY;
                            for iv in r[1]..=r[3] {
                                for iu in r[0]..=r[2] {
                                    m = m.max(cells.cut(cells.index(f, iu, iv)));
                                }
                            }
                            assert_eq!(cells.max_cut_at(f, level, bx, by), m, "face {f} level {level}");
                        }
                    }
                }
            }
        }
        let beyond = 5.0;
        let mut seen = vec![false; cells.total];
        cells.raster(
            None,
            beyond,
            |_| true,
            |_| true,
            |it, _| {
                it.for_each(|i| seen[i] = true);
                true
            },
        );
        // Blocks emitted whole may hold hidden cells; every cell not hidden is emitted, and
        // some hidden ones are skipped.
        for (i, &v) in seen.iter().enumerate() {
            assert!(v || cells.cut(i) < beyond, "cell {i} is not cut off but was skipped");
        }
        assert!(seen.iter().any(|&v| !v));
    }
}
