//! The nearest-hit rule every query shares, table walk, BVH and brute force alike, on the GPU
//! and in the f64 reference (twins of WGSL `Closest`, `no_closest`, `consider`,
//! `closest_limit` and `closest_again` in `shaders/shared/closest.wgsl`, and of
//! `brute_nearest` in `shaders/shared/brute.wgsl`; keep them in sync).
//!
//! # Ties within the error bound
//! Every hit comes with `err`, a bound on the rounding error of its distance `t` from the
//! intersection test's own arithmetic ([`super::geometry`], `reference::geometry`). The
//! *window* of a ray is the least `t + err` over its hits, and its *tie set* is every hit
//! with `t ≤ window`: the hits that rounding could have made the nearest (the nearest
//! computed hit is always in it). The lowest primitive id in the tie set wins. This is a
//! property of the set of hits, not of the order they are tested in, so every accelerator
//! gives the same answer; coplanar overlapping surfaces, whose distances differ only by
//! rounding, show the lower id on the GPU and the CPU alike.
//!
//! A walk stops once its next lower bound passes the window ([`Closest::limit`]): no hit
//! beyond it can join the tie set. It keeps the winner so far, the window and the least `t`.
//! When a hit narrows the window past the winner while some earlier hit stays inside, the
//! winner among those cannot be known from what was kept: the answer is marked `lost`, and
//! the caller walks the ray again with the final window ([`Closest::again`]), in which the
//! window cannot narrow any further. That takes at least three hits within a few rounding
//! errors of each other, so almost no ray walks twice.
//!
//! The rule is generic over the distance type ([`Dist`]): f32 as on the GPU, f64 for the CPU
//! reference.

use super::geometry::{Prim32, PrimHit, Ray};
use super::NO_ID;

/// A hit distance type: f32 on the GPU and in the tests, f64 in the reference renderer.
pub trait Dist: Copy + PartialOrd + From<f32> + std::ops::Add<Output = Self> + std::fmt::Debug {
    /// Larger than every distance.
    const INFINITY: Self;
    /// The least f32 not below `self` (the far end of an f32 bounding-sphere test).
    fn far_f32(self) -> f32;
}

impl Dist for f32 {
    const INFINITY: f32 = f32::INFINITY;
    fn far_f32(self) -> f32 {
        self
    }
}

impl Dist for f64 {
    const INFINITY: f64 = f64::INFINITY;
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

/// What a primitive test hands the rule: the distance, the bound on its rounding error, and
/// the test's own record (the f32 [`PrimHit`], or the reference's hit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestHit<F, H> {
    pub t: F,
    pub err: F,
    pub hit: H,
}

/// A nearest-hit answer: whether there is one, the winning primitive, its distance and
/// record, and the walk's tie bookkeeping (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest<F, H> {
    pub found: bool,
    pub prim: u32,
    pub t: F,
    pub hit: H,
    /// The least `t + err` over the hits so far (infinite before the first).
    pub window: F,
    /// The least `t` over the hits so far (infinite before the first).
    pub t_min: F,
    /// The winner among the hits inside the window was lost: walk again ([`Closest::again`]).
    pub lost: bool,
}

/// No hit yet (WGSL `no_closest`).
pub fn no_closest<F: Dist, H: Default>() -> Closest<F, H> {
    Closest {
        found: false,
        prim: NO_ID,
        t: F::from(0.0),
        hit: H::default(),
        window: F::INFINITY,
        t_min: F::INFINITY,
        lost: false,
    }
}

impl<F: Dist, H: Default> Closest<F, H> {
    /// A fresh answer for the second walk of a ray whose first lost its winner: no hit yet,
    /// the window already the first walk's final one (WGSL `closest_again`).
    pub fn again(&self) -> Closest<F, H> {
        Closest { window: self.window, ..no_closest() }
    }
}

impl<F: Dist, H> Closest<F, H> {
    /// How far a walk must go on: no hit beyond this can join the tie set (the window, or
    /// `t_max` while it is wider; WGSL `closest_limit`).
    pub fn limit(&self, t_max: F) -> F {
        if self.window < t_max {
            self.window
        } else {
            t_max
        }
    }

    /// The winner's distance, or `t_max` when there is none.
    pub fn best_t(&self, t_max: F) -> F {
        if self.found {
            self.t
        } else {
            t_max
        }
    }
}

/// Takes hit `hit` of primitive `id` (a test's answer, `None` for a miss) into `best` by the
/// tie rule; returns the new [`Closest::limit`] for `t_max`.
pub fn consider<F: Dist, H>(best: &mut Closest<F, H>, id: u32, hit: Option<TestHit<F, H>>, t_max: F) -> F {
    if let Some(h) = hit {
        let reach = h.t + h.err;
        let window = if reach < best.window { reach } else { best.window };
        let stays = best.found && best.t <= window;
        if best.found && !stays && best.t_min <= window {
            // The winner left the window but an earlier hit did not: which one has the lowest
            // id was not kept.
            best.lost = true;
        }
        let joins = h.t <= window;
        if joins && (!stays || id < best.prim) {
            best.found = true;
            best.prim = id;
            best.t = h.t;
            best.hit = h.hit;
        }
        best.window = window;
        if h.t < best.t_min {
            best.t_min = h.t;
        }
    }
    best.limit(t_max)
}

/// The f32 primitive test as the walkers' test closures want it.
pub fn test_prim(p: &Prim32, ray: &Ray, t_max: f32) -> Option<TestHit<f32, PrimHit>> {
    let h = p.intersect(ray, t_max);
    h.ok.then_some(TestHit { t: h.t, err: h.err, hit: h })
}

/// Brute force: the nearest hit with `0 < t < t_max` over every primitive but `skip`, by the
/// tie rule.
pub fn brute_nearest(prims: &[Prim32], ray: &Ray, t_max: f32, skip: u32) -> Closest<f32, PrimHit> {
    let walk = |mut best: Closest<f32, PrimHit>| {
        for (id, p) in prims.iter().enumerate() {
            let id = id as u32;
            if id != skip {
                consider(&mut best, id, test_prim(p, ray, t_max), t_max);
            }
        }
        best
    };
    let best = walk(no_closest());
    if best.lost {
        walk(best.again())
    } else {
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hits `(id, t, err)` in every order give one answer: the lowest id with
    /// `t ≤ min(t + err)`, after a second walk where the first lost it.
    #[test]
    fn the_tie_rule_does_not_depend_on_the_order_of_the_tests() {
        let cases: &[&[(u32, f64, f64)]] = &[
            &[(5, 1.0, 0.0), (3, 2.0, 0.0)],
            &[(5, 1.0, 0.1), (3, 1.05, 0.0), (1, 1.2, 0.0)],
            // The window narrows past the first winner while another stays: lost, walked again.
            &[(1, 1.0 + 2e-3, 1e-2), (2, 1.0 + 1e-3, 1e-2), (5, 1.0, 1.5e-3)],
            &[(4, 1.0, 1e-3), (2, 1.0005, 1e-3), (3, 1.0009, 1e-3), (1, 1.0011, 1e-3)],
            &[(7, 3.0, 1.0), (6, 2.5, 0.2), (2, 2.71, 0.0), (1, 2.69, 0.5)],
        ];
        for hits in cases {
            let window = hits.iter().map(|h| h.1 + h.2).fold(f64::INFINITY, f64::min);
            let want = hits.iter().filter(|h| h.1 <= window).map(|h| h.0).min().unwrap();
            let mut order: Vec<usize> = (0..hits.len()).collect();
            permutations(&mut order, 0, &mut |order| {
                let walk = |mut best: Closest<f64, ()>| {
                    for &i in order {
                        let (id, t, err) = hits[i];
                        consider(&mut best, id, Some(TestHit { t, err, hit: () }), 10.0);
                    }
                    best
                };
                let first = walk(no_closest());
                let best = if first.lost { walk(first.again()) } else { first };
                assert!(!best.lost && best.found);
                assert_eq!(best.prim, want, "{hits:?} in the order {order:?}");
                assert_eq!(best.window, window);
            });
        }
    }

    fn permutations(v: &mut Vec<usize>, k: usize, f: &mut dyn FnMut(&[usize])) {
        if k == v.len() {
            f(v);
            return;
        }
        for i in k..v.len() {
            v.swap(k, i);
            permutations(v, k + 1, f);
            v.swap(k, i);
        }
    }

    #[test]
    fn misses_change_nothing_and_the_limit_is_the_window() {
        let mut best = no_closest::<f32, ()>();
        assert_eq!(consider(&mut best, 0, None, 5.0), 5.0);
        assert!(!best.found);
        assert_eq!(consider(&mut best, 3, Some(TestHit { t: 2.0, err: 0.5, hit: () }), 5.0), 2.5);
        assert_eq!(consider(&mut best, 1, Some(TestHit { t: 2.4, err: 0.0, hit: () }), 5.0), 2.4);
        assert_eq!((best.prim, best.t), (1, 2.4));
        assert_eq!(consider(&mut best, 0, Some(TestHit { t: 4.0, err: 9.0, hit: () }), 5.0), 2.4);
        assert_eq!(best.prim, 1);
    }
}
