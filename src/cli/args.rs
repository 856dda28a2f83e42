//! The command line's own spellings of the library's choices: one `clap::ValueEnum` per
//! choice an option takes, each mapped onto the library's type, so that the library does not
//! depend on the command line's parser. A value's doc comment is its `--help` text.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use glam::DVec3;

use cuberay::accuracy::Parameter;
use cuberay::job::{Accel, KernelForm, Precision, SurfaceWalk};
use cuberay::load::{EnvChoice, Setup};
use cuberay::output::Aov;
use cuberay::sampling::Sampling;
use cuberay::scene::environment::DEFAULT_LIGHTS;
use cuberay::scene::{Tonemap, Transfer, ViewOverride};

/// `--accel`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AccelArg {
    /// GPU: the candidate table of each origin (eye, light) whose build pays for this render, the BVH for the rest; CPU: brute force for tiny scenes, a BVH above.
    Auto,
    /// Test every primitive for every ray.
    Brute,
    /// Bounding volume hierarchy.
    Bvh,
    /// The direction-cube candidate tables of the coherence method (Ohta and Maekawa) for eye
    /// and light rays; for rays leaving surfaces the BVH or ray queries (--surface-walk).
    Cube,
    /// GPU only: the platform's ray tracing (ray queries) for every ray. Needs a GPU with
    /// ray tracing, or Mesa >= 24.1's lavapipe.
    Rayquery,
}

impl From<AccelArg> for Accel {
    fn from(a: AccelArg) -> Accel {
        match a {
            AccelArg::Auto => Accel::Auto,
            AccelArg::Brute => Accel::Brute,
            AccelArg::Bvh => Accel::Bvh,
            AccelArg::Cube => Accel::Cube,
            AccelArg::Rayquery => Accel::RayQuery,
        }
    }
}

/// `--surface-walk`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SurfaceWalkArg {
    /// Ray queries where the adapter has them, except lavapipe (whose software ones
    /// measured slower than the BVH), else the BVH.
    Auto,
    /// The BVH, walked in the kernels' own code.
    Bvh,
    /// The platform's ray tracing (ray queries): a GPU with ray tracing, or Mesa >= 24.1's
    /// lavapipe.
    Rayquery,
}

impl From<SurfaceWalkArg> for SurfaceWalk {
    fn from(a: SurfaceWalkArg) -> SurfaceWalk {
        match a {
            SurfaceWalkArg::Auto => SurfaceWalk::Auto,
            SurfaceWalkArg::Bvh => SurfaceWalk::Bvh,
            SurfaceWalkArg::Rayquery => SurfaceWalk::RayQuery,
        }
    }
}

/// `--kernel-form`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum KernelFormArg {
    /// The form measured faster on the adapter: the tree on drivers without a loop limit,
    /// where it won; the wavefront on Mesa's lavapipe before 24.
    Auto,
    /// Breadth first over queues of rays (a kernel per step).
    Wavefront,
    /// Depth first, each invocation tracing its point's whole ray tree (one kernel).
    Tree,
}

impl From<KernelFormArg> for KernelForm {
    fn from(a: KernelFormArg) -> KernelForm {
        match a {
            KernelFormArg::Auto => KernelForm::Auto,
            KernelFormArg::Wavefront => KernelForm::Wavefront,
            KernelFormArg::Tree => KernelForm::Tree,
        }
    }
}

/// `--precision`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PrecisionArg {
    /// f64 where f32 cannot resolve the scene at this image size, else f32.
    Auto,
    F32,
    F64,
}

impl From<PrecisionArg> for Precision {
    fn from(p: PrecisionArg) -> Precision {
        match p {
            PrecisionArg::Auto => Precision::Auto,
            PrecisionArg::F32 => Precision::F32,
            PrecisionArg::F64 => Precision::F64,
        }
    }
}

/// `--sampling`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SamplingArg {
    /// Pixel centres, or stratified jitter with `--spp N` (N > 1).
    #[value(alias = "pixels")]
    Center,
    /// SPD procedure: rays at the (W+1)×(H+1) pixel corners, four averaged per pixel.
    Corners,
}

impl From<SamplingArg> for Sampling {
    fn from(s: SamplingArg) -> Sampling {
        match s {
            SamplingArg::Center => Sampling::Pixels,
            SamplingArg::Corners => Sampling::Corners,
        }
    }
}

/// `--aov`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AovArg {
    /// Distance from the eye ray's origin to the first hit, in scene units, in R, G and B.
    /// Miss: 0 (no hit is at distance 0).
    Depth,
    /// World-space unit shading normal at the first hit, turned to face the eye ray
    /// (x, y, z in R, G, B). Miss: (0, 0, 0).
    Normal,
    /// Object id (index of the primitive in the scene) of the first hit, in R, G and B
    /// (exact up to 2²⁴). Miss: −1.
    Id,
}

impl From<AovArg> for Aov {
    fn from(a: AovArg) -> Aov {
        match a {
            AovArg::Depth => Aov::Depth,
            AovArg::Normal => Aov::Normal,
            AovArg::Id => Aov::Id,
        }
    }
}

/// `--transfer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TransferArg {
    /// The values are linear radiance: encode them with the sRGB transfer function (glTF).
    Srgb,
    /// The values are already display values, as the 1987 renderers of the SPD wrote the
    /// shaded colour straight to the frame buffer: store them as they are (NFF).
    Display,
}

impl From<TransferArg> for Transfer {
    fn from(t: TransferArg) -> Transfer {
        match t {
            TransferArg::Srgb => Transfer::Srgb,
            TransferArg::Display => Transfer::Display,
        }
    }
}

/// `--tonemap`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TonemapArg {
    /// The values as they are, clamped to [0, 1].
    None,
    /// Khronos PBR Neutral: colours below 0.76 kept, brighter ones compressed towards white
    /// (the glTF viewers' reference).
    PbrNeutral,
    /// ACES filmic (Hill's fit), as the glTF Sample Viewer's "ACES".
    Aces,
}

impl From<TonemapArg> for Tonemap {
    fn from(t: TonemapArg) -> Tonemap {
        match t {
            TonemapArg::None => Tonemap::None,
            TonemapArg::PbrNeutral => Tonemap::PbrNeutral,
            TonemapArg::Aces => Tonemap::Aces,
        }
    }
}

/// A point or vector `X,Y,Z`.
fn vec3(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(x, y, z)),
        [_, _, _] => Err(format!("{s:?} is not three finite numbers")),
        _ => Err(format!("{s:?} is not X,Y,Z (three numbers)")),
    }
}

/// The camera instead of the file's, part by part, and the environment around the scene:
/// what the command line adds to a scene file.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// The eye, X,Y,Z in the scene's coordinates (default: the file's camera's).
    #[arg(long, value_name = "X,Y,Z", value_parser = vec3, allow_hyphen_values = true)]
    pub look_from: Option<DVec3>,
    /// The point at the centre of the image (default: the file's camera's; `cuberay info`
    /// prints the camera in these flags' terms).
    #[arg(long, value_name = "X,Y,Z", value_parser = vec3, allow_hyphen_values = true)]
    pub look_at: Option<DVec3>,
    /// The up direction (default: the scene's up, glTF +Y, NFF the viewpoint's `up`, where
    /// --look-from or --look-at move the camera; else the camera's own).
    #[arg(long, value_name = "X,Y,Z", value_parser = vec3, allow_hyphen_values = true)]
    pub up: Option<DVec3>,
    /// The vertical field of view in degrees, between the image's top and bottom edges
    /// (makes the camera a perspective one).
    #[arg(long, value_name = "DEG")]
    pub fov: Option<f64>,
    /// The environment: an equirectangular .hdr or .exr map of the radiance around the scene
    /// (what rays leaving the scene see, and the light of --env-lights directional lights);
    /// `studio` for the built-in studio; `none` for the file's background and lights (a
    /// headlight where it has none). Default: the studio for a glTF scene without lights,
    /// else none.
    #[arg(long, value_name = "FILE|studio|none")]
    pub env: Option<String>,
    /// Turns the environment by DEG degrees about the up axis (counter-clockwise seen from
    /// above).
    #[arg(long, value_name = "DEG", default_value_t = 0.0, allow_hyphen_values = true)]
    pub env_rotate: f64,
    /// Multiplies the environment's radiance (and its lights').
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub env_intensity: f64,
    /// How many directional lights stand in for the environment (median cut of its power;
    /// 0: none, the map is only seen).
    #[arg(long, value_name = "K", default_value_t = DEFAULT_LIGHTS)]
    pub env_lights: u32,
}

impl SceneArgs {
    /// The library's setup of a loaded scene.
    pub fn setup(&self) -> Setup {
        let env = match self.env.as_deref() {
            None => EnvChoice::Auto,
            Some("none") => EnvChoice::None,
            Some("studio") => EnvChoice::Studio,
            Some(path) => EnvChoice::File(PathBuf::from(path)),
        };
        Setup {
            view: ViewOverride { from: self.look_from, at: self.look_at, up: self.up, fov_degrees: self.fov },
            env,
            env_rotate: self.env_rotate,
            env_intensity: self.env_intensity,
            env_lights: self.env_lights,
        }
    }
}

/// How a PNG (and the preview window) shows the radiance.
#[derive(Args, Debug, Clone)]
pub struct DisplayArgs {
    /// How a PNG (and the preview window) encodes the values: srgb (linear radiance,
    /// sRGB-encoded) or display (the values as they are). Default: display for NFF, whose
    /// colours are display values, srgb for glTF.
    #[arg(long, value_enum)]
    pub transfer: Option<TransferArg>,
    /// Multiplies the radiance a PNG (and the preview window) shows by 2^EV.
    #[arg(long, value_name = "EV", default_value_t = 0.0, allow_hyphen_values = true)]
    pub exposure: f64,
    /// How a PNG (and the preview window) brings radiance beyond 1 into range. Default:
    /// pbr-neutral for glTF, none for NFF. EXR and HDR files keep the radiance as rendered.
    #[arg(long, value_enum)]
    pub tonemap: Option<TonemapArg>,
}

/// `accuracy --params`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ParameterArg {
    /// Samples per pixel (stratified jitter).
    Spp,
    /// Maximum ray-tree depth.
    #[value(alias = "max_depth")]
    MaxDepth,
    /// The kernels' intersection arithmetic: f32, f64 where the adapter has it.
    Precision,
    /// The spawn offset: the scaled policy, fixed epsilons of several sizes.
    Offset,
    /// Cells per face edge of the eye's table: time and memory, never the image.
    #[value(alias = "table_resolution")]
    TableResolution,
    /// The accelerator: time only, never the image.
    Accel,
}

impl From<ParameterArg> for Parameter {
    fn from(p: ParameterArg) -> Parameter {
        match p {
            ParameterArg::Spp => Parameter::Spp,
            ParameterArg::MaxDepth => Parameter::MaxDepth,
            ParameterArg::Precision => Parameter::Precision,
            ParameterArg::Offset => Parameter::Offset,
            ParameterArg::TableResolution => Parameter::TableResolution,
            ParameterArg::Accel => Parameter::Accel,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every spelling maps onto a distinct value of the library's type, and each of the
    /// library's values has a spelling.
    #[test]
    fn every_value_of_each_library_choice_has_one_spelling() {
        fn distinct<A: ValueEnum, L: PartialEq + std::fmt::Debug>(to: impl Fn(&A) -> L, all: usize) {
            let mapped: Vec<L> = A::value_variants().iter().map(to).collect();
            for (i, a) in mapped.iter().enumerate() {
                assert!(!mapped[..i].contains(a), "{a:?} twice");
            }
            assert_eq!(mapped.len(), all);
        }
        distinct(|a: &AccelArg| Accel::from(*a), 5);
        distinct(|a: &SurfaceWalkArg| SurfaceWalk::from(*a), 3);
        distinct(|a: &KernelFormArg| KernelForm::from(*a), 3);
        distinct(|a: &PrecisionArg| Precision::from(*a), 3);
        distinct(|a: &SamplingArg| Sampling::from(*a), 2);
        distinct(|a: &AovArg| Aov::from(*a), 3);
        distinct(|a: &TransferArg| Transfer::from(*a), 2);
        distinct(|a: &TonemapArg| Tonemap::from(*a), 3);
        distinct(|a: &ParameterArg| Parameter::from(*a), Parameter::ALL.len());
    }
}
