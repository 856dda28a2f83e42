//! What accuracy costs in time (`cuberay accuracy`): the settings that trade accuracy for
//! time, swept one at a time from a base setting on the GPU, each render measured against a
//! converged reference from the CPU's f64 renderer.
//!
//! The base setting is 4 samples per pixel, depth 5, f32, the scaled spawn offset, the
//! default table resolution and `--accel cube`; each row changes one [`Parameter`]. A row
//! records the kernel time (median of the timed runs after a warm-up), the preprocessing
//! time (the tables are built once per row) and the tables' bytes, the image error
//! ([`metrics::image_error`]), the eye rays' hit error against the reference's at the pixel
//! centres ([`metrics::hit_error`]), and the self-hits and blocked shadow rays the render
//! counted (acne and light leaks). The reference is rendered once per scene, size and
//! settings and kept in a cache file ([`reference()`]).

mod cache;
pub mod metrics;
pub mod plot;
mod report;

pub use cache::{reference, reference_cache, Reference};
pub use report::{csv, pareto, summary, table, Pick, Summary};

use std::collections::HashMap;

use indicatif::ProgressBar;
use serde::{Deserialize, Serialize};

use crate::arith::spawn::SpawnPolicy;
use crate::coherence::defs::default_eye_cells;
use crate::coherence::BuildParams;
use crate::error::{Error, Result};
use crate::gpu::prepare::{build_params, Purpose};
use crate::gpu::GpuRenderer;
use crate::job::{Accel, Precision, RenderOptions};
use crate::output::{Aov, Image};
use crate::sampling::Sampling;
use crate::scene::Scene;
use crate::tablefile::StoredTables;
use metrics::{hit_error, image_error, HitError, ImageError};

/// A setting the sweep varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Parameter {
    /// Samples per pixel (stratified jitter).
    Spp,
    /// Maximum ray-tree depth.
    MaxDepth,
    /// The kernels' intersection arithmetic: f32, f64 where the adapter has it.
    Precision,
    /// The spawn offset: the scaled policy, fixed epsilons of several sizes.
    Offset,
    /// Cells per face edge of the eye's table: time and memory, never the image.
    TableResolution,
    /// The accelerator: time only, never the image.
    Accel,
}

impl Parameter {
    pub const ALL: [Parameter; 6] = [
        Parameter::Spp,
        Parameter::MaxDepth,
        Parameter::Precision,
        Parameter::Offset,
        Parameter::TableResolution,
        Parameter::Accel,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Parameter::Spp => "spp",
            Parameter::MaxDepth => "max_depth",
            Parameter::Precision => "precision",
            Parameter::Offset => "offset",
            Parameter::TableResolution => "table_resolution",
            Parameter::Accel => "accel",
        }
    }
}

/// Fixed spawn offsets tried, as fractions of the scene's bounding diagonal: from below an
/// f32 rounding step of the coordinates (acne) to far more than any (light leaks).
pub const FIXED_OFFSETS: [f64; 4] = [1e-8, 1e-6, 1e-4, 1e-2];

/// Relative offsets tried besides the scaled policy's `2⁻²¹` (`SPAWN_OFFSET_REL`): 8× less
/// (where acne starts on the SPD scenes) and 8× more.
pub const RELATIVE_OFFSETS: [(&str, f32); 2] =
    [("rel 2^-24", 1.0 / 16_777_216.0), ("rel 2^-18", 1.0 / 262_144.0)];

/// What a sweep renders.
#[derive(Clone, Debug, Serialize)]
pub struct Settings {
    pub width: u32,
    pub height: u32,
    /// The base setting's samples per pixel and depth.
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u64,
    /// Timed runs per row, after a warm-up; the median is reported.
    pub runs: u32,
    /// The FLIP mean of the equal-quality summary.
    pub threshold: f64,
    /// 64×64, at most 8 samples per pixel, one timed run (for tests).
    pub quick: bool,
    pub parameters: Vec<Parameter>,
    /// The base setting's precision (`--precision`; default auto). The precision row
    /// renders f32 and f64 whatever it is.
    pub precision: Precision,
}

impl Settings {
    /// The base setting of `width`×`height` (`quick`: the quick one) over `parameters`.
    pub fn new(width: u32, height: u32, quick: bool, parameters: Vec<Parameter>) -> Settings {
        let (width, height) = if quick { (64, 64) } else { (width, height) };
        Settings {
            width,
            height,
            spp: 4,
            max_depth: 5,
            seed: 0,
            runs: if quick { 1 } else { 3 },
            threshold: 0.01,
            quick,
            parameters,
            precision: Precision::Auto,
        }
    }

    /// The base render's options.
    pub fn base(&self) -> RenderOptions {
        RenderOptions {
            spp: self.spp,
            seed: self.seed,
            sampling: Sampling::Pixels,
            max_depth: self.max_depth,
            accel: Accel::Cube,
            precision: self.precision,
            ..RenderOptions::new(self.width, self.height)
        }
    }

    /// The samples per pixel the `spp` rows try.
    fn spp_values(&self) -> Vec<u32> {
        let top = if self.quick { 8 } else { 64 };
        (0..=6).map(|k| 1u32 << k).filter(|&s| s <= top).collect()
    }

    /// The reference's samples per pixel (four times the most a row takes) and depth
    /// (twice the deepest row's).
    pub fn reference_options(&self) -> RenderOptions {
        let spp = 4 * self.spp_values().last().copied().unwrap_or(self.spp).max(self.spp);
        RenderOptions { spp, max_depth: 16, accel: Accel::Auto, ..self.base() }
    }

    /// The rows of `parameter` for `scene` on `gpu`: their value's label and options.
    fn rows(&self, parameter: Parameter, scene: &Scene, gpu: &GpuRenderer) -> Vec<(String, RenderOptions)> {
        let base = self.base();
        let with = |label: String, o: RenderOptions| (label, o);
        match parameter {
            Parameter::Spp => self
                .spp_values()
                .into_iter()
                .map(|spp| with(spp.to_string(), RenderOptions { spp, ..base.clone() }))
                .collect(),
            Parameter::MaxDepth => (1..=8)
                .map(|max_depth| with(max_depth.to_string(), RenderOptions { max_depth, ..base.clone() }))
                .collect(),
            Parameter::Precision => {
                let mut v =
                    vec![with("f32".into(), RenderOptions { precision: Precision::F32, ..base.clone() })];
                if gpu.ctx.f64 {
                    v.push(with("f64".into(), RenderOptions { precision: Precision::F64, ..base.clone() }));
                }
                v
            }
            Parameter::Offset => {
                let size = scene.bounds().diagonal();
                let mut v = vec![with("scaled".into(), base.clone())];
                for (label, rel) in RELATIVE_OFFSETS {
                    v.push(with(
                        label.into(),
                        RenderOptions { spawn: SpawnPolicy::Relative(rel), ..base.clone() },
                    ));
                }
                for k in FIXED_OFFSETS {
                    let spawn = SpawnPolicy::Fixed((k * size) as f32);
                    v.push(with(format!("fixed {k:e}·size"), RenderOptions { spawn, ..base.clone() }));
                }
                v
            }
            Parameter::TableResolution => {
                let params = BuildParams { image: Some((self.width, self.height)), ..BuildParams::default() };
                let n = default_eye_cells(scene, &params);
                [n / 4, n / 2, n, 2 * n]
                    .into_iter()
                    .map(|c| c.max(1))
                    .map(|c| {
                        with(
                            c.to_string(),
                            RenderOptions { eye_cells: (c != n).then_some(c), ..base.clone() },
                        )
                    })
                    .collect()
            }
            Parameter::Accel => Accel::GPU
                .into_iter()
                .filter(|&a| a != Accel::RayQuery || gpu.caps.ray_queries)
                .map(|accel| with(accel.name().into(), RenderOptions { accel, ..base.clone() }))
                .collect(),
        }
    }
}

/// One row of the sweep.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub parameter: Parameter,
    pub value: String,
    /// The base setting (each parameter's series has it).
    pub base: bool,
    /// Kernel time from timestamp queries (median of the timed runs).
    pub gpu_s: f64,
    pub preprocess_s: f64,
    /// Bytes of the tables or the BVH on the device.
    pub table_bytes: u64,
    #[serde(flatten)]
    pub error: ImageError,
    #[serde(flatten)]
    pub hits: HitError,
    /// Spawned rays whose nearest hit lies within 4 spawn offsets of their origin: acne where
    /// the offset is below the rounding error, neighbours that touch the surface where it
    /// is large.
    pub self_hits: u64,
    /// The share of shadow rays blocked (falling below the base's: light leaks).
    pub blocked_share: f64,
    /// The image (for checks; not written).
    #[serde(skip)]
    pub image: Image,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return 0.0;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// A render's measurements, shared by the rows of equal options.
#[derive(Clone)]
struct Measured {
    gpu_s: f64,
    preprocess_s: f64,
    table_bytes: u64,
    error: ImageError,
    hits: HitError,
    self_hits: u64,
    blocked_share: f64,
    image: Image,
}

/// Renders `opts` on `gpu` (a counted run, a warm-up, then `runs` timed runs) and measures
/// it against `reference`.
fn measure(
    gpu: &GpuRenderer,
    scene: &Scene,
    opts: &RenderOptions,
    runs: u32,
    reference: &Reference,
) -> Result<Measured> {
    let hidden = ProgressBar::hidden();
    // The tables are built once for the row and handed to each run: a large offset's tables
    // take many seconds to build, and they are the same every run.
    let (stored, build_s) = match build_params(scene, opts, Purpose::Render)? {
        Some(params) => {
            let start = std::time::Instant::now();
            let tables = crate::coherence::build(scene, &params)?;
            (Some(StoredTables { flat: tables.flat }), start.elapsed().as_secs_f64())
        }
        None => (None, 0.0),
    };
    // A counted run gives the self-hits and blocked shadow rays; the timed runs count nothing,
    // as a render without `--stats` (counting costs lavapipe's kernels 5-22 % of their time),
    // after a warm-up of their own kernels.
    let counted =
        gpu.render_with(scene, &RenderOptions { count: true, ..opts.clone() }, stored.clone(), &hidden)?;
    let timed = RenderOptions { count: false, ..opts.clone() };
    gpu.render_with(scene, &timed, stored.clone(), &hidden)?;
    let mut renders = Vec::new();
    for _ in 0..runs.max(1) {
        renders.push(gpu.render_with(scene, &timed, stored.clone(), &hidden)?);
    }
    let last = renders.last().expect("one run at least");
    let s = &counted.stats;
    let id = gpu.render_aov(scene, &timed, Aov::Id, &hidden)?.image;
    let depth = gpu.render_aov(scene, &timed, Aov::Depth, &hidden)?.image;
    Ok(Measured {
        gpu_s: median(renders.iter().map(|r| r.stats.time.gpu_s.unwrap_or(r.stats.time.trace_s)).collect()),
        preprocess_s: build_s + median(renders.iter().map(|r| r.stats.time.preprocess_s).collect()),
        table_bytes: s.accel_bytes,
        error: image_error(&reference.image, &last.image),
        hits: hit_error(&reference.id, &reference.depth, &id, &depth, scene.bounds().diagonal()),
        self_hits: s.rays.self_hits,
        blocked_share: s.rays.shadow_blocked as f64 / s.rays.shadow.max(1) as f64,
        image: last.image.clone(),
    })
}

/// The sweep of `settings` over `scene` on `gpu` against `reference`; `progress` is told
/// how many rows there are and advanced after each.
pub fn sweep(
    gpu: &GpuRenderer,
    scene: &Scene,
    settings: &Settings,
    reference: &Reference,
    progress: &ProgressBar,
) -> Result<Vec<Row>> {
    if settings.parameters.is_empty() {
        return Err(Error::Options("the sweep has no parameter: name at least one".into()));
    }
    let base = settings.base();
    let plan: Vec<(Parameter, String, RenderOptions)> = settings
        .parameters
        .iter()
        .flat_map(|&p| settings.rows(p, scene, gpu).into_iter().map(move |(v, o)| (p, v, o)))
        .collect();
    progress.set_length(plan.len() as u64);
    // Rows with the same options (the base setting in every series) are rendered once.
    let mut done: HashMap<String, Measured> = HashMap::new();
    let mut rows = Vec::with_capacity(plan.len());
    for (parameter, value, opts) in plan {
        crate::interrupt::check()?;
        progress.set_message(format!("{} {value}", parameter.name()));
        let key = format!("{opts:?}");
        let m = match done.get(&key) {
            Some(m) => m.clone(),
            None => {
                let m = measure(gpu, scene, &opts, settings.runs, reference)?;
                done.insert(key.clone(), m.clone());
                m
            }
        };
        rows.push(Row {
            parameter,
            value,
            base: key == format!("{base:?}"),
            gpu_s: m.gpu_s,
            preprocess_s: m.preprocess_s,
            table_bytes: m.table_bytes,
            error: m.error,
            hits: m.hits,
            self_hits: m.self_hits,
            blocked_share: m.blocked_share,
            image: m.image,
        });
        progress.inc(1);
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(parameter: Parameter, value: &str, gpu_s: f64, flip_mean: f64, base: bool) -> Row {
        Row {
            parameter,
            value: value.into(),
            base,
            gpu_s,
            preprocess_s: 0.0,
            table_bytes: 0,
            error: ImageError { flip_mean, ..Default::default() },
            hits: HitError::default(),
            self_hits: 0,
            blocked_share: 0.0,
            image: Image::new(1, 1, false),
        }
    }

    #[test]
    fn the_front_and_the_summaries_pick_the_right_rows() {
        let rows = vec![
            row(Parameter::Spp, "1", 1.0, 0.04, false),
            row(Parameter::Spp, "4", 4.0, 0.02, true),
            row(Parameter::Spp, "16", 16.0, 0.008, false),
            // Slower and worse than spp 4: off the front.
            row(Parameter::MaxDepth, "2", 5.0, 0.03, false),
            // As fast as the base and better: the equal-time pick.
            row(Parameter::MaxDepth, "3", 3.5, 0.015, false),
        ];
        assert_eq!(pareto(&rows), [0, 2, 4]);
        let s = summary(&rows, 0.01);
        assert_eq!((s.base_gpu_s, s.base_flip_mean), (4.0, 0.02));
        let t = s.equal_time.clone().unwrap();
        assert_eq!((t.parameter, t.value.as_str()), (Parameter::MaxDepth, "3"));
        let q = s.equal_quality.clone().unwrap();
        assert_eq!((q.parameter, q.value.as_str()), (Parameter::Spp, "16"));
        assert!(summary(&rows, 0.001).equal_quality.is_none());
        let text = table(&rows, &s);
        assert!(text.contains("| spp | 4 (base) |") && text.contains("| spp | 16 * |"), "{text}");
        let csv = csv(&rows);
        assert_eq!(csv.lines().count(), 6);
        assert!(csv.lines().nth(2).unwrap().starts_with("spp,4,true,4,"));
    }

    #[test]
    fn settings_sweep_what_they_say() {
        let s = Settings::new(256, 128, false, vec![Parameter::Spp]);
        assert_eq!((s.width, s.height, s.runs), (256, 128, 3));
        assert_eq!(s.spp_values(), [1, 2, 4, 8, 16, 32, 64]);
        let r = s.reference_options();
        assert_eq!((r.spp, r.max_depth), (256, 16));
        let q = Settings::new(256, 128, true, vec![Parameter::Spp]);
        assert_eq!((q.width, q.height, q.runs, q.spp_values().len()), (64, 64, 1, 4));
        assert_eq!(q.reference_options().spp, 32);
    }
}
