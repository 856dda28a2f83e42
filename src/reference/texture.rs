//! Texture sampling: sRGB texels decoded to linear, wrap modes, bilinear or nearest.
//!
//! Texture coordinates follow glTF: (0, 0) is the top-left corner of the image, u grows
//! to the right and v downwards; texel (i, j) has its centre at ((i + 0.5)/W, (j + 0.5)/H).

use glam::{DVec2, DVec3};

use crate::scene::{Texture, Wrap};

/// The sRGB electro-optical transfer function: an 8-bit sRGB value to linear [0, 1].
pub fn srgb_to_linear(v: u8) -> f64 {
    let c = v as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn wrap(i: i64, n: u32, mode: Wrap) -> usize {
    let n = n as i64;
    let j = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m >= n {
                2 * n - 1 - m
            } else {
                m
            }
        }
    };
    j as usize
}

fn texel(t: &Texture, i: i64, j: i64) -> DVec3 {
    let x = wrap(i, t.width, t.wrap_s);
    let y = wrap(j, t.height, t.wrap_t);
    let c = t.texels[y * t.width as usize + x];
    DVec3::new(srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2]))
}

/// The linear RGB colour of texture `t` at `uv`.
pub fn sample(t: &Texture, uv: DVec2) -> DVec3 {
    // Keep coordinates in a range where the integer conversion is exact; every wrap mode
    // is periodic or constant far away, so this changes nothing visible.
    let x = (uv.x * t.width as f64).clamp(-1e12, 1e12);
    let y = (uv.y * t.height as f64).clamp(-1e12, 1e12);
    if !t.linear {
        return texel(t, x.floor() as i64, y.floor() as i64);
    }
    let (x, y) = (x - 0.5, y - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (i, j) = (x0 as i64, y0 as i64);
    let top = texel(t, i, j) * (1.0 - fx) + texel(t, i + 1, j) * fx;
    let bottom = texel(t, i, j + 1) * (1.0 - fx) + texel(t, i + 1, j + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(wrap: Wrap, linear: bool) -> Texture {
        Texture {
            name: None,
            width: 2,
            height: 1,
            texels: vec![[0, 0, 0, 255], [255, 255, 255, 255]],
            wrap_s: wrap,
            wrap_t: wrap,
            linear,
        }
    }

    #[test]
    fn srgb_decoding() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        assert!((srgb_to_linear(188) - 0.5).abs() < 0.01);
    }

    #[test]
    fn nearest_and_wrap_modes() {
        let t = checker(Wrap::Repeat, false);
        assert_eq!(sample(&t, DVec2::new(0.25, 0.5)).x, 0.0);
        assert_eq!(sample(&t, DVec2::new(0.75, 0.5)).x, 1.0);
        assert_eq!(sample(&t, DVec2::new(1.25, 0.5)).x, 0.0);
        assert_eq!(sample(&t, DVec2::new(-0.25, 0.5)).x, 1.0);
        let t = checker(Wrap::ClampToEdge, false);
        assert_eq!(sample(&t, DVec2::new(5.0, 0.5)).x, 1.0);
        assert_eq!(sample(&t, DVec2::new(-5.0, 0.5)).x, 0.0);
        let t = checker(Wrap::MirroredRepeat, false);
        // [0,1) is black|white, [1,2) mirrored is white|black.
        assert_eq!(sample(&t, DVec2::new(1.25, 0.5)).x, 1.0);
        assert_eq!(sample(&t, DVec2::new(1.75, 0.5)).x, 0.0);
    }

    #[test]
    fn bilinear_interpolates_in_linear_space() {
        let t = checker(Wrap::ClampToEdge, true);
        // Halfway between the two texel centres.
        assert!((sample(&t, DVec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-12);
        assert_eq!(sample(&t, DVec2::new(0.25, 0.5)).x, 0.0);
    }
}
