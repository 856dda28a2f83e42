//! The render job both backends take and the result both return: what to render
//! ([`RenderOptions`]: image size, sampling, depth, accelerator), the statistics' settings
//! block, and the rendered image with its statistics ([`Rendered`]).
//!
//! It sits beside the renderers, not inside either: the GPU renderer, the preview and the
//! CPU reference all read it, and none of them imports another.

use glam::DVec3;

use crate::arith::precision::F32Need;
use crate::arith::spawn::SpawnPolicy;
use crate::cost::AutoAccel;
use crate::error::{Error, Result};
use crate::output::Image;
pub use crate::region::Region;
use crate::sampling::Sampling;
use crate::scene::{OriginKey, Scene, Tonemap, Transfer};
use crate::stats::{self, Stats};

/// Which acceleration structure finds a ray's candidates (`--accel`): on the GPU the
/// kernels' variant holds one ([`crate::gpu::shaders::Variant::accel`]), on the CPU the
/// reference walks one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Accel {
    /// GPU: the direction-cube tables; CPU: brute force for tiny scenes, a BVH above.
    Auto,
    /// Test every primitive for every ray.
    Brute,
    /// Bounding volume hierarchy.
    Bvh,
    /// The direction-cube candidate tables of the coherence method (Ohta and Maekawa) for eye
    /// and light rays; for rays leaving surfaces the BVH or the platform's ray queries
    /// ([`SurfaceWalk`]).
    Cube,
    /// GPU only: the platform's ray queries for every ray (the driver's structure over a box
    /// per primitive culls, the kernels test its candidates).
    RayQuery,
}

impl Accel {
    /// The accelerators a GPU kernel traces with (every one but `auto`).
    pub const GPU: [Accel; 4] = [Accel::Cube, Accel::Bvh, Accel::Brute, Accel::RayQuery];

    /// The `--accel` name.
    pub fn name(self) -> &'static str {
        match self {
            Accel::Auto => "auto",
            Accel::Cube => "cube",
            Accel::Bvh => "bvh",
            Accel::Brute => "brute",
            Accel::RayQuery => "rayquery",
        }
    }
}

/// What the GPU's rays leaving surfaces take under `--accel cube` and `auto`
/// (`--surface-walk`): they have no single origin, so no table serves them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SurfaceWalk {
    /// The platform's ray queries where the adapter has them, except lavapipe, whose
    /// software ones measured slower than the BVH (`gpu::choose::resolve`); else the
    /// BVH.
    #[default]
    Auto,
    /// The BVH walked in the kernels' own code.
    Bvh,
    /// The platform's ray queries (an adapter without them refuses the render).
    RayQuery,
}

impl SurfaceWalk {
    pub fn name(self) -> &'static str {
        match self {
            SurfaceWalk::Auto => "auto",
            SurfaceWalk::Bvh => "bvh",
            SurfaceWalk::RayQuery => "rayquery",
        }
    }
}

/// How the GPU kernels trace a tile's ray trees (`--kernel-form`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum KernelForm {
    /// The faster form on the adapter, as measured (`gpu::choose::resolve`).
    #[default]
    Auto,
    /// Breadth first, a kernel per step (trace, shade, shadow) over queues of rays in
    /// memory: the form of SIMT GPUs, and the one whose walks are cut into passes within
    /// lavapipe's loop limit.
    Wavefront,
    /// Depth first, one kernel per sample, each invocation tracing its point's whole ray
    /// tree with its pending rays on a private stack (the register form): no queue traffic,
    /// but unbounded loops, so only on drivers without a loop limit.
    Tree,
}

impl KernelForm {
    pub fn name(self) -> &'static str {
        match self {
            KernelForm::Auto => "auto",
            KernelForm::Wavefront => "wavefront",
            KernelForm::Tree => "tree",
        }
    }
}

/// The arithmetic of the GPU kernels' intersection tests and hit points (`--precision`):
/// f32, f64 where the adapter has `SHADER_F64` (a kernel variant; `cuberay accuracy`
/// measures its cost), or, by default, whichever the scene calls for
/// ([`crate::arith::precision`]). The CPU reference always computes in f64.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// f64 where f32 cannot resolve the scene as the image shows it, else f32
    /// (`gpu::choose::resolve`).
    #[default]
    Auto,
    F32,
    F64,
}

impl Precision {
    pub fn name(self) -> &'static str {
        match self {
            Precision::Auto => "auto",
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

/// What to render and how.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel with [`Sampling::Pixels`] (1: the pixel centre; N > 1:
    /// stratified jitter). Must be 1 with [`Sampling::Corners`].
    pub spp: u32,
    pub seed: u64,
    pub sampling: Sampling,
    /// Maximum ray-tree depth, the eye ray being depth 1 (SPD: 5).
    pub max_depth: u32,
    pub accel: Accel,
    /// What rays leaving surfaces take on the GPU under `cube` and `auto` ([`SurfaceWalk`]):
    /// the GPU renderer resolves [`SurfaceWalk::Auto`] for its adapter; unresolved, it is the
    /// BVH.
    pub surface: SurfaceWalk,
    /// How the GPU kernels trace the ray trees ([`KernelForm`]): the GPU renderer resolves
    /// [`KernelForm::Auto`] for its adapter; unresolved, it is the wavefront.
    pub form: KernelForm,
    /// How far the GPU kernels move spawned rays off their surfaces (the candidate tables
    /// are built for it). The CPU reference keeps its own, much smaller f64 offset.
    pub spawn: SpawnPolicy,
    /// The GPU kernels' intersection arithmetic ([`Precision`]).
    pub precision: Precision,
    /// Why [`Precision::Auto`] chose what `precision` now says: set by
    /// `gpu::choose::resolve`, `None` where the precision was given.
    pub auto_precision: Option<F32Need>,
    /// What [`Accel::Auto`] weighed and chose (per origin): set by `gpu::choose::resolve`,
    /// `None` where the accelerator was given.
    pub auto_accel: Option<AutoAccel>,
    /// With `cube`, the origins left without a table, whose rays walk the BVH (`auto`'s
    /// choice; default none).
    pub untabled: Vec<OriginKey>,
    /// Cells per face edge of the eye's direction cube; `None`: about two pixels a cell.
    /// Changes the tables' time and memory, never the image.
    pub eye_cells: Option<u32>,
    /// How a PNG encodes the values; `None`: the scene's ([`Scene::transfer`]).
    pub transfer: Option<Transfer>,
    /// `--exposure`: a PNG (and the preview) shows the radiance times 2^exposure.
    pub exposure: f64,
    /// `--tonemap`: how a PNG (and the preview) brings radiance beyond 1 into range; `None`:
    /// the scene's default ([`Tonemap::default_for`] its transfer).
    pub tonemap: Option<Tonemap>,
    /// The part of the image to render (`--tile`, `--crop`); `None`: all of it. The
    /// region changes which grid points are traced, never how: every pixel of it gets the
    /// samples, seeds and tables of the whole render.
    pub region: Option<Region>,
    /// Whether the GPU kernels count rays and tests for the statistics (default: yes). They
    /// run faster uncounted (see `Variant::counters`), and the counts of their
    /// [`crate::stats::Stats`] are then zero; the CPU reference always counts.
    pub count: bool,
}

/// The grid points the render of a region traces: `size` points from grid point `origin`,
/// of which those with local coordinates below `owned` are its own (counted in its
/// statistics). With corner sampling a region traces the corners on its right and bottom edges too, to
/// average its pixels, but owns them only at the image's edge: the neighbour owns the rest,
/// so the counts of the parts of an image add up to those of the whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridRegion {
    pub origin: (u32, u32),
    pub size: (u32, u32),
    pub owned: (u32, u32),
}

impl GridRegion {
    pub fn points(&self) -> u64 {
        self.size.0 as u64 * self.size.1 as u64
    }

    /// Whether local point (`i`, `j`) is counted.
    pub fn owns(&self, i: u32, j: u32) -> bool {
        i < self.owned.0 && j < self.owned.1
    }
}

impl RenderOptions {
    /// Pixel centres, one sample, depth 5, automatic acceleration.
    pub fn new(width: u32, height: u32) -> RenderOptions {
        RenderOptions {
            width,
            height,
            spp: 1,
            seed: 0,
            sampling: Sampling::Pixels,
            max_depth: 5,
            accel: Accel::Auto,
            surface: SurfaceWalk::Auto,
            form: KernelForm::Auto,
            spawn: SpawnPolicy::Scaled,
            precision: Precision::Auto,
            auto_precision: None,
            auto_accel: None,
            untabled: Vec::new(),
            eye_cells: None,
            transfer: None,
            exposure: 0.0,
            tonemap: None,
            region: None,
            count: true,
        }
    }

    /// Checks the options; the error says what is wrong in words.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Options(m));
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
        if let Some(n) = self.eye_cells {
            if !(1..=8192).contains(&n) {
                return bad(format!("the eye table's {n} cells per face edge are not within 1..=8192"));
            }
        }
        if let Some(w) = self.region {
            if w.x0 >= w.x1 || w.y0 >= w.y1 || w.x1 > self.width || w.y1 > self.height {
                return bad(format!(
                    "the region {w} (x0,y0,x1,y1) is not a non-empty part of the {}x{} image",
                    self.width, self.height
                ));
            }
        }
        Ok(())
    }

    /// The pixels this job renders: its region, or the whole image.
    pub fn region(&self) -> Region {
        self.region.unwrap_or(Region::full(self.width, self.height))
    }

    /// The grid of eye-ray points of the whole image: the pixels, or the (W+1)×(H+1) pixel
    /// corners.
    pub fn grid(&self) -> (u32, u32) {
        match self.sampling {
            Sampling::Corners => (self.width + 1, self.height + 1),
            Sampling::Pixels => (self.width, self.height),
        }
    }

    /// The grid points this job traces and owns ([`GridRegion`]).
    pub fn grid_region(&self) -> GridRegion {
        let w = self.region();
        let (ww, wh) = (w.width(), w.height());
        match self.sampling {
            Sampling::Corners => GridRegion {
                origin: (w.x0, w.y0),
                size: (ww + 1, wh + 1),
                owned: (ww + (w.x1 == self.width) as u32, wh + (w.y1 == self.height) as u32),
            },
            Sampling::Pixels => GridRegion { origin: (w.x0, w.y0), size: (ww, wh), owned: (ww, wh) },
        }
    }

    /// The transfer of this job's images for `scene`.
    pub fn transfer_for(&self, scene: &Scene) -> Transfer {
        self.transfer.unwrap_or(scene.transfer)
    }

    /// The tone mapping of `scene`'s PNG: the option's, else the scene's default.
    pub fn tonemap_for(&self, scene: &Scene) -> Tonemap {
        self.tonemap.unwrap_or(Tonemap::default_for(scene.transfer))
    }

    /// Gives a rendered image of `scene` the way a PNG shows it: transfer, tone mapping and
    /// exposure (both backends' images alike).
    pub fn show(&self, scene: &Scene, image: &mut Image) {
        image.transfer = self.transfer_for(scene);
        image.tonemap = self.tonemap_for(scene);
        image.exposure = crate::output::exposure_scale(self.exposure);
    }

    /// The settings block of the statistics of a render of `scene`.
    pub fn settings(&self, scene: &Scene, backend: &str, accel: &str) -> stats::Settings {
        stats::Settings {
            backend: backend.into(),
            accel: accel.into(),
            surface_walk: None,
            kernel_form: None,
            size: [self.width, self.height],
            spp: self.spp,
            sampling: match self.sampling {
                Sampling::Corners => "corners".into(),
                Sampling::Pixels if self.spp > 1 => "jitter".into(),
                Sampling::Pixels => "center".into(),
            },
            seed: self.seed,
            max_depth: self.max_depth,
            precision: if backend == "cpu" { "f64".into() } else { self.precision.name().into() },
            precision_auto: (backend != "cpu")
                .then(|| self.auto_precision.as_ref().map(|n| n.reason()))
                .flatten(),
            accel_auto: (backend != "cpu").then(|| self.auto_accel.as_ref().map(|a| a.reason())).flatten(),
            transfer: self.transfer_for(scene),
            tonemap: self.tonemap_for(scene),
            exposure: self.exposure,
            window: self.region.filter(|w| !w.is_full(self.width, self.height)),
        }
    }

    /// The settings block of an AOV pass: one eye ray through each pixel centre.
    pub fn aov_settings(&self, scene: &Scene, backend: &str, accel: &str) -> stats::Settings {
        let mut set = self.settings(scene, backend, accel);
        set.sampling = "center".into();
        set.spp = 1;
        set.max_depth = 1;
        set
    }
}

/// The image of a render of `scene` from its grid of eye-ray points (one summed RGB per
/// point of [`RenderOptions::grid_region`], as the kernels leave them): each pixel the mean
/// of its four corners with SPD sampling, else its sum over `samples` samples divided by
/// `samples` (in f64). The image is the region's size.
pub fn grid_image(opts: &RenderOptions, scene: &Scene, values: &[[f32; 4]], samples: u32) -> Image {
    let win = opts.region();
    let (w, h) = (win.width(), win.height());
    let gw = opts.grid_region().size.0;
    let corners = opts.sampling == Sampling::Corners;
    let at = |i: u32, j: u32| {
        let p = values[(j * gw + i) as usize];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    };
    let mut image = Image::new(w, h, false);
    opts.show(scene, &mut image);
    for j in 0..h {
        for i in 0..w {
            let v = if corners {
                (at(i, j) + at(i + 1, j) + at(i, j + 1) + at(i + 1, j + 1)) * 0.25
            } else {
                at(i, j) / samples as f64
            };
            image.pixels[(j * w + i) as usize] = [v.x as f32, v.y as f32, v.z as f32, 1.0];
        }
    }
    image
}

/// A rendered image and its statistics.
pub struct Rendered {
    pub image: Image,
    pub stats: Stats,
}

/// The effects a render of `scene` with `max_depth` simulates.
pub fn simulated_effects(scene: &Scene, max_depth: u32) -> Vec<&'static str> {
    let mut e = scene.effects();
    if max_depth < 2 {
        e.reflection = false;
        e.refraction = false;
    }
    e.names()
}
