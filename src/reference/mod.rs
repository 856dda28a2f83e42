//! The CPU reference renderer: Whitted ray tracing of a [`Scene`] in f64, independent of
//! the coherence tables. It is the yardstick the GPU renderer is judged against.
//!
//! - [`geometry`]: rays, exact-as-practical primitive intersection, robust spawn offsets;
//! - [`accel`]: the queries every accelerator answers ([`accel::Intersector`]), each told the
//!   ray's origin entity, and the shared nearest-hit rule;
//! - [`brute`] and [`bvh`]: brute force, and a BVH built by the `obvhs` crate;
//! - [`tables`]: `--accel cube`, the reference's own intersection tests in the order and
//!   number the direction-cube tables of [`crate::coherence`] choose (the only file here
//!   that knows the tables);
//! - [`shade`]: the Whitted shading model and the ray tree;
//! - [`texture`]: texture sampling.
//!
//! [`render`] produces a linear radiance image and [`render_aov`] an auxiliary image, both
//! with [`Stats`] counted per the SPD procedure. Rows are traced in parallel (rayon);
//! the result does not depend on the number of threads.

use std::time::Instant;

use glam::DVec3;
use indicatif::ProgressBar;
use rayon::prelude::*;

use crate::error::Result;
use crate::job::{simulated_effects, Accel, RenderOptions, Rendered};
use crate::output::{Aov, Image};
use crate::sampling::{self, Sampling};
use crate::scene::Scene;
use crate::stats::{self, Counters, Stats};

pub mod accel;
pub mod brute;
pub mod bvh;
pub mod geometry;
pub mod shade;
pub mod tables;
pub mod texture;

use accel::{Intersector, AUTO_BRUTE_MAX};
use brute::Brute;
use bvh::BvhAccel;
use geometry::Ray;
use shade::Tracer;
use tables::TableAccel;

/// Builds the accelerator `kind` asks for; the candidate tables cover primary rays of a
/// `width`×`height` image.
pub fn build_accel<'a>(
    scene: &'a Scene,
    kind: Accel,
    width: u32,
    height: u32,
) -> Result<Box<dyn Intersector + 'a>> {
    Ok(match kind {
        Accel::Auto if scene.primitives.len() <= AUTO_BRUTE_MAX => Box::new(Brute::new(scene)),
        Accel::Brute => Box::new(Brute::new(scene)),
        Accel::Auto | Accel::Bvh => Box::new(BvhAccel::new(scene)),
        Accel::Cube => Box::new(TableAccel::new(scene, width, height)?),
        Accel::RayQuery => {
            return Err(crate::error::Error::Options(
                "--accel rayquery is the GPU's ray tracing; the CPU reference has none (use --accel bvh, or \
                 --backend gpu)"
                    .into(),
            ))
        }
    })
}

fn prepare(scene: &Scene, opts: &RenderOptions) -> Result<()> {
    opts.validate()?;
    scene.validate()
}

/// Whether a stop was asked for: the pixel loops then skip their work, and the render
/// returns `Error::Interrupted`.
fn stopped() -> bool {
    crate::interrupt::requested().is_some()
}

fn to_pixel(c: DVec3) -> [f32; 4] {
    [c.x as f32, c.y as f32, c.z as f32, 1.0]
}

/// Renders `scene` to linear radiance. `progress` advances once per traced row.
pub fn render(scene: &Scene, opts: &RenderOptions, progress: &ProgressBar) -> Result<Rendered> {
    prepare(scene, opts)?;
    let (w, h) = (opts.width, opts.height);
    let start = Instant::now();
    let accel = build_accel(scene, opts.accel, w, h)?;
    let preprocess_s = start.elapsed().as_secs_f64();
    let tracer = Tracer { scene, accel: accel.as_ref(), max_depth: opts.max_depth };
    let cam = &scene.camera;
    let eye_ray = |x: f64, y: f64| {
        let (o, d) = cam.ray(x, y, w, h);
        Ray::new(o, d)
    };

    let start = Instant::now();
    let win = opts.region();
    let grid = opts.grid_region();
    let (x0, y0) = grid.origin;
    let (gw, gh) = grid.size;
    let (ww, wh) = (win.width() as usize, win.height() as usize);
    let mut image = Image::new(win.width(), win.height(), false);
    opts.show(scene, &mut image);
    let mut counters = Counters::default();
    // One task per row of the window's grid points; a point the window does not own (a
    // corner on its far edges) is traced for its pixels but counted by its owner.
    progress.set_length(gh as u64);
    let rows: Vec<(Vec<DVec3>, Counters)> = (0..gh)
        .into_par_iter()
        .map(|lj| {
            let mut c = Counters::default();
            let mut elsewhere = Counters::default();
            let row = (0..gw)
                .map(|li| {
                    let counted = if grid.owns(li, lj) { &mut c } else { &mut elsewhere };
                    let (i, j) = (x0 + li, y0 + lj);
                    match opts.sampling {
                        Sampling::Corners if stopped() => DVec3::ZERO,
                        Sampling::Corners => tracer.eye(&eye_ray(i as f64, j as f64), counted),
                        Sampling::Pixels => {
                            let mut sum = DVec3::ZERO;
                            for s in 0..opts.spp {
                                if stopped() {
                                    break;
                                }
                                let (x, y) = sampling::sample_position(i, j, w, s, opts.spp, opts.seed);
                                sum += tracer.eye(&eye_ray(x, y), counted);
                            }
                            sum / opts.spp as f64
                        }
                    }
                })
                .collect();
            progress.inc(1);
            (row, c)
        })
        .collect();
    for (_, c) in &rows {
        counters += *c;
    }
    for j in 0..wh {
        for i in 0..ww {
            let v = match opts.sampling {
                // Each pixel the mean of its four corners.
                Sampling::Corners => {
                    let (top, bottom) = (&rows[j].0, &rows[j + 1].0);
                    (top[i] + top[i + 1] + bottom[i] + bottom[i + 1]) * 0.25
                }
                Sampling::Pixels => rows[j].0[i],
            };
            image.pixels[j * ww + i] = to_pixel(v);
        }
    }
    crate::interrupt::check()?;
    let trace_s = start.elapsed().as_secs_f64();
    let stats = Stats::new(
        opts.settings(scene, "cpu", accel.name()),
        simulated_effects(scene, opts.max_depth),
        &counters,
        stats::Times { preprocess_s, trace_s, ..Default::default() },
    );
    Ok(Rendered { image, stats })
}

/// Renders an auxiliary output from the eye ray through each pixel centre (whatever the
/// sampling options say); see [`Aov`] for the values. Only eye rays are traced and counted.
pub fn render_aov(scene: &Scene, opts: &RenderOptions, aov: Aov, progress: &ProgressBar) -> Result<Rendered> {
    prepare(scene, opts)?;
    let (w, h) = (opts.width, opts.height);
    let start = Instant::now();
    let accel = build_accel(scene, opts.accel, w, h)?;
    let preprocess_s = start.elapsed().as_secs_f64();
    let tracer = Tracer { scene, accel: accel.as_ref(), max_depth: 1 };
    let start = Instant::now();
    let win = opts.region();
    progress.set_length(win.height() as u64);
    let rows: Vec<(Vec<[f32; 4]>, Counters)> = (win.y0..win.y1)
        .into_par_iter()
        .map(|j| {
            let mut c = Counters::default();
            let row = (win.x0..win.x1)
                .map(|i| {
                    let (o, d) = scene.camera.ray(i as f64 + 0.5, j as f64 + 0.5, w, h);
                    if stopped() {
                        return [0.0; 4];
                    }
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
    let mut image = Image::new(win.width(), win.height(), true);
    let mut counters = Counters::default();
    let ww = win.width() as usize;
    for (j, (row, c)) in rows.into_iter().enumerate() {
        counters += c;
        image.pixels[j * ww..(j + 1) * ww].copy_from_slice(&row);
    }
    crate::interrupt::check()?;
    let trace_s = start.elapsed().as_secs_f64();
    let set = opts.aov_settings(scene, "cpu", accel.name());
    let stats =
        Stats::new(set, Vec::new(), &counters, stats::Times { preprocess_s, trace_s, ..Default::default() });
    Ok(Rendered { image, stats })
}
