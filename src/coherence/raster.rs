//! The cell rasteriser: an origin's work windows (the cells searched per face), and the
//! hierarchical rasterisation of a direction bound into them.

use std::sync::Arc;

use super::cells::{cell_cone, cell_span, region_cone, CellCone, Cone};
use super::context::Ctx;
use super::defs::OriginDef;

/// Cells of an origin's work windows, with cached or computed cell cones.
pub struct Cells {
    pub n: u32,
    pub win: [Option<[u32; 4]>; 6],
    pub base: [usize; 6],
    pub total: usize,
    cube: Option<Arc<Vec<CellCone>>>,
}

impl Cells {
    pub fn new(def: &OriginDef, ctx: &Ctx) -> Cells {
        let mut base = [0; 6];
        let mut total = 0;
        for (b, w) in base.iter_mut().zip(&def.window) {
            *b = total;
            if let Some(w) = w {
                total += (w[2] * w[3]) as usize;
            }
        }
        Cells { n: def.n, win: def.window, base, total, cube: ctx.cube(def.n) }
    }

    #[inline]
    pub fn cone(&self, f: usize, iu: u32, iv: u32) -> CellCone {
        match &self.cube {
            Some(c) => c[(f * self.n as usize + iv as usize) * self.n as usize + iu as usize],
            None => cell_cone(f, iu, iv, self.n),
        }
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

    /// Hierarchical rasterisation of a bound into the windows: blocks the bound misses are
    /// dropped, blocks of at most `BULK` cells wholly inside it are emitted at once (one
    /// `d_min` and cover test for the block), others are split down to single cells.
    /// `emit(cells, block)` receives the local cell indices of the block; it returns false to
    /// stop the rasterisation (then `raster` returns false).
    pub fn raster(
        &self,
        cone: Option<&Cone>,
        meets: impl Fn(&CellCone) -> bool,
        inside: impl Fn(&CellCone) -> bool,
        mut emit: impl FnMut(&mut dyn Iterator<Item = usize>, &CellCone) -> bool,
    ) -> bool {
        let mut stack: Vec<[u32; 4]> = Vec::new();
        for f in 0..6 {
            let Some(r) = self.face_rect(f, cone) else { continue };
            if self.cube.is_some() && (r[2] - r[0] + 1) * (r[3] - r[1] + 1) <= 16 {
                // Small rectangles: test the cached cells one by one.
                for iv in r[1]..=r[3] {
                    for iu in r[0]..=r[2] {
                        let cell = self.cone(f, iu, iv);
                        if meets(&cell) && !emit(&mut std::iter::once(self.index(f, iu, iv)), &cell) {
                            return false;
                        }
                    }
                }
                continue;
            }
            stack.push(r);
            while let Some(r) = stack.pop() {
                let (w, h) = (r[2] - r[0] + 1, r[3] - r[1] + 1);
                let single = w == 1 && h == 1;
                let region = if single { self.cone(f, r[0], r[1]) } else { region_cone(f, r, self.n) };
                if !meets(&region) {
                    continue;
                }
                if single || (w * h <= BULK && inside(&region)) {
                    let mut it = (r[1]..=r[3])
                        .flat_map(|iv| (r[0]..=r[2]).map(move |iu| (iu, iv)))
                        .map(|(iu, iv)| self.index(f, iu, iv));
                    if !emit(&mut it, &region) {
                        return false;
                    }
                    continue;
                }
                if w >= h {
                    let m = r[0] + w / 2;
                    stack.push([m, r[1], r[2], r[3]]);
                    stack.push([r[0], r[1], m - 1, r[3]]);
                } else {
                    let m = r[1] + h / 2;
                    stack.push([r[0], m, r[2], r[3]]);
                    stack.push([r[0], r[1], r[2], m - 1]);
                }
            }
        }
        true
    }
}

/// Largest block emitted without splitting.
const BULK: u32 = 16;

impl Cells {
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
