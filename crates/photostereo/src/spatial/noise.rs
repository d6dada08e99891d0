//! Signal-dependent sensor noise, σ²(I) = σ₀² + g·I (read noise + shot noise), measured
//! on the images themselves.
//!
//! Each sample's residual against a local quadratic is taken with Immerkær's 3×3 mask
//! N = [1 −2 1; −2 4 −2; 1 −2 1] (the product of the second differences along rows and
//! columns: it cancels every quadratic in (x, y), so smooth shading leaves almost nothing
//! and the residual of i.i.d. noise has variance 36 σ²; Immerkær, "Fast noise variance
//! estimation", CVIU 64(2), 1996). The samples are binned by the 3×3 mean intensity; in
//! each bin σ_b = 1.4826 · median|r| / 6 (robust to edges and highlights), and
//! (σ₀², g) is the non-negative least-squares line through the (mean, σ_b²) of the bins.
//! Use it on a calibration sphere (mask = the sphere's disc) or on a target (its mask):
//! only pixels whose whole 3×3 neighbourhood lies in the mask count.

use crate::image::{ImageStack, Mask};

/// Number of intensity bins of the fit.
const BINS: usize = 8;
/// At most this many samples are used (a regular subsample beyond).
const MAX_SAMPLES: usize = 400_000;

/// σ²(I) = `read`² + `gain` · I, in the images' intensity units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseModel {
    /// Standard deviation at zero signal (read noise), intensity units.
    pub read: f32,
    /// Slope of the variance with the signal (shot noise), intensity units.
    pub gain: f32,
}

impl NoiseModel {
    /// A constant noise of standard deviation `sigma`.
    pub fn constant(sigma: f32) -> Self {
        NoiseModel {
            read: sigma,
            gain: 0.0,
        }
    }

    /// Variance of a sample of (noise-free) value `i`.
    #[inline]
    pub fn variance(&self, i: f32) -> f32 {
        self.read * self.read + self.gain * i.max(0.0)
    }

    /// Standard deviation of a sample of value `i`.
    #[inline]
    pub fn sigma(&self, i: f32) -> f32 {
        self.variance(i).sqrt()
    }

    /// The noise with the larger variance at every level (of two estimates, e.g. the
    /// sphere's and the target's).
    pub fn max(self, other: NoiseModel) -> NoiseModel {
        NoiseModel {
            read: self.read.max(other.read),
            gain: self.gain.max(other.gain),
        }
    }

    /// Estimate the model from the `mask` pixels of `stack` (see the module docs).
    /// Returns a zero model when fewer than 100 pixels have a full 3×3 neighbourhood.
    pub fn estimate(stack: &ImageStack, mask: &Mask) -> NoiseModel {
        let samples = residuals(stack, mask);
        if samples.len() < 100 * stack.k.max(1) {
            return NoiseModel::constant(0.0);
        }
        fit(samples)
    }
}

/// (3×3 mean, Immerkær residual) of the interior samples, subsampled to at most
/// [`MAX_SAMPLES`].
fn residuals(stack: &ImageStack, mask: &Mask) -> Vec<(f32, f32)> {
    let (w, h, k) = (stack.width, stack.height, stack.k);
    if w < 3 || h < 3 || mask.width != w || mask.height != h {
        return Vec::new();
    }
    let inside = (1..h - 1)
        .flat_map(|r| (1..w - 1).map(move |c| (r, c)))
        .filter(|&(r, c)| (0..3).all(|i| (0..3).all(|j| *mask.get(r + i - 1, c + j - 1))))
        .count();
    let stride = (inside * k).div_ceil(MAX_SAMPLES).max(1);
    const N: [[f32; 3]; 3] = [[1.0, -2.0, 1.0], [-2.0, 4.0, -2.0], [1.0, -2.0, 1.0]];
    let mut out = Vec::with_capacity((inside * k / stride).min(MAX_SAMPLES) + 1);
    let mut seen = 0usize;
    for r in 1..h - 1 {
        for c in 1..w - 1 {
            if !(0..3).all(|i| (0..3).all(|j| *mask.get(r + i - 1, c + j - 1))) {
                continue;
            }
            seen += 1;
            if seen % stride != 0 {
                continue;
            }
            for light in 0..k {
                let (mut res, mut mean) = (0.0f32, 0.0f32);
                for (i, row) in N.iter().enumerate() {
                    for (j, &wgt) in row.iter().enumerate() {
                        let v = stack.pixel(r + i - 1, c + j - 1)[light];
                        res += wgt * v;
                        mean += v;
                    }
                }
                if res.is_finite() && mean.is_finite() {
                    out.push((mean / 9.0, res.abs()));
                }
            }
        }
    }
    out
}

/// Bin by intensity, robust σ per bin, non-negative line σ² = a + g·I.
fn fit(mut samples: Vec<(f32, f32)>) -> NoiseModel {
    samples.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let n = samples.len();
    let mut pts = Vec::with_capacity(BINS);
    for b in 0..BINS {
        let bin = &samples[b * n / BINS..(b + 1) * n / BINS];
        let mean = bin.iter().map(|s| s.0 as f64).sum::<f64>() / bin.len() as f64;
        let mut res: Vec<f32> = bin.iter().map(|s| s.1).collect();
        let mid = res.len() / 2;
        let med = *res.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1 as f64;
        let sigma = 1.4826 * med / 6.0;
        pts.push((mean.max(0.0), sigma * sigma));
    }
    // least squares of v = a + g·m; fall back to one of the two terms when either is < 0
    let np = pts.len() as f64;
    let (sm, sv) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), &(m, v)| (a + m, b + v));
    let (mm, mv) = (sm / np, sv / np);
    let sxx: f64 = pts.iter().map(|&(m, _)| (m - mm).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|&(m, v)| (m - mm) * (v - mv)).sum();
    let mut g = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let mut a = mv - g * mm;
    if g < 0.0 {
        g = 0.0;
        a = mv;
    } else if a < 0.0 {
        let smm: f64 = pts.iter().map(|&(m, _)| m * m).sum();
        let smv: f64 = pts.iter().map(|&(m, v)| m * v).sum();
        a = 0.0;
        g = if smm > 0.0 { (smv / smm).max(0.0) } else { 0.0 };
    }
    NoiseModel {
        read: a.max(0.0).sqrt() as f32,
        gain: g as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::random::SplitMix64;

    fn noisy_ramp(read: f32, gain: f32) -> (ImageStack, Mask) {
        let (w, h, k) = (120, 100, 4);
        let mut s = ImageStack::zeros(w, h, k);
        let mut rng = SplitMix64::new(7);
        for r in 0..h {
            for c in 0..w {
                let px = s.pixel_flat_mut(r * w + c);
                for (l, v) in px.iter_mut().enumerate() {
                    // smooth shading: a quadratic in (x, y) plus a gentle wave
                    let x = c as f32 / w as f32;
                    let y = r as f32 / h as f32;
                    let clean = 0.1 + 0.8 * x * (1.0 - 0.3 * y) + 0.05 * l as f32 + 0.02 * y * y;
                    let sd = (read * read + gain * clean).sqrt();
                    *v = clean + sd * rng.normal() as f32;
                }
            }
        }
        (s, Mask::full(w, h))
    }

    #[test]
    fn recovers_read_and_shot_noise() {
        let (s, m) = noisy_ramp(0.01, 0.0004);
        let est = NoiseModel::estimate(&s, &m);
        // measured: read 0.0101, gain 0.000392
        assert!((est.read - 0.01).abs() < 0.002, "{est:?}");
        assert!((est.gain - 0.0004).abs() < 0.0001, "{est:?}");
    }

    #[test]
    fn constant_noise_has_no_gain() {
        let (s, m) = noisy_ramp(0.02, 0.0);
        let est = NoiseModel::estimate(&s, &m);
        assert!((est.sigma(0.5) - 0.02).abs() < 0.002, "{est:?}");
    }
}
