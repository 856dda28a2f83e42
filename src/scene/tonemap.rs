//! How rendered radiance becomes what a display shows: the tone mapping (`--tonemap`:
//! none, Khronos PBR Neutral, ACES filmic; twin of `shaders/shared/tonemap.wgsl`) and the
//! transfer that encodes the result in 8 bits (`--transfer`). The scene carries its
//! defaults (glTF: sRGB and PBR Neutral; NFF: display values as they are); the PNG writer
//! and the preview apply them (`output::display_rgb8`, `display.wgsl`).

use serde::Serialize;

/// How rendered values become the 8-bit values of a PNG (or a window), after clamping to
/// [0, 1].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transfer {
    /// The values are linear radiance: encode them with the sRGB transfer function (glTF).
    #[default]
    Srgb,
    /// The values are already display values, as the 1987 renderers of the SPD wrote the
    /// shaded colour straight to the frame buffer: store them as they are (NFF).
    Display,
}

/// How radiance beyond what a display shows becomes display values (`--tonemap`), before the
/// transfer encodes them. glTF viewers show glTF scenes through Khronos PBR Neutral.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tonemap {
    /// The values as they are, clamped to [0, 1].
    #[default]
    None,
    /// Khronos PBR Neutral: colours below 0.76 unchanged (but for a small offset of dark
    /// ones), brighter ones compressed towards white with little hue shift.
    PbrNeutral,
    /// ACES filmic, Hill's fit of the RRT and ODT (as the glTF Sample Viewer's "ACES").
    Aces,
}

impl Tonemap {
    /// The name `--tonemap` and the JSON use.
    pub fn name(self) -> &'static str {
        match self {
            Tonemap::None => "none",
            Tonemap::PbrNeutral => "pbr-neutral",
            Tonemap::Aces => "aces",
        }
    }

    /// What a scene shows through by default: PBR Neutral where its values are linear
    /// radiance (glTF), none where they are display values (NFF).
    pub fn default_for(transfer: Transfer) -> Tonemap {
        match transfer {
            Transfer::Srgb => Tonemap::PbrNeutral,
            Transfer::Display => Tonemap::None,
        }
    }

    /// Maps linear RGB (already scaled by the exposure) to [0, 1] (WGSL twin `tonemap` in
    /// `shaders/display.wgsl`).
    pub fn apply(self, c: [f32; 3]) -> [f32; 3] {
        let c = c.map(|v| if v.is_nan() { 0.0 } else { v.max(0.0) });
        let out = match self {
            Tonemap::None => c,
            Tonemap::PbrNeutral => pbr_neutral(c),
            Tonemap::Aces => aces(c),
        };
        out.map(|v| v.clamp(0.0, 1.0))
    }
}

/// Khronos PBR Neutral (KhronosGroup/ToneMapping, "PBR Neutral"), f32 as the WGSL twin.
fn pbr_neutral(c: [f32; 3]) -> [f32; 3] {
    const START: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let x = c[0].min(c[1]).min(c[2]);
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    let c = c.map(|v| v - offset);
    let peak = c[0].max(c[1]).max(c[2]);
    if peak < START {
        return c;
    }
    let d = 1.0 - START;
    let new_peak = 1.0 - d * d / (peak + d - START);
    let c = c.map(|v| v * (new_peak / peak));
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.map(|v| v * (1.0 - g) + new_peak * g)
}

/// ACES filmic: sRGB to the RRT's space, Hill's fit of the RRT and ODT, back to sRGB.
fn aces(c: [f32; 3]) -> [f32; 3] {
    const INPUT: [[f32; 3]; 3] =
        [[0.59719, 0.35458, 0.04823], [0.07600, 0.90834, 0.01566], [0.02840, 0.13383, 0.83777]];
    const OUTPUT: [[f32; 3]; 3] =
        [[1.60475, -0.53108, -0.07367], [-0.10208, 1.10813, -0.00605], [-0.00327, -0.07276, 1.07602]];
    let mul = |m: &[[f32; 3]; 3], v: [f32; 3]| m.map(|r| r[0] * v[0] + r[1] * v[1] + r[2] * v[2]);
    let fit = |v: f32| (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.432951) + 0.238081);
    mul(&OUTPUT, mul(&INPUT, c).map(fit))
}

impl Transfer {
    /// The name `--transfer` and the JSON use.
    pub fn name(self) -> &'static str {
        match self {
            Transfer::Srgb => "srgb",
            Transfer::Display => "display",
        }
    }
}
