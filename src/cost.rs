//! What `--accel auto` weighs, per origin (the eye, each point or spot light): the predicted
//! time to build the origin's direction-cube table against the kernel time the table saves
//! the rays traced from it, over the BVH those rays walk otherwise. A table is built only
//! where it pays; with none, the render is `--accel bvh`.
//!
//! The model is linear and deliberately simple (docs/performance.md, "what auto weighs",
//! has the measurements it is calibrated on, and `cuberay bench` prints the measured build
//! and kernel times beside its predictions for any scene):
//! - an origin's build costs [`BUILD_S_PER_PRIM`] of one core per primitive and
//!   [`BUILD_S_PER_CELL`] per cell of its cube, spread over the build's threads;
//! - an eye ray traced through the eye's table instead of the BVH saves [`SAVED_S_PER_EYE_RAY`],
//!   a shadow ray through its light's table [`SAVED_S_PER_SHADOW_RAY`]; a render traces one
//!   eye ray per grid point and sample, and a shadow ray per light and hit of its tree
//!   (more where mirrors and glass make the trees deeper).
//!
//! The tables' saving per ray shrinks as the scene grows (at a million primitives the
//! kernels measured the same with either), while the build grows with it: the model keeps
//! the saving constant, which errs towards the tables only where both are small.

use crate::coherence::{BuildParams, OriginKey};
use crate::scene::{Effects, LightKind, Scene};

/// Seconds of one core an origin's table build costs per primitive and per cell of its
/// cube (docs/performance.md, "what auto weighs": fitted on the SPD at 512², 4k–1M
/// primitives, 2 cores; gears_s4's large polygons cost 4× more a cell).
pub const BUILD_S_PER_PRIM: f64 = 1.0e-6;
pub const BUILD_S_PER_CELL: f64 = 0.3e-6;

/// Kernel seconds an eye ray saves walking the eye's table instead of the wide BVH (the
/// canonical SPD at 512², Mesa 22.3: 0.08–0.14 µs).
pub const SAVED_S_PER_EYE_RAY: f64 = 0.1e-6;

/// Kernel seconds a shadow ray saves walking its light's table instead of the wide BVH (the
/// same scenes: 0.03–0.17 µs).
pub const SAVED_S_PER_SHADOW_RAY: f64 = 0.05e-6;

/// The hits an eye ray's tree makes, each of which traces a shadow ray to every light: one,
/// and where a share `r` of the primitives reflects or transmits, `r` more at each further
/// depth (the SPD's mirrored scenes: 2–5 at depth 5).
fn hits_per_eye_ray(scene: &Scene, effects: Effects, max_depth: u32) -> f64 {
    if scene.primitives.is_empty() || !effects.reflection {
        return 1.0;
    }
    let spawning = scene
        .primitives
        .iter()
        .filter(|p| {
            let m = &scene.materials[p.material() as usize];
            m.reflects() || m.transmits()
        })
        .count();
    1.0 + (spawning as f64 / scene.primitives.len() as f64) * max_depth.saturating_sub(1) as f64
}

/// Seconds a render that mixes origins with and without tables pays over one that does not
/// (lavapipe, Mesa 22.3: the kernels of both walks compiled at first dispatch, and a shadow
/// kernel that carries both; measured as the whole `render` command on the canonical SPD at
/// 512², docs/performance.md, "what auto weighs").
pub const MIXED_S: f64 = 0.08;

/// One origin's prediction.
#[derive(Clone, Debug, PartialEq)]
pub struct OriginCost {
    pub key: OriginKey,
    /// Rays the render traces from it.
    pub rays: u64,
    /// Predicted seconds of its table's build, and of kernel time the table saves.
    pub build_s: f64,
    pub saved_s: f64,
}

impl OriginCost {
    /// Whether the table pays for its build.
    pub fn pays(&self) -> bool {
        self.build_s < self.saved_s
    }

    /// "the eye", "light 2".
    pub fn name(&self) -> String {
        match self.key {
            OriginKey::Eye => "the eye".into(),
            OriginKey::Light(i) => format!("light {i}"),
            OriginKey::Surface(_) => "a surface".into(),
        }
    }
}

/// What `--accel auto` chose for a render, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct AutoAccel {
    /// Every origin that could have a table, with its prediction.
    pub origins: Vec<OriginCost>,
    /// Whether each origin gets its table: every one, none, or those that pay, whichever is
    /// predicted fastest, a mix paying [`MIXED_S`].
    pub tables: Vec<bool>,
}

impl AutoAccel {
    /// Predicts the tables of `scene` (whose effects are `effects`) for a render tracing
    /// `eye_rays` eye rays to `max_depth`, built with `params` (the eye's cells from its
    /// image, the lights' from their budget) on `threads` build threads.
    pub fn predict(
        scene: &Scene,
        eye_rays: u64,
        max_depth: u32,
        effects: Effects,
        params: &BuildParams,
        threads: usize,
    ) -> AutoAccel {
        let (w, h) = params.eye_image(scene);
        let eye_cells = (w as f64 * h as f64) / (params.eye_pixels_per_cell * params.eye_pixels_per_cell);
        let build_s = |cells: f64| {
            (BUILD_S_PER_PRIM * scene.primitives.len() as f64 + BUILD_S_PER_CELL * cells)
                / threads.max(1) as f64
        };
        let shadow_rays = (eye_rays as f64 * hits_per_eye_ray(scene, effects, max_depth)) as u64;
        let mut origins = Vec::new();
        if !scene.primitives.is_empty() {
            origins.push(OriginCost {
                key: OriginKey::Eye,
                rays: eye_rays,
                build_s: build_s(eye_cells),
                saved_s: eye_rays as f64 * SAVED_S_PER_EYE_RAY,
            });
            if effects.shadows {
                for (i, l) in scene.lights.iter().enumerate() {
                    if l.kind != LightKind::Directional {
                        origins.push(OriginCost {
                            key: OriginKey::Light(i),
                            rays: shadow_rays,
                            build_s: build_s(params.light_cells as f64),
                            saved_s: shadow_rays as f64 * SAVED_S_PER_SHADOW_RAY,
                        });
                    }
                }
            }
        }
        let tables = Self::cheapest(&origins);
        AutoAccel { origins, tables }
    }

    /// Which origins get a table: every one, none, or those whose table pays (plus
    /// [`MIXED_S`]), whichever has the least predicted build less saving.
    fn cheapest(origins: &[OriginCost]) -> Vec<bool> {
        let net = |o: &OriginCost| o.build_s - o.saved_s;
        let all: f64 = origins.iter().map(net).sum();
        let paying: f64 = origins.iter().filter(|o| o.pays()).map(net).sum();
        let mixed = origins.iter().any(OriginCost::pays) && !origins.iter().all(OriginCost::pays);
        let some = paying + if mixed { MIXED_S } else { 0.0 };
        if all <= some.min(0.0) {
            vec![true; origins.len()]
        } else if some < 0.0 {
            origins.iter().map(OriginCost::pays).collect()
        } else {
            vec![false; origins.len()]
        }
    }

    /// Whether any table pays: the render is `cube`, else `bvh`.
    pub fn any(&self) -> bool {
        self.tables.iter().any(|&t| t)
    }

    /// The origins left without a table.
    pub fn untabled(&self) -> Vec<OriginKey> {
        self.origins.iter().zip(&self.tables).filter(|(_, &t)| !t).map(|(o, _)| o.key).collect()
    }

    /// One line for `info` and `--stats`: what was chosen for each origin, with the
    /// predicted seconds.
    pub fn reason(&self) -> String {
        if self.origins.is_empty() {
            return "no origin to build a table for".into();
        }
        let list = |tabled: bool| -> Vec<String> {
            self.origins
                .iter()
                .zip(&self.tables)
                .filter(|(_, &t)| t == tabled)
                .map(|(o, _)| format!("{} ({:.3} s to build, {:.3} s saved)", o.name(), o.build_s, o.saved_s))
                .collect()
        };
        let (tabled, untabled) = (list(true), list(false));
        match (tabled.is_empty(), untabled.is_empty()) {
            (true, _) => format!("no tables: they would cost more than they save: {}", untabled.join(", ")),
            (false, true) => format!("every table pays for its build: {}", tabled.join(", ")),
            (false, false) => {
                format!("tables for {}; the BVH for {}", tabled.join(", "), untabled.join(", "))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The effects of a scene without mirrors, with shadows or not.
    fn lit(shadows: bool) -> Effects {
        Effects { shadows, ..Effects::default() }
    }

    fn scene_of(prims: usize, lights: usize) -> Scene {
        crate::load::nff::parse(
            &format!(
                "v\nfrom 0 0 -10\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 64 64\n{}f 1 1 1 0.5 0 0 0 1\n{}",
                (0..lights).map(|i| format!("l {i} 5 -5\n")).collect::<String>(),
                (0..prims).map(|i| format!("s {} 0 0 0.1\n", i as f64 * 0.01)).collect::<String>()
            ),
            std::path::Path::new("t.nff"),
        )
        .unwrap()
        .scene
    }

    /// Small scenes in big images take every table, big scenes in small images none, and
    /// an eye's table pays before a light's (its rays save more).
    #[test]
    fn tables_pay_where_rays_outnumber_primitives() {
        let (small, big) = (scene_of(100, 2), scene_of(20_000, 2));
        // No cells to speak of: the primitives decide.
        let params = BuildParams { image: Some((2, 2)), light_cells: 1, ..BuildParams::default() };
        let all = AutoAccel::predict(&small, 512 * 512, 5, lit(true), &params, 2);
        assert_eq!(all.origins.len(), 3);
        assert!(all.untabled().is_empty(), "{}", all.reason());
        let none = AutoAccel::predict(&big, 64 * 64, 5, lit(true), &params, 2);
        assert!(!none.any(), "{}", none.reason());
        assert!(none.reason().starts_with("no tables"), "{}", none.reason());
        // The eye's table saves 0.2 s more than its build, which outweighs a mix's cost; the
        // lights' cells make theirs cost more than they save.
        let rays = ((BUILD_S_PER_PRIM * 10_000.0 + 0.2) / SAVED_S_PER_EYE_RAY) as u64;
        let costly = BuildParams { light_cells: 1 << 24, ..params.clone() };
        let eye = AutoAccel::predict(&big, rays, 5, lit(true), &costly, 2);
        assert_eq!(eye.untabled(), vec![OriginKey::Light(0), OriginKey::Light(1)], "{}", eye.reason());
        assert!(eye.reason().starts_with("tables for the eye"), "{}", eye.reason());
        // Where the eye's gain is smaller than a mix's cost, no table at all.
        let rays = ((BUILD_S_PER_PRIM * 10_000.0 + MIXED_S / 2.0) / SAVED_S_PER_EYE_RAY) as u64;
        let small_gain = AutoAccel::predict(&big, rays, 5, lit(true), &costly, 2);
        assert!(small_gain.origins[0].pays() && !small_gain.any(), "{}", small_gain.reason());
        let unlit = AutoAccel::predict(&small, 512 * 512, 5, lit(false), &params, 2);
        assert_eq!(unlit.origins.len(), 1);
        // A light's cells cost its table too.
        let cells = BuildParams { light_cells: 1 << 30, ..params };
        let costly_lights = AutoAccel::predict(&small, 512 * 512, 5, lit(true), &cells, 2);
        let (eye, lights) = (&costly_lights.origins[0], &costly_lights.origins[1..]);
        assert!(eye.pays() && lights.iter().all(|o| !o.pays()), "{}", costly_lights.reason());
    }
}
