//! The CPU reference renderer: Whitted ray tracing of a [`Scene`] in f64, independent of
//! the coherence tables. It is the yardstick the GPU renderer is judged against.
//!
//! - [`geometry`]: rays, exact-as-practical primitive intersection, robust spawn offsets;
//! - [`accel`]: brute force and BVH behind the [`accel::Accel`] trait, which receives
//!   each ray's origin entity so that the direction-cube tables can plug in;
//! - [`cube`]: `--accel cube`, the reference's own intersection tests in the order and
//!   number the direction-cube tables of [`crate::coherence`] choose;
//! - [`shade`]: the Whitted shading model and the ray tree;
//! - [`sampling`]: where eye rays go (pixel centres, stratified jitter, SPD corners);
//! - [`texture`]: texture sampling.
//!
//! [`render`] produces a linear radiance image and [`render_aov`] an auxiliary image, both
//! with [`Stats`] counted per the SPD procedure. Rows are traced in parallel (rayon);
//! the result does not depend on the number of threads.

use std::time::Instant;

use glam::DVec3;
use indicatif::ProgressBar;
use rayon::prelude::*;

use crate::output::{Aov, Image};
use crate::scene::Scene;
use crate::stats::{self, Counters, Stats};

pub mod accel;
pub mod cube;
pub mod geometry;
pub mod sampling;
pub mod shade;
pub mod texture;

pub use accel::AccelKind;
pub use sampling::Sampling;

use geometry::Ray;
use shade::Tracer;

/// What to render and how.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel with [`Sampling::Center`] (1: the pixel centre; N > 1:
    /// stratified jitter). Must be 1 with [`Sampling::Corners`].
    pub spp: u32,
    pub seed: u64,
    pub sampling: Sampling,
    /// Maximum ray-tree depth, the eye ray being depth 1 (SPD: 5).
    pub max_depth: u32,
    pub accel: AccelKind,
}

impl RenderOptions {
    /// Pixel centres, one sample, depth 5, automatic acceleration.
    pub fn new(width: u32, height: u32) -> RenderOptions {
        RenderOptions {
            width,
            height,
            spp: 1,
            seed: 0,
            sampling: Sampling::Center,
            max_depth: 5,
            accel: AccelKind::Auto,
        }
    }

    /// Checks the options; the error says what is wrong in words.
    pub fn validate(&self) -> Result<(), RenderError> {
        let bad = |m: String| Err(RenderError::Options(m));
        if self.width == 0 || self.height == 0 || self.width > 32768 || self.height > 32768 {
            return bad(format!(
                "image size {}x{} is not within 1..=32768 per side",
                self.width, self.height
            ));
        }
        if self.spp == 0 {
            return bad("--spp must be at least 1".into());
        }
        if self.sampling == Sampling::Corners && self.spp != 1 {
            return bad("--sampling corners traces exactly the pixel corners: --spp must be 1".into());
        }
        if self.max_depth == 0 {
            return bad("--max-depth must be at least 1 (the eye ray)".into());
        }
        Ok(())
    }
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Invalid render options.
    #[error("{0}")]
    Options(String),
    /// The scene breaks an invariant of the scene model.
    #[error("invalid scene: {0}")]
    Scene(String),
    /// The direction-cube tables (`--accel cube`) could not be built.
    #[error(transparent)]
    Tables(#[from] crate::coherence::BuildError),
}

/// A rendered image and its statistics.
pub struct Rendered {
    pub image: Image,
    pub stats: Stats,
}

/// The settings block of the statistics, shared by both backends.
pub fn settings(opts: &RenderOptions, backend: &str, accel: &str) -> stats::Settings {
    stats::Settings {
        backend: backend.into(),
        accel: accel.into(),
        size: [opts.width, opts.height],
        spp: opts.spp,
        sampling: match opts.sampling {
            Sampling::Corners => "corners".into(),
            Sampling::Center if opts.spp > 1 => "jitter".into(),
            Sampling::Center => "center".into(),
        },
        seed: opts.seed,
        max_depth: opts.max_depth,
    }
}

/// The effects a render with `max_depth` simulates.
pub fn simulated_effects(scene: &Scene, max_depth: u32) -> Vec<&'static str> {
    let mut e = scene.effects();
    if max_depth < 2 {
        e.reflection = false;
        e.refraction = false;
    }
    e.names()
}

fn prepare(scene: &Scene, opts: &RenderOptions) -> Result<(), RenderError> {
    opts.validate()?;
    scene.validate().map_err(RenderError::Scene)
}

fn to_pixel(c: DVec3) -> [f32; 4] {
    [c.x as f32, c.y as f32, c.z as f32, 1.0]
}

/// Renders `scene` to linear radiance. `progress` advances once per traced row.
pub fn render(scene: &Scene, opts: &RenderOptions, progress: &ProgressBar) -> Result<Rendered, RenderError> {
    prepare(scene, opts)?;
    let (w, h) = (opts.width, opts.height);
    let start = Instant::now();
    let accel = accel::build(scene, opts.accel, w, h)?;
    let preprocess_s = start.elapsed().as_secs_f64();
    let tracer = Tracer { scene, accel: accel.as_ref(), max_depth: opts.max_depth };
    let cam = &scene.camera;
    let eye_ray = |x: f64, y: f64| {
        let (o, d) = cam.ray(x, y, w, h);
        Ray::new(o, d)
    };

    let start = Instant::now();
    let mut image = Image::new(w, h, false);
    let mut counters = Counters::default();
    match opts.sampling {
        Sampling::Corners => {
            progress.set_length(h as u64 + 1);
            // Radiance at the (W+1)×(H+1) corners, one row of corners per task.
            let rows: Vec<(Vec<DVec3>, Counters)> = (0..=h)
                .into_par_iter()
                .map(|j| {
                    let mut c = Counters::default();
                    let row = (0..=w).map(|i| tracer.eye(&eye_ray(i as f64, j as f64), &mut c)).collect();
                    progress.inc(1);
                    (row, c)
                })
                .collect();
            for (_, c) in &rows {
                counters += *c;
            }
            for j in 0..h as usize {
                for i in 0..w as usize {
                    let (top, bottom) = (&rows[j].0, &rows[j + 1].0);
                    let mean = (top[i] + top[i + 1] + bottom[i] + bottom[i + 1]) * 0.25;
                    image.pixels[j * w as usize + i] = to_pixel(mean);
                }
            }
        }
        Sampling::Center => {
            progress.set_length(h as u64);
            let spp = opts.spp;
            let rows: Vec<(Vec<[f32; 4]>, Counters)> = (0..h)
                .into_par_iter()
                .map(|j| {
                    let mut c = Counters::default();
                    let row = (0..w)
                        .map(|i| {
                            let mut sum = DVec3::ZERO;
                            for s in 0..spp {
                                let (x, y) = sampling::sample_position(i, j, w, s, spp, opts.seed);
                                sum += tracer.eye(&eye_ray(x, y), &mut c);
                            }
                            to_pixel(sum / spp as f64)
                        })
                        .collect();
                    progress.inc(1);
                    (row, c)
                })
                .collect();
            for (j, (row, c)) in rows.into_iter().enumerate() {
                counters += c;
                image.pixels[j * w as usize..(j + 1) * w as usize].copy_from_slice(&row);
            }
        }
    }
    let trace_s = start.elapsed().as_secs_f64();
    let stats = Stats::new(
        settings(opts, "cpu", accel.name()),
        simulated_effects(scene, opts.max_depth),
        &counters,
        stats::Times { preprocess_s, trace_s, ..Default::default() },
    );
    Ok(Rendered { image, stats })
}

/// Renders an auxiliary output from the eye ray through each pixel centre (whatever the
/// sampling options say); see [`Aov`] for the values. Only eye rays are traced and counted.
pub fn render_aov(
    scene: &Scene,
    opts: &RenderOptions,
    aov: Aov,
    progress: &ProgressBar,
) -> Result<Rendered, RenderError> {
    prepare(scene, opts)?;
    let (w, h) = (opts.width, opts.height);
    let start = Instant::now();
    let accel = accel::build(scene, opts.accel, w, h)?;
    let preprocess_s = start.elapsed().as_secs_f64();
    let tracer = Tracer { scene, accel: accel.as_ref(), max_depth: 1 };
    let start = Instant::now();
    progress.set_length(h as u64);
    let rows: Vec<(Vec<[f32; 4]>, Counters)> = (0..h)
        .into_par_iter()
        .map(|j| {
            let mut c = Counters::default();
            let row = (0..w)
                .map(|i| {
                    let (o, d) = scene.camera.ray(i as f64 + 0.5, j as f64 + 0.5, w, h);
                    match tracer.first_hit(&Ray::new(o, d), &mut c) {
                        None => match aov {
                            Aov::Id => [-1.0, -1.0, -1.0, 0.0],
                            Aov::Depth | Aov::Normal => [0.0; 4],
                        },
                        Some(f) => match aov {
                            Aov::Depth => [f.t as f32, f.t as f32, f.t as f32, 1.0],
                            Aov::Normal => [f.normal.x as f32, f.normal.y as f32, f.normal.z as f32, 1.0],
                            Aov::Id => [f.prim as f32, f.prim as f32, f.prim as f32, 1.0],
                        },
                    }
                })
                .collect();
            progress.inc(1);
            (row, c)
        })
        .collect();
    let mut image = Image::new(w, h, true);
    let mut counters = Counters::default();
    for (j, (row, c)) in rows.into_iter().enumerate() {
        counters += c;
        image.pixels[j * w as usize..(j + 1) * w as usize].copy_from_slice(&row);
    }
    let trace_s = start.elapsed().as_secs_f64();
    let mut set = settings(opts, "cpu", accel.name());
    set.sampling = "center".into();
    set.spp = 1;
    set.max_depth = 1;
    let stats =
        Stats::new(set, Vec::new(), &counters, stats::Times { preprocess_s, trace_s, ..Default::default() });
    Ok(Rendered { image, stats })
}
