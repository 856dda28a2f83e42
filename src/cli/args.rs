//! The command line's own spellings of the library's choices: one `clap::ValueEnum` per
//! choice an option takes, each mapped onto the library's type, so that the library does not
//! depend on the command line's parser. A value's doc comment is its `--help` text.

use clap::ValueEnum;

use cuberay::accuracy::Parameter;
use cuberay::job::{AccelKind, Precision};
use cuberay::output::Aov;
use cuberay::sampling::Sampling;
use cuberay::scene::Transfer;

/// `--accel`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AccelArg {
    /// GPU: the candidate tables; CPU: brute force for tiny scenes, a BVH above.
    Auto,
    /// Test every primitive for every ray.
    Brute,
    /// Bounding volume hierarchy.
    Bvh,
    /// The direction-cube candidate tables of the coherence method (Ohta and Maekawa) for eye
    /// and light rays; the BVH for rays leaving surfaces.
    Cube,
}

impl From<AccelArg> for AccelKind {
    fn from(a: AccelArg) -> AccelKind {
        match a {
            AccelArg::Auto => AccelKind::Auto,
            AccelArg::Brute => AccelKind::Brute,
            AccelArg::Bvh => AccelKind::Bvh,
            AccelArg::Cube => AccelKind::Cube,
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
        distinct(|a: &AccelArg| AccelKind::from(*a), 4);
        distinct(|a: &PrecisionArg| Precision::from(*a), 3);
        distinct(|a: &SamplingArg| Sampling::from(*a), 2);
        distinct(|a: &AovArg| Aov::from(*a), 3);
        distinct(|a: &TransferArg| Transfer::from(*a), 2);
        distinct(|a: &ParameterArg| Parameter::from(*a), Parameter::ALL.len());
    }
}
