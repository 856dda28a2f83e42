//! The environment around a scene (`--env`): an equirectangular map of the radiance that
//! reaches the scene from every direction, what a ray that leaves the scene sees, and the
//! directional lights that stand in for it in Whitted shading.
//!
//! **The map.** Texels are stored as shared-exponent RGB ([`rgbe_encode`], Radiance's RGBE,
//! the form of `.hdr` files: 8-bit mantissas and one exponent a texel, about 0.4 % of the
//! brightest channel), row 0 at the top. The map's frame is its `up` axis (the top row) and
//! its `front` (the centre column on the horizon); with `side = front × up`, a direction of
//! local coordinates (x along `front`, y along `up`, z along `side`) lies at
//! `u = 0.5 + atan2(z, x) / 2π` across the map (0 its left edge) and `v = acos(y) / π` down
//! it: the equirectangular convention of the Khronos glTF Sample Viewer (its `dirToUV`, with
//! the image's top row up). A glTF scene's up is +Y and front +X, so the centre column is +X
//! and u = 0.75 is +Z. Lookups are bilinear between texel centres, wrapping around in u and
//! clamped at the poles ([`Environment::radiance`]; WGSL twin `environment` in
//! `shaders/shared/environment.wgsl`).
//!
//! **The lights.** Whitted shading lights a surface by point and directional lights only,
//! so the map is split by median cut (Debevec 2005, "A median cut algorithm for light probe
//! sampling") into regions of equal luminous power, each a directional light from its
//! power-weighted mean direction ([`Environment::lights`]). Each light carries its region's
//! power `∫ L dω` over π: in cuberay's Whitted terms (a diffuse surface returns its colour
//! times `kd` times a light's radiance times the cosine, without the Lambertian 1/π), a
//! white diffuse surface under a uniform map of radiance L returns L, as it would under the
//! sky itself. The lights' powers sum to the map's whole integral.

use std::f64::consts::PI;

use glam::DVec3;

use super::light::{Light, LightKind, LightSource};
use crate::error::{Error, Result};

/// The widest map an environment accepts, in texels (a map of 16384×8192 is 512 MiB of
/// texels on the device, beyond any adapter's single binding).
pub const MAX_WIDTH: u32 = 16384;

/// The most directional lights `--env-lights` may ask for.
pub const MAX_LIGHTS: u32 = 1024;

/// The lights an environment gives by default (`--env-lights`).
pub const DEFAULT_LIGHTS: u32 = 16;

/// Encodes linear RGB (finite, non-negative) as shared-exponent RGB: the exponent byte `e`
/// makes the largest channel's mantissa 128..255 in `channel = mantissa · 2^(e − 136)`;
/// values too small for a mantissa of 1 (below 2⁻¹³⁵) encode as black, values beyond
/// 255·2¹¹⁹ saturate.
pub fn rgbe_encode(c: [f32; 3]) -> u32 {
    let m = c[0].max(c[1]).max(c[2]) as f64;
    if m.is_nan() || m <= 0.0 {
        return 0;
    }
    // 2^(e − 136)·256 > m ≥ 2^(e − 136)·128: e = floor(log2 m) + 129.
    let mut e = m.log2().floor() as i32 + 129;
    let scale = |e: i32| (2.0f64).powi(136 - e);
    if (m * scale(e)).round() > 255.0 {
        e += 1;
    }
    if e < 1 {
        return 0;
    }
    let e = e.min(255);
    let q = |v: f32| ((v as f64 * scale(e)).round().clamp(0.0, 255.0)) as u32;
    q(c[0]) | q(c[1]) << 8 | q(c[2]) << 16 | (e as u32) << 24
}

/// Decodes shared-exponent RGB ([`rgbe_encode`]); exact in f32 and f64 alike.
pub fn rgbe_decode(t: u32) -> [f32; 3] {
    let e = (t >> 24) as i32;
    if e == 0 {
        return [0.0; 3];
    }
    let s = (2.0f32).powi(e - 136);
    [(t & 0xff) as f32 * s, ((t >> 8) & 0xff) as f32 * s, ((t >> 16) & 0xff) as f32 * s]
}

/// An equirectangular radiance map around the scene (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// What it is, for messages and `info`: a file's name, or `studio`.
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// Shared-exponent texels ([`rgbe_encode`]), row by row from the top, left to right.
    pub texels: Vec<u32>,
    /// What the map's radiance is multiplied by (`--env-intensity`).
    pub intensity: f64,
    /// Unit vectors: the map's top, and its centre column's direction on the horizon
    /// (orthogonal to `up`).
    pub up: DVec3,
    pub front: DVec3,
}

impl Environment {
    /// An environment of `width`×`height` linear RGB texels (`rgb`, three a texel, row 0 at
    /// the top) around `up`, its centre column towards `front` (made orthogonal to `up`).
    /// Refuses maps of no texels, wider than [`MAX_WIDTH`] or not twice as wide as high within
    /// a texel, and texels that are not finite or are negative (naming the first).
    pub fn from_rgb(
        name: &str,
        width: u32,
        height: u32,
        rgb: &[f32],
        up: DVec3,
        front: DVec3,
    ) -> Result<Environment> {
        let bad = |m: String| Err(Error::Scene(format!("environment {name}: {m}")));
        if width == 0 || height == 0 {
            return bad(format!("the map is {width}x{height}: it has no texels"));
        }
        if width > MAX_WIDTH {
            return bad(format!("the map is {width} texels wide, more than the {MAX_WIDTH} cuberay takes"));
        }
        if (width as i64 - 2 * height as i64).abs() > 1 {
            return bad(format!(
                "the map is {width}x{height}: an equirectangular map is twice as wide as it is high"
            ));
        }
        if rgb.len() != 3 * width as usize * height as usize {
            return bad(format!("{} values for {width}x{height} texels", rgb.len()));
        }
        if let Some(i) = rgb.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            let t = i / 3;
            return bad(format!(
                "texel ({}, {}) holds {} in channel {}: radiance must be finite and non-negative",
                t % width as usize,
                t / width as usize,
                rgb[i],
                i % 3
            ));
        }
        let Some((up, front)) = frame(up, front) else {
            return bad(format!("its up {up} and front {front} are zero or parallel"));
        };
        let texels = rgb.chunks_exact(3).map(|c| rgbe_encode([c[0], c[1], c[2]])).collect();
        Ok(Environment { name: name.into(), width, height, texels, intensity: 1.0, up, front })
    }

    /// The map turned by `degrees` about its up axis (counter-clockwise seen from above: the
    /// right-hand rule about `up`).
    pub fn rotated(mut self, degrees: f64) -> Environment {
        let (s, c) = degrees.to_radians().sin_cos();
        let side = self.front.cross(self.up);
        self.front = (self.front * c - side * s).normalize();
        self
    }

    /// Texel `(x, y)` decoded, without the intensity.
    pub fn texel(&self, x: u32, y: u32) -> DVec3 {
        let t = rgbe_decode(self.texels[(y * self.width + x) as usize]);
        DVec3::new(t[0] as f64, t[1] as f64, t[2] as f64)
    }

    /// The side axis of the map's frame: `front × up` (local z).
    pub fn side(&self) -> DVec3 {
        self.front.cross(self.up)
    }

    /// Where direction `d` (not zero) falls on the map: (u, v) in [0, 1].
    pub fn uv(&self, d: DVec3) -> (f64, f64) {
        let d = d.normalize();
        let (x, y, z) = (d.dot(self.front), d.dot(self.up), d.dot(self.side()));
        (0.5 + z.atan2(x) / (2.0 * PI), y.clamp(-1.0, 1.0).acos() / PI)
    }

    /// The world direction of map position (u, v).
    pub fn direction(&self, u: f64, v: f64) -> DVec3 {
        let (theta, phi) = (v * PI, (u - 0.5) * 2.0 * PI);
        self.front * (phi.cos() * theta.sin())
            + self.up * theta.cos()
            + self.side() * (phi.sin() * theta.sin())
    }

    /// The radiance arriving along `-d` from direction `d` (not zero): the map bilinear
    /// between texel centres, wrapped in u, clamped at the poles, times the intensity.
    pub fn radiance(&self, d: DVec3) -> DVec3 {
        let (u, v) = self.uv(d);
        let (w, h) = (self.width as i64, self.height as i64);
        let texel = |x: i64, y: i64| self.texel(x.rem_euclid(w) as u32, y.clamp(0, h - 1) as u32);
        super::bilinear(u * w as f64, v * h as f64, texel) * self.intensity
    }

    /// The solid angle of a texel of row `y`: `(2π / width)·(cos θ₀ − cos θ₁)` between the
    /// row's polar angles, so that the rows sum to 4π.
    pub fn texel_solid_angle(&self, y: u32) -> f64 {
        let h = self.height as f64;
        let (t0, t1) = (y as f64 * PI / h, (y + 1) as f64 * PI / h);
        2.0 * PI / self.width as f64 * (t0.cos() - t1.cos())
    }

    /// The map's whole integral of radiance over the sphere, `∫ L dω` (RGB), with the
    /// intensity.
    pub fn power(&self) -> DVec3 {
        let mut p = DVec3::ZERO;
        for y in 0..self.height {
            let row: DVec3 = (0..self.width).map(|x| self.texel(x, y)).sum();
            p += row * self.texel_solid_angle(y);
        }
        p * self.intensity
    }

    /// Up to `k` directional lights standing in for the map (see the module doc): median cut
    /// of its luminous power, each region a light of its power over π from its
    /// power-weighted mean direction. Regions without power give no light.
    pub fn lights(&self, k: u32) -> Vec<Light> {
        median_cut(&PowerGrid::of(self), k)
            .into_iter()
            .filter_map(|r| {
                let d = r.direction.try_normalize()?;
                (r.power.max_element() > 0.0).then(|| Light {
                    kind: LightKind::Directional,
                    position: DVec3::ZERO,
                    direction: -d,
                    color: r.power / PI,
                    intensity: 1.0,
                    inverse_square: false,
                    range: None,
                    source: LightSource::Environment,
                })
            })
            .collect()
    }

    /// Checks the invariants [`Environment::from_rgb`] establishes.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Scene(format!("environment {}: {m}", self.name)));
        if self.width == 0
            || self.height == 0
            || self.texels.len() != self.width as usize * self.height as usize
        {
            return bad(format!("{} texels for a {}x{} map", self.texels.len(), self.width, self.height));
        }
        if !(self.intensity.is_finite() && self.intensity >= 0.0) {
            return bad(format!("intensity {} is not finite and non-negative", self.intensity));
        }
        // The kernels scale texels by the intensity in f32: the brightest must stay finite.
        let brightest = self.texels.iter().map(|&t| t >> 24).max().unwrap_or(0) as i32;
        let bound = 256.0 * 2f64.powi(brightest - 136) * self.intensity;
        if bound > f32::MAX as f64 {
            return bad(format!(
                "intensity {} times its brightest texel (up to {:.3e}) is beyond f32's range ({:.3e}), which the \
                 GPU holds radiance in",
                self.intensity,
                bound / self.intensity,
                f32::MAX
            ));
        }
        let unit = |v: DVec3| v.is_finite() && (v.length() - 1.0).abs() < 1e-9;
        if !(unit(self.up) && unit(self.front) && self.up.dot(self.front).abs() < 1e-9) {
            return bad("its up and front are not orthogonal unit vectors".into());
        }
        Ok(())
    }
}

/// `up` normalised and `front` made orthogonal to it and normalised; `None` for zero or
/// parallel vectors.
fn frame(up: DVec3, front: DVec3) -> Option<(DVec3, DVec3)> {
    let up = up.try_normalize()?;
    let front = (front - up * front.dot(up)).try_normalize()?;
    Some((up, front))
}

/// The map's power per cell of a grid at most [`GRID_WIDTH`] wide (whole blocks of texels),
/// for the median cut: RGB power, luminous power and power-weighted direction per cell.
struct PowerGrid {
    width: usize,
    height: usize,
    power: Vec<DVec3>,
    luma: Vec<f64>,
    direction: Vec<DVec3>,
    /// A cell's angular width at its row's latitude, and its height, in radians.
    cell_width: Vec<f64>,
    cell_height: f64,
}

/// The widest grid the median cut splits: cells of whole texels of maps wider than this.
const GRID_WIDTH: u32 = 1024;

/// Rec. 709 luminance.
fn luma(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl PowerGrid {
    fn of(env: &Environment) -> PowerGrid {
        let f = env.width.div_ceil(GRID_WIDTH).max(1);
        let (gw, gh) = (env.width.div_ceil(f) as usize, env.height.div_ceil(f) as usize);
        let mut power = vec![DVec3::ZERO; gw * gh];
        let mut direction = vec![DVec3::ZERO; gw * gh];
        // A texel centre's direction: front·cos φ sin θ + up·cos θ + side·sin φ sin θ.
        let columns: Vec<(f64, f64)> = (0..env.width)
            .map(|x| (((x as f64 + 0.5) / env.width as f64 - 0.5) * 2.0 * PI).sin_cos())
            .collect();
        let side = env.side();
        for y in 0..env.height {
            let omega = env.texel_solid_angle(y) * env.intensity;
            let (st, ct) = ((y as f64 + 0.5) / env.height as f64 * PI).sin_cos();
            for x in 0..env.width {
                let p = env.texel(x, y) * omega;
                let i = (y / f) as usize * gw + (x / f) as usize;
                power[i] += p;
                let (sp, cp) = columns[x as usize];
                direction[i] += (env.front * (cp * st) + env.up * ct + side * (sp * st)) * luma(p);
            }
        }
        let luma = power.iter().map(|p| luma(*p)).collect();
        let cell_height = PI / gh as f64;
        let cell_width =
            (0..gh).map(|y| 2.0 * PI / gw as f64 * ((y as f64 + 0.5) * cell_height).sin()).collect();
        PowerGrid { width: gw, height: gh, power, luma, direction, cell_width, cell_height }
    }
}

/// A rectangle of grid cells, `x0..x1` × `y0..y1`, and what it holds.
#[derive(Clone, Copy, Debug)]
struct Region {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
    luma: f64,
    power: DVec3,
    direction: DVec3,
}

impl Region {
    fn of(g: &PowerGrid, x0: usize, x1: usize, y0: usize, y1: usize) -> Region {
        let mut r = Region { x0, x1, y0, y1, luma: 0.0, power: DVec3::ZERO, direction: DVec3::ZERO };
        for y in y0..y1 {
            for x in x0..x1 {
                let i = y * g.width + x;
                r.luma += g.luma[i];
                r.power += g.power[i];
                r.direction += g.direction[i];
            }
        }
        r
    }

    /// Its extent across (at its middle row's latitude) and down, in radians.
    fn extent(&self, g: &PowerGrid) -> (f64, f64) {
        let mid = (self.y0 + self.y1 - 1) / 2;
        ((self.x1 - self.x0) as f64 * g.cell_width[mid], (self.y1 - self.y0) as f64 * g.cell_height)
    }

    /// The two halves of equal luminous power across its longer extent, or `None` for a
    /// single cell.
    fn split(&self, g: &PowerGrid) -> Option<(Region, Region)> {
        let (across, down) = self.extent(g);
        let by_columns = across >= down && self.x1 - self.x0 > 1 || self.y1 - self.y0 <= 1;
        let (lo, hi) = if by_columns { (self.x0, self.x1) } else { (self.y0, self.y1) };
        if hi - lo <= 1 {
            return None;
        }
        let line = |i: usize| -> f64 {
            if by_columns {
                (self.y0..self.y1).map(|y| g.luma[y * g.width + i]).sum()
            } else {
                (self.x0..self.x1).map(|x| g.luma[i * g.width + x]).sum()
            }
        };
        // The first line at which the power before it reaches half (at least one line each).
        let (mut acc, mut cut) = (0.0, lo + 1);
        for i in lo..hi - 1 {
            acc += line(i);
            cut = i + 1;
            if acc >= self.luma * 0.5 {
                break;
            }
        }
        Some(if by_columns {
            (Region::of(g, self.x0, cut, self.y0, self.y1), Region::of(g, cut, self.x1, self.y0, self.y1))
        } else {
            (Region::of(g, self.x0, self.x1, self.y0, cut), Region::of(g, self.x0, self.x1, cut, self.y1))
        })
    }
}

/// Splits the grid into at most `k` regions: the region of most luminous power is halved
/// until there are `k`, or none with power can be.
fn median_cut(g: &PowerGrid, k: u32) -> Vec<Region> {
    if k == 0 {
        return Vec::new();
    }
    let mut regions = vec![Region::of(g, 0, g.width, 0, g.height)];
    let mut whole = Vec::new();
    while regions.len() + whole.len() < k as usize {
        let Some(i) = (0..regions.len())
            .filter(|&i| regions[i].luma > 0.0)
            .max_by(|&a, &b| regions[a].luma.total_cmp(&regions[b].luma))
        else {
            break;
        };
        let r = regions.swap_remove(i);
        match r.split(g) {
            Some((a, b)) => regions.extend([a, b]),
            None => whole.push(r),
        }
    }
    regions.extend(whole);
    regions
}

/// The built-in studio environment of glTF scenes without lights: a soft grey dome, lighter
/// overhead and darker below the horizon, and three large soft boxes (a key light, a fill
/// light and a light from above and behind), neutral in colour. Around `up`, its key light
/// towards `front`'s side of the scene.
pub fn studio(up: DVec3, front: DVec3) -> Environment {
    const W: u32 = 512;
    const H: u32 = 256;
    // (azimuth, elevation) of the box's centre, half-width, half-height (degrees), radiance.
    const BOXES: [(f64, f64, f64, f64, f64); 3] =
        [(35.0, 35.0, 22.0, 14.0, 9.0), (-110.0, 15.0, 28.0, 12.0, 2.5), (170.0, 62.0, 20.0, 12.0, 5.0)];
    let smooth = |e0: f64, e1: f64, x: f64| {
        let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    };
    let mut rgb = Vec::with_capacity((3 * W * H) as usize);
    for y in 0..H {
        let elevation = 90.0 - (y as f64 + 0.5) / H as f64 * 180.0;
        // Dome: 0.9 overhead to 0.65 at the horizon; a floor of 0.22 below it.
        let sky = 0.65 + 0.25 * (elevation.max(0.0) / 90.0).sqrt();
        let dome = 0.22 + (sky - 0.22) * smooth(-4.0, 2.0, elevation);
        for x in 0..W {
            let azimuth = ((x as f64 + 0.5) / W as f64 - 0.5) * 360.0;
            let mut l = dome;
            for (az, el, hw, hh, radiance) in BOXES {
                let mut da = (azimuth - az).abs() % 360.0;
                da = da.min(360.0 - da);
                let inside =
                    (1.0 - smooth(hw - 6.0, hw, da)) * (1.0 - smooth(hh - 4.0, hh, (elevation - el).abs()));
                l += (radiance - dome) * inside;
            }
            rgb.extend([l as f32; 3]);
        }
    }
    let mut env = Environment::from_rgb("studio", W, H, &rgb, up, front).expect("the studio map is valid");
    env.name = "studio".into();
    env
}

#[cfg(test)]
mod tests {
    use super::*;

    fn uniform(l: f32, w: u32) -> Environment {
        Environment::from_rgb("uniform", w, w / 2, &vec![l; (3 * w * (w / 2)) as usize], DVec3::Y, DVec3::X)
            .unwrap()
    }

    #[test]
    fn shared_exponent_texels_round_trip_within_a_mantissa_step() {
        for v in [0.0f32, 1e-30, 1e-6, 0.1, 0.5, 1.0, 3.7, 255.0, 1e5, 3e30] {
            for c in [[v, v * 0.5, v * 0.01], [v * 0.3, v, 0.0]] {
                let back = rgbe_decode(rgbe_encode(c));
                let m = c[0].max(c[1]).max(c[2]);
                for k in 0..3 {
                    assert!((back[k] - c[k]).abs() <= m / 256.0 + 1e-38, "{c:?} -> {back:?}");
                }
            }
        }
        assert_eq!(rgbe_encode([0.0; 3]), 0);
        assert_eq!(rgbe_decode(0), [0.0; 3]);
    }

    #[test]
    fn directions_and_map_positions_follow_the_sample_viewer() {
        let e = uniform(1.0, 64);
        // The centre column on the horizon is front (+X), u = 0.75 is +Z, the top row up.
        let close = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12;
        assert!(close(e.uv(DVec3::X), (0.5, 0.5)));
        assert!(close(e.uv(DVec3::Z), (0.75, 0.5)));
        assert!(close(e.uv(-DVec3::Z), (0.25, 0.5)));
        assert!(e.uv(DVec3::Y).1.abs() < 1e-12 && (e.uv(-DVec3::Y).1 - 1.0).abs() < 1e-12);
        for (u, v) in [(0.1, 0.2), (0.6, 0.9), (0.99, 0.5)] {
            let (u2, v2) = e.uv(e.direction(u, v));
            assert!((u - u2).abs() < 1e-12 && (v - v2).abs() < 1e-12);
        }
        // Turning the map by 90° about up (+Y, right-handed) carries its centre column from
        // +X to -Z.
        let r = uniform(1.0, 64).rotated(90.0);
        assert!(close(r.uv(-DVec3::Z), (0.5, 0.5)), "{:?}", r.uv(-DVec3::Z));
    }

    #[test]
    fn texel_solid_angles_cover_the_sphere() {
        let e = uniform(2.0, 100);
        let all: f64 = (0..e.height).map(|y| e.texel_solid_angle(y) * e.width as f64).sum();
        assert!((all - 4.0 * PI).abs() < 1e-9);
        assert!((e.power() - DVec3::splat(8.0 * PI)).length() < 1e-6);
    }

    #[test]
    fn the_lights_carry_the_maps_whole_power() {
        for env in [uniform(0.7, 256), studio(DVec3::Y, DVec3::X)] {
            for k in [1, 4, 16, 33] {
                let lights = env.lights(k);
                assert!(lights.len() <= k as usize && !lights.is_empty());
                let sum: DVec3 = lights.iter().map(|l| l.color * l.intensity * PI).sum();
                let whole = env.power();
                assert!((sum - whole).length() < 1e-9 * whole.length(), "{k}: {sum} against {whole}");
            }
        }
    }

    #[test]
    fn bad_maps_are_refused_with_the_texel_named() {
        let e = Environment::from_rgb("x.hdr", 4, 2, &[1.0; 24], DVec3::Y, DVec3::X);
        assert!(e.is_ok());
        let mut rgb = vec![1.0f32; 24];
        rgb[13] = f32::NAN;
        let msg = Environment::from_rgb("x.hdr", 4, 2, &rgb, DVec3::Y, DVec3::X).unwrap_err().to_string();
        assert!(msg.contains("x.hdr") && msg.contains("texel (0, 1)") && msg.contains("NaN"), "{msg}");
        rgb[13] = -1.0;
        assert!(Environment::from_rgb("x.hdr", 4, 2, &rgb, DVec3::Y, DVec3::X).is_err());
        assert!(Environment::from_rgb("x.hdr", 4, 4, &[1.0; 48], DVec3::Y, DVec3::X).is_err());
        assert!(Environment::from_rgb("x.hdr", 0, 0, &[], DVec3::Y, DVec3::X).is_err());
    }
}
