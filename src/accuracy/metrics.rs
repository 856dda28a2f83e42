//! How far a render is from the reference: RMSE, PSNR and relMSE on the linear radiance (so
//! that differences below an 8-bit step still count), FLIP mean and 99th percentile on what
//! a viewer sees (both images encoded as the PNG writer encodes them), and, from the
//! pixel-centre AOVs, the share of eye rays that hit another object than the reference's and
//! the largest hit-distance error relative to the scene's size.

use serde::Serialize;

use crate::output::{to_rgb8, Image};

/// relMSE's ε: `mean((I − R)² / (R² + ε))` (Gharbi et al. 2019 use 0.01).
pub const RELMSE_EPSILON: f64 = 0.01;

/// A render's error against the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ImageError {
    pub rmse: f64,
    /// In dB, peak 1; `null` when the images are equal.
    pub psnr: Option<f64>,
    pub relmse: f64,
    pub flip_mean: f64,
    pub flip_p99: f64,
}

/// `test` against `reference` (same size).
pub fn image_error(reference: &Image, test: &Image) -> ImageError {
    assert_eq!((reference.width, reference.height), (test.width, test.height), "image sizes differ");
    let (mut se, mut rel) = (0.0, 0.0);
    for (r, t) in reference.pixels.iter().zip(&test.pixels) {
        for c in 0..3 {
            let (r, t) = (r[c] as f64, t[c] as f64);
            se += (t - r) * (t - r);
            rel += (t - r) * (t - r) / (r * r + RELMSE_EPSILON);
        }
    }
    let n = (3 * reference.pixels.len()).max(1) as f64;
    let mse = se / n;
    let (w, h) = (reference.width, reference.height);
    let a = nv_flip::FlipImageRgb8::with_data(w, h, &to_rgb8(reference).into_raw());
    let b = nv_flip::FlipImageRgb8::with_data(w, h, &to_rgb8(test).into_raw());
    let map = nv_flip::flip(a, b, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mut pool = nv_flip::FlipPool::from_image(&map);
    ImageError {
        rmse: mse.sqrt(),
        psnr: (mse > 0.0).then(|| -10.0 * mse.log10()),
        relmse: rel / n,
        flip_mean: pool.mean() as f64,
        flip_p99: pool.get_percentile(0.99, true) as f64,
    }
}

/// Eye rays through the pixel centres against the reference's: the share that hit another
/// object (or hit where the other missed), and the largest difference of the hit distance
/// where both hit the same object, over `size` (the scene's bounding diagonal).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct HitError {
    pub id_disagreement: f64,
    pub max_t_error: f64,
}

/// The hit error of the `id` and `depth` AOVs of a render against the reference's.
pub fn hit_error(ref_id: &Image, ref_depth: &Image, id: &Image, depth: &Image, size: f64) -> HitError {
    let mut differ = 0usize;
    let mut worst: f64 = 0.0;
    for k in 0..ref_id.pixels.len() {
        if ref_id.pixels[k][0] != id.pixels[k][0] {
            differ += 1;
        } else if ref_id.pixels[k][0] >= 0.0 {
            let d = (ref_depth.pixels[k][0] as f64 - depth.pixels[k][0] as f64).abs();
            worst = worst.max(d);
        }
    }
    HitError {
        id_disagreement: differ as f64 / ref_id.pixels.len().max(1) as f64,
        max_t_error: if size > 0.0 { worst / size } else { worst },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(v: f32) -> Image {
        let mut img = Image::new(8, 8, false);
        for p in &mut img.pixels {
            *p = [v, v, v, 1.0];
        }
        img
    }

    #[test]
    fn equal_images_have_no_error_and_offsets_have_the_expected_one() {
        let e = image_error(&flat(0.5), &flat(0.5));
        assert_eq!((e.rmse, e.psnr, e.relmse), (0.0, None, 0.0));
        assert!(e.flip_mean < 1e-6 && e.flip_p99 < 1e-6);
        let e = image_error(&flat(0.5), &flat(0.6));
        assert!((e.rmse - 0.1).abs() < 1e-6, "{e:?}");
        assert!((e.psnr.unwrap() - 20.0).abs() < 1e-4, "{e:?}");
        assert!((e.relmse - 0.01 / 0.26).abs() < 1e-6, "{e:?}");
        // A uniform difference: every pixel has the same FLIP value, so p99 is the mean.
        assert!(e.flip_mean > 0.0 && (e.flip_p99 - e.flip_mean).abs() < 1e-5, "{e:?}");
    }

    #[test]
    fn hits_on_other_objects_and_distance_errors_are_counted() {
        let (mut id, mut depth) = (Image::new(2, 2, true), Image::new(2, 2, true));
        for (k, p) in id.pixels.iter_mut().enumerate() {
            *p = [k as f32; 4];
        }
        for p in &mut depth.pixels {
            *p = [3.0; 4];
        }
        let (mut id2, mut depth2) = (id.clone(), depth.clone());
        id2.pixels[3] = [-1.0; 4];
        depth2.pixels[1] = [3.5; 4];
        let e = hit_error(&id, &depth, &id2, &depth2, 10.0);
        assert_eq!(e.id_disagreement, 0.25);
        assert!((e.max_t_error - 0.05).abs() < 1e-12);
    }
}
