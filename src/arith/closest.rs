//! The nearest-hit rule every query shares, table walk and brute force alike: a hit counts
//! when it is nearer than the best so far, or as near with a lower primitive id, so that the
//! answer does not depend on the order of the tests (twins of WGSL `Closest`, `no_closest`,
//! `consider` in `shaders/shared/geometry.wgsl` and `brute_nearest` in
//! `shaders/shared/brute.wgsl`; keep them in sync).
//!
//! The rule is generic over the distance type ([`Dist`]): f32 as on the GPU, f64 for the CPU
//! reference's `--accel cube`, which walks the same tables with its own tests.

use super::geometry::{Prim32, PrimHit, Ray};
use super::NO_ID;

/// A hit distance type: f32 on the GPU and in the tests, f64 in the reference renderer.
pub trait Dist: Copy + PartialOrd + From<f32> + std::fmt::Debug {
    /// The least f32 not below `self` (the far end of an f32 bounding-sphere test).
    fn far_f32(self) -> f32;
}

impl Dist for f32 {
    fn far_f32(self) -> f32 {
        self
    }
}

impl Dist for f64 {
    fn far_f32(self) -> f32 {
        let f = self as f32;
        if (f as f64) >= self {
            f
        } else if f >= 0.0 {
            f32::from_bits(f.to_bits() + 1)
        } else {
            f32::from_bits(f.to_bits() - 1)
        }
    }
}

/// A nearest-hit answer: whether there is one, the primitive, its distance and what the test
/// returned with it (the f32 [`PrimHit`], or the reference's own hit record).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest<F, H> {
    pub found: bool,
    pub prim: u32,
    pub t: F,
    pub hit: H,
}

/// No hit yet (WGSL `no_closest`).
pub fn no_closest<F: Dist, H: Default>() -> Closest<F, H> {
    Closest { found: false, prim: NO_ID, t: F::from(0.0), hit: H::default() }
}

impl<F: Dist, H> Closest<F, H> {
    /// The distance a hit must beat: the nearest so far, or `t_max` before the first.
    pub fn best_t(&self, t_max: F) -> F {
        if self.found {
            self.t
        } else {
            t_max
        }
    }
}

/// Keeps `hit` (the answer of testing primitive `id` against `t_max`) in `best` when it is
/// nearer than `best_t`, or as near with a lower id. Returns the distance to beat.
pub fn consider<F: Dist, H>(best: &mut Closest<F, H>, id: u32, hit: Option<(F, H)>, best_t: F) -> F {
    if let Some((t, h)) = hit {
        if t < best_t || (t == best_t && best.found && id < best.prim) {
            *best = Closest { found: true, prim: id, t, hit: h };
            return t;
        }
    }
    best_t
}

/// The f32 primitive test as the walkers' test closures want it.
pub fn test_prim(p: &Prim32, ray: &Ray, t_max: f32) -> Option<(f32, PrimHit)> {
    let h = p.intersect(ray, t_max);
    h.ok.then_some((h.t, h))
}

/// Brute force: the nearest hit with `0 < t < t_max` over every primitive but `skip`.
pub fn brute_nearest(prims: &[Prim32], ray: &Ray, t_max: f32, skip: u32) -> Closest<f32, PrimHit> {
    let mut best = no_closest();
    let mut best_t = t_max;
    for (id, p) in prims.iter().enumerate() {
        let id = id as u32;
        if id != skip {
            best_t = consider(&mut best, id, test_prim(p, ray, t_max), best_t);
        }
    }
    best
}
