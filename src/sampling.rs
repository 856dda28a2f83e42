//! Where eye rays go through the image: pixel centres, stratified jitter (`--spp N
//! --seed S`), or the SPD pixel corners. Both backends place their samples with these
//! functions (the GPU's twins are in `shaders/shared/sampling.wgsl`, keep them in sync), so
//! the random numbers come from a stateless 32-bit hash that WGSL can copy.
//!
//! - **Centre** (`spp = 1`): pixel (i, j) is sampled once at (i + 0.5, j + 0.5).
//! - **Jitter** (`spp = N > 1`): sample s of pixel (i, j) lies in stratum
//!   (s, (s·g) mod N) of an N×N grid over the pixel, where g is the first integer from
//!   round(N/φ) up that is coprime to N (a rank-1 lattice, so every row and column of the
//!   grid holds one sample), at a uniformly random place inside that stratum.
//! - **Corners** (SPD procedure): (W+1)×(H+1) rays at the integer positions (i, j), each
//!   pixel the mean of its four corners.
//!
//! The random number for (seed, pixel, sample, dimension) is
//! `pcg(pcg(pcg(pcg(seed_hi) ^ seed_lo) ^ pixel) ^ (2·sample + dimension))` with
//! `pixel = j·W + i`, taking the top 24 bits as a fraction in [0, 1) (exact in f32).

/// How eye rays are placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampling {
    /// Within each pixel: its centre with one sample, stratified jitter with more (`--spp N`,
    /// N > 1; `--sampling center` on the command line).
    Pixels,
    /// SPD procedure: rays at the (W+1)×(H+1) pixel corners, four averaged per pixel.
    Corners,
}

/// The PCG-RXS-M-XS 32-bit hash (Jarzynski and Olano, JCGT 2020).
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The seed's part of every random number, `pcg(pcg(seed_hi) ^ seed_lo)` (the GPU gets it
/// precomputed as `Params::seed_hash`).
pub fn seed_hash(seed: u64) -> u32 {
    pcg(pcg((seed >> 32) as u32) ^ seed as u32)
}

/// A number in [0, 1) for (seed, pixel, sample, dimension); see the module documentation.
pub fn random(seed: u64, pixel: u32, sample: u32, dim: u32) -> f64 {
    let h = pcg(pcg(seed_hash(seed) ^ pixel) ^ (2 * sample + dim));
    (h >> 8) as f64 / (1u32 << 24) as f64
}

fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// The lattice generator for `n` samples: the first integer ≥ round(n/φ) coprime to n.
pub fn lattice_generator(n: u32) -> u32 {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut g = ((n as f64 / phi).round() as u32).max(1);
    while gcd(g, n) != 1 {
        g += 1;
    }
    g
}

/// Image position of sample `s` (of `spp`) in pixel (i, j) of a `width`-wide image.
pub fn sample_position(i: u32, j: u32, width: u32, s: u32, spp: u32, seed: u64) -> (f64, f64) {
    if spp <= 1 {
        return (i as f64 + 0.5, j as f64 + 0.5);
    }
    let pixel = j.wrapping_mul(width).wrapping_add(i);
    let g = lattice_generator(spp);
    let sx = s;
    let sy = ((s as u64 * g as u64) % spp as u64) as u32;
    let n = spp as f64;
    let x = (sx as f64 + random(seed, pixel, s, 0)) / n;
    let y = (sy as f64 + random(seed, pixel, s, 1)) / n;
    (i as f64 + x, j as f64 + y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jitter_is_stratified_and_deterministic() {
        for spp in [2u32, 3, 4, 7, 16] {
            let mut cols = vec![false; spp as usize];
            let mut rows = vec![false; spp as usize];
            for s in 0..spp {
                let (x, y) = sample_position(3, 5, 10, s, spp, 42);
                assert!((3.0..4.0).contains(&x) && (5.0..6.0).contains(&y));
                let (cx, cy) = (((x - 3.0) * spp as f64) as usize, ((y - 5.0) * spp as f64) as usize);
                assert!(!cols[cx] && !rows[cy], "spp {spp}: two samples in one stratum");
                cols[cx] = true;
                rows[cy] = true;
                assert_eq!((x, y), sample_position(3, 5, 10, s, spp, 42));
            }
        }
        // Another seed moves the samples.
        assert_ne!(sample_position(3, 5, 10, 0, 4, 1), sample_position(3, 5, 10, 0, 4, 2));
        assert_eq!(sample_position(3, 5, 10, 0, 1, 7), (3.5, 5.5));
    }
}
