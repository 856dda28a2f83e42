//! Comparing two renders of one scene (the GPU against the CPU reference): RMSE, PSNR,
//! FLIP mean (NVIDIA's perceptual metric, through the `nv-flip` crate), maximum absolute
//! difference and the share of pixels differing by more than a tolerance, plus a FLIP
//! heat map.
//!
//! Every metric is taken on what a viewer sees: both images are encoded as the PNG
//! writer encodes them (clamped, by the render's transfer, 8 bits), and RMSE, PSNR, the
//! maximum difference and the tolerance use those values scaled to [0, 1] (PSNR with peak
//! 1). A pixel is over the tolerance when any of its channels differs by more than it.

use serde::Serialize;

use crate::output::{to_rgb8, Image};

/// The comparison of a test image with a reference.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    pub rmse: f64,
    /// In dB; `null` in JSON (None) when the images are identical.
    pub psnr: Option<f64>,
    pub flip_mean: f64,
    pub max_abs: f64,
    /// Share of pixels (0..1) with a channel differing by more than `tolerance`.
    pub over_tolerance: f64,
    pub tolerance: f64,
    /// Pixels where either image is not finite (they must be none).
    pub non_finite: u64,
}

/// Compares `test` with `reference` (same size); also returns the FLIP heat map as
/// RGB8 (magma colour map), row-major.
pub fn compare(reference: &Image, test: &Image, tolerance: f64) -> (Comparison, Vec<u8>) {
    assert_eq!((reference.width, reference.height), (test.width, test.height), "image sizes differ");
    let (w, h) = (reference.width, reference.height);
    let non_finite = reference
        .pixels
        .iter()
        .zip(&test.pixels)
        .filter(|(a, b)| !a[..3].iter().chain(&b[..3]).all(|v| v.is_finite()))
        .count() as u64;
    let a = to_rgb8(reference).into_raw();
    let b = to_rgb8(test).into_raw();
    let mut sum_sq = 0.0;
    let mut max_abs: f64 = 0.0;
    let mut over = 0u64;
    for (pa, pb) in a.chunks_exact(3).zip(b.chunks_exact(3)) {
        let mut worst: f64 = 0.0;
        for c in 0..3 {
            let d = (pa[c] as f64 - pb[c] as f64).abs() / 255.0;
            sum_sq += d * d;
            worst = worst.max(d);
        }
        max_abs = max_abs.max(worst);
        if worst > tolerance {
            over += 1;
        }
    }
    let n = (w as u64 * h as u64).max(1) as f64;
    let rmse = (sum_sq / (3.0 * n)).sqrt();
    let psnr = (rmse > 0.0).then(|| -20.0 * rmse.log10());
    let ra = nv_flip::FlipImageRgb8::with_data(w, h, &a);
    let rb = nv_flip::FlipImageRgb8::with_data(w, h, &b);
    let map = nv_flip::flip(ra, rb, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let flip_mean = nv_flip::FlipPool::from_image(&map).mean() as f64;
    let heat = map.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    (
        Comparison { rmse, psnr, flip_mean, max_abs, over_tolerance: over as f64 / n, tolerance, non_finite },
        heat,
    )
}

impl Comparison {
    /// The table `cuberay compare` prints.
    pub fn to_text(&self) -> String {
        let psnr = self.psnr.map_or("inf (identical)".to_string(), |p| format!("{p:.2} dB"));
        format!(
            "RMSE            {:.6}\nPSNR            {psnr}\nFLIP mean       {:.6}\nmax abs         {:.6}\nover tolerance  {:.4}% of pixels (> {})\n",
            self.rmse,
            self.flip_mean,
            self.max_abs,
            self.over_tolerance * 100.0,
            self.tolerance
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(v: f32) -> Image {
        let mut img = Image::new(16, 16, false);
        for p in &mut img.pixels {
            *p = [v, v, v, 1.0];
        }
        img
    }

    #[test]
    fn identical_images_do_not_differ() {
        let (c, heat) = compare(&flat(0.5), &flat(0.5), 0.01);
        assert_eq!((c.rmse, c.max_abs, c.over_tolerance, c.psnr), (0.0, 0.0, 0.0, None));
        assert!(c.flip_mean < 1e-6);
        assert_eq!(heat.len(), 16 * 16 * 3);
    }

    #[test]
    fn black_against_white_differs_fully() {
        let (c, _) = compare(&flat(0.0), &flat(1.0), 0.01);
        assert!((c.rmse - 1.0).abs() < 1e-12 && (c.max_abs - 1.0).abs() < 1e-12);
        assert_eq!(c.over_tolerance, 1.0);
        assert_eq!(c.psnr, Some(-0.0));
        assert!(c.flip_mean > 0.5, "{}", c.flip_mean);
    }
}
