//! The wave plan: which passes of which wavefront kernel a wave of a tile runs, in what
//! order, over which queues ([`WavePlan::passes`]). Plain data, apart from wgpu: the
//! schedule ([`super::schedule`]) encodes the passes and dispatches them.
//!
//! A wave traces one sample of every point of a tile. In the register form
//! ([`KernelForm::Tree`]) it is one pass of the `tree` kernel, each invocation tracing its
//! point's whole ray tree. In the wavefront form: depth by depth, passes of `nearest`
//! (the first of them making the eye rays; retry passes for walks longer than a pass), one
//! of `shade` over the depth's hits, then passes of `shadow` for the shadow rays too long to
//! trace at their hit. Queues alternate between depths, and each is emptied before the pass
//! that fills it.

use super::shaders::{Kernel, Variant};
pub use crate::job::KernelForm;
use crate::layout::{
    PassDesc, QUEUE_COUNT, QUEUE_HIT, QUEUE_RAY0, QUEUE_RAY1, QUEUE_RETRY0, QUEUE_RETRY1, QUEUE_SHADOW,
    QUEUE_SRETRY0, QUEUE_SRETRY1, SRC_EYE,
};

/// The queue a pass names for rays it must not spawn: a push there raises
/// [`crate::layout::structs::OVERFLOW_UNFINISHED`] (a walk outlasted its passes).
pub const NO_QUEUE: u32 = QUEUE_COUNT;

/// What the waves of one render do: rays to `max_depth` (the eye ray is depth 1), shadow
/// passes when `shadows`, and `retries` more passes of `nearest` (and of `shadow`) per depth
/// for walks longer than one; or, in the register form (`form` [`KernelForm::Tree`]), one
/// pass of the `tree` kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WavePlan {
    pub max_depth: u32,
    pub shadows: bool,
    pub retries: u32,
    pub form: KernelForm,
}

/// One pass of a wave: its kernel and descriptor, the queues to empty before it, and the
/// queue whose length sizes its dispatch (`None`: one invocation per point of the tile).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pass {
    pub kernel: Kernel,
    pub desc: PassDesc,
    pub resets: Vec<u32>,
    pub over: Option<u32>,
}

impl WavePlan {
    /// The waves of a render of `variant` to `max_depth`, with `retries` more passes per
    /// depth. Only a variant that spawns rays from its hits (mirrors, glass or blended
    /// surfaces) traces past the eye's depth: the passes of an empty depth still cost
    /// lavapipe about 50 µs each, and at depth 5 they took 13–15 % of tetra_s6's kernel time.
    /// `form` is the resolved one (not [`KernelForm::Auto`]).
    pub fn new(variant: Variant, max_depth: u32, retries: u32, form: KernelForm) -> WavePlan {
        let spawns = variant.effects.reflection || variant.effects.refraction || variant.effects.blend;
        WavePlan {
            max_depth: if spawns { max_depth } else { max_depth.min(1) },
            shadows: variant.effects.shadows,
            retries,
            form,
        }
    }

    /// The passes of the wave of sample `sample`.
    pub fn passes(&self, sample: u32) -> Vec<Pass> {
        if self.form == KernelForm::Tree {
            let desc = PassDesc {
                src: SRC_EYE,
                next: NO_QUEUE,
                shadow: NO_QUEUE,
                retry: NO_QUEUE,
                sample,
                hit: NO_QUEUE,
                depth: 1,
                ..PassDesc::default()
            };
            return vec![Pass { kernel: Kernel::Tree, desc, resets: Vec::new(), over: None }];
        }
        let mut v = Vec::new();
        // Retry queues in turn; the last pass of a depth has none left.
        let retry =
            |r: u32, pair: [u32; 2]| if r == self.retries { NO_QUEUE } else { pair[(r % 2) as usize] };
        for depth in 1..=self.max_depth {
            let desc = |src, next, shadow, retry| PassDesc {
                src,
                next,
                shadow,
                retry,
                sample,
                hit: NO_QUEUE,
                depth,
                ..PassDesc::default()
            };
            let (src, next) =
                if depth % 2 == 1 { (QUEUE_RAY0, QUEUE_RAY1) } else { (QUEUE_RAY1, QUEUE_RAY0) };
            let pair = [QUEUE_RETRY0, QUEUE_RETRY1];
            for r in 0..=self.retries {
                // The first pass makes the eye rays itself, one per point of the tile.
                let from = match r {
                    0 if depth == 1 => SRC_EYE,
                    0 => src,
                    _ => pair[((r - 1) % 2) as usize],
                };
                let into = retry(r, pair);
                let mut resets = if r == 0 { vec![QUEUE_HIT] } else { Vec::new() };
                resets.extend((into != NO_QUEUE).then_some(into));
                v.push(Pass {
                    kernel: Kernel::Nearest,
                    desc: PassDesc { hit: QUEUE_HIT, ..desc(from, NO_QUEUE, NO_QUEUE, into) },
                    resets,
                    over: (from != SRC_EYE).then_some(from),
                });
            }
            // The hits of every pass of the depth, shaded at once.
            v.push(Pass {
                kernel: Kernel::Shade,
                desc: desc(QUEUE_HIT, next, QUEUE_SHADOW, NO_QUEUE),
                resets: vec![next, QUEUE_SHADOW],
                over: Some(QUEUE_HIT),
            });
            if self.shadows {
                let pair = [QUEUE_SRETRY0, QUEUE_SRETRY1];
                for r in 0..=self.retries {
                    let from = if r == 0 { QUEUE_SHADOW } else { pair[((r - 1) % 2) as usize] };
                    let into = retry(r, pair);
                    let resets = (into != NO_QUEUE).then_some(into).into_iter().collect();
                    v.push(Pass {
                        kernel: Kernel::Shadow,
                        desc: desc(from, NO_QUEUE, NO_QUEUE, into),
                        resets,
                        over: Some(from),
                    });
                }
            }
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Effects;

    /// Each queue a pass reads was emptied before the pass that fills it and is read only
    /// after: following the passes, every read finds a queue some earlier pass wrote into
    /// since its last reset, and nothing reads a queue it writes.
    #[test]
    fn passes_read_what_earlier_passes_wrote() {
        for plan in [
            WavePlan { max_depth: 1, shadows: false, retries: 0, form: KernelForm::Wavefront },
            WavePlan { max_depth: 5, shadows: true, retries: 0, form: KernelForm::Wavefront },
            WavePlan { max_depth: 5, shadows: true, retries: 3, form: KernelForm::Wavefront },
            WavePlan { max_depth: 16, shadows: false, retries: 1, form: KernelForm::Wavefront },
        ] {
            let passes = plan.passes(7);
            // The first pass makes the eye rays: one invocation per point, no queue read.
            assert_eq!(passes[0].kernel, Kernel::Nearest);
            assert_eq!((passes[0].desc.src, passes[0].over), (SRC_EYE, None));
            assert!(passes.iter().all(|p| p.desc.sample == 7));
            assert_eq!(passes.iter().filter(|p| p.desc.src == SRC_EYE).count(), 1);
            let count = |k: Kernel| passes.iter().filter(|p| p.kernel == k).count() as u32;
            assert_eq!(count(Kernel::Nearest), plan.max_depth * (plan.retries + 1), "{plan:?}");
            assert_eq!(count(Kernel::Shade), plan.max_depth, "{plan:?}");
            let shadow = count(Kernel::Shadow);
            assert_eq!(shadow, if plan.shadows { plan.max_depth * (plan.retries + 1) } else { 0 });
            // Queues written since their last reset.
            let mut filled = [false; QUEUE_COUNT as usize];
            for p in &passes {
                for &q in &p.resets {
                    filled[q as usize] = false;
                }
                let d = p.desc;
                if let Some(q) = p.over {
                    assert!(filled[q as usize], "{plan:?}: {p:?} reads queue {q}, which nothing filled");
                    assert!(![d.next, d.shadow, d.retry, d.hit].contains(&q), "{p:?}");
                }
                // What each kernel pushes to; the queues it does not push to are NO_QUEUE.
                let (writes, unused) = match p.kernel {
                    Kernel::Nearest => (vec![d.hit, d.retry], vec![d.next, d.shadow]),
                    Kernel::Shade => (vec![d.next, d.shadow], vec![d.hit, d.retry]),
                    _ => (vec![d.retry], vec![d.next, d.shadow, d.hit]),
                };
                assert!(unused.iter().all(|&q| q == NO_QUEUE), "{p:?}");
                for q in writes.into_iter().filter(|&q| q < QUEUE_COUNT) {
                    filled[q as usize] = true;
                }
            }
            // The last pass of each depth has no retry queue: a longer walk is reported.
            let last_nearest: Vec<&Pass> = passes
                .iter()
                .filter(|p| p.kernel == Kernel::Nearest)
                .skip(plan.retries as usize)
                .step_by(plan.retries as usize + 1)
                .collect();
            assert!(last_nearest.iter().all(|p| p.desc.retry == NO_QUEUE), "{plan:?}");
        }
    }

    /// Only hits that spawn rays (mirrors, glass) need the depths past the eye's.
    #[test]
    fn a_plan_traces_past_the_eye_only_where_hits_spawn_rays() {
        let lit = Effects { shadows: true, ..Effects::default() };
        let matte = Variant { effects: lit, ..Variant::default() };
        let plan = WavePlan::new(matte, 5, 2, KernelForm::Wavefront);
        assert_eq!(plan, WavePlan { max_depth: 1, shadows: true, retries: 2, form: KernelForm::Wavefront });
        assert!(plan.passes(0).iter().all(|p| p.desc.next == NO_QUEUE || p.kernel == Kernel::Shade));
        let mirror = Effects { reflection: true, ..lit };
        let glass = Effects { refraction: true, ..lit };
        for v in [Variant { effects: mirror, ..matte }, Variant { effects: glass, ..matte }] {
            assert_eq!(WavePlan::new(v, 5, 2, KernelForm::Wavefront).max_depth, 5, "{v:?}");
        }
        assert_eq!(WavePlan::new(matte, 0, 0, KernelForm::Wavefront).max_depth, 0);
    }

    /// The register form's wave is one pass of the `tree` kernel, over the tile's points,
    /// that makes its own eye rays and pushes into no queue, whatever the depth and lights.
    #[test]
    fn a_tree_wave_is_one_pass_that_makes_its_eye_rays() {
        let mirror = Variant {
            effects: Effects { shadows: true, reflection: true, ..Effects::default() },
            ..Variant::default()
        };
        let plan = WavePlan::new(mirror, 5, 3, KernelForm::Tree);
        let passes = plan.passes(7);
        assert_eq!(passes.len(), 1);
        let p = &passes[0];
        assert_eq!((p.kernel, p.over, p.resets.len()), (Kernel::Tree, None, 0));
        assert_eq!((p.desc.src, p.desc.sample, p.desc.depth), (SRC_EYE, 7, 1));
        for q in [p.desc.next, p.desc.shadow, p.desc.retry, p.desc.hit] {
            assert_eq!(q, NO_QUEUE);
        }
    }
}
