//! Signal-dependent sensor noise, σ²(I) = max(σ₀² + g·I, Δ²/12) (read noise + shot
//! noise, never below the quantisation's), measured on the images themselves.
//!
//! Quantisation: a sample rounded to steps of Δ carries an error uniform in ±Δ/2, of
//! variance Δ²/12 — the least noise an 8-bit image has, however smooth the scene (and
//! the only noise of a clean render). Δ is found from the images: in each image the
//! smallest positive difference between two distinct sample values of the mask (all
//! levels are multiples of Δ, and a natural image uses neighbouring levels), the median
//! over the images ([`Levels::step`]); float images give a negligible Δ. It is a
//! floor, not a term of the fit: on quantised data the residuals below measure it
//! except where a region is flat at one level (a metal's dark side, all zeros), where
//! they measure nothing and the fit alone would claim noise-free samples.
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

use super::levels::{Censor, Levels};
use crate::image::{ImageStack, Mask};

/// Number of intensity bins of the fit.
const BINS: usize = 8;
/// At most this many samples are used (a regular subsample beyond).
const MAX_SAMPLES: usize = 400_000;

/// σ²(I) = max(`read`² + `gain` · I, `step`²/12), in the images' intensity units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseModel {
    /// Standard deviation at zero signal (read noise), intensity units.
    pub read: f32,
    /// Slope of the variance with the signal (shot noise), intensity units.
    pub gain: f32,
    /// Quantisation step Δ of the samples (intensity units; 0 = unquantised): the
    /// variance is never below Δ²/12.
    pub step: f32,
}

impl NoiseModel {
    /// A constant noise of standard deviation `sigma`.
    pub fn constant(sigma: f32) -> Self {
        NoiseModel {
            read: sigma,
            gain: 0.0,
            step: 0.0,
        }
    }

    /// Variance of a sample of (noise-free) value `i`.
    #[inline]
    pub fn variance(&self, i: f32) -> f32 {
        let fit = self.read * self.read + self.gain * i.max(0.0);
        fit.max(self.step * self.step / 12.0)
    }

    /// Standard deviation of a sample of value `i`.
    #[inline]
    pub fn sigma(&self, i: f32) -> f32 {
        self.variance(i).sqrt()
    }

    /// Whether the quantisation is (about) all the noise there is in the dark: the
    /// fitted read and shot noise at 5% of full scale (I = 0.05) is within 4× the
    /// quantisation variance Δ²/12. True for clean 8-bit images; false for 16-bit or
    /// float images with real sensor noise, whose Gaussian model the fit describes. Taken
    /// in the dark, where the samples that are bounds are: the fit's slope also takes up
    /// the residuals of sharp highlights (a clean 8-bit metal vase: read 1.5e-4, gain
    /// 1.8e-5, Δ 3.9e-3, 7× Δ²/12 at mid scale but 0.7× at 5%).
    pub fn quantisation_limited(&self) -> bool {
        let floor = self.step * self.step / 12.0;
        floor > 0.0 && self.read * self.read + self.gain * 0.05 <= 4.0 * floor
    }

    /// The noise with the larger variance at every level (of two estimates, e.g. the
    /// sphere's and the target's).
    pub fn max(self, other: NoiseModel) -> NoiseModel {
        NoiseModel {
            read: self.read.max(other.read),
            gain: self.gain.max(other.gain),
            step: self.step.max(other.step),
        }
    }

    /// Estimate the model from the `mask` pixels of `stack` (see the module docs).
    /// Returns a zero model when fewer than 100 pixels have a full 3×3 neighbourhood.
    pub fn estimate(stack: &ImageStack, mask: &Mask) -> NoiseModel {
        Self::estimate_above(stack, mask, 0.0)
    }

    /// [`Self::estimate`] of the samples less a camera's black level `level` (image
    /// units; [`NoiseSampler::above`]): the model of the stack with the level taken off,
    /// without a copy of it.
    pub fn estimate_above(stack: &ImageStack, mask: &Mask, level: f32) -> NoiseModel {
        if (stack.width, stack.height) != (mask.width, mask.height) {
            return NoiseModel::constant(0.0);
        }
        let mut sampler = NoiseSampler::new(mask, stack.k).above(level);
        sampler.feed(stack, 0);
        sampler.finish()
    }

    /// [`Self::estimate`], and the censoring bounds of the same samples
    /// ([`Censor`], with the model's quantisation step).
    pub fn estimate_with_censor(stack: &ImageStack, mask: &Mask) -> (NoiseModel, Censor) {
        if (stack.width, stack.height) != (mask.width, mask.height) {
            return (NoiseModel::constant(0.0), Censor::none(stack.k));
        }
        let mut sampler = NoiseSampler::new(mask, stack.k);
        sampler.feed(stack, 0);
        sampler.finish_with_censor()
    }
}

/// [`NoiseModel::estimate`] fed by row bands, top to bottom (a capture too large to
/// hold whole): it keeps the last two rows of each band for the 3×3 neighbourhoods
/// across band edges and takes the same samples in the same order, so the model is
/// the one of the whole stack, bit for bit.
#[derive(Clone, Debug)]
pub struct NoiseSampler {
    mask: Mask,
    k: usize,
    /// Every `stride`-th interior pixel is sampled (at most [`MAX_SAMPLES`] samples).
    stride: usize,
    /// Interior pixels seen so far, row-major.
    seen: usize,
    /// The next centre row to take.
    next: usize,
    /// The last rows fed (pixel-major), up to two, and the index of the first.
    tail: (Vec<f32>, usize),
    samples: Vec<(f32, f32)>,
    /// A black level taken off every sample's intensity ([`NoiseSampler::above`]).
    offset: f32,
    /// The quantisation step and the censoring bounds, fed the same bands.
    levels: Levels,
}

impl NoiseSampler {
    /// A sampler of the `mask` pixels of `k` images of the mask's size.
    pub fn new(mask: &Mask, k: usize) -> Self {
        let (w, h) = (mask.width, mask.height);
        let interior =
            |r: usize, c: usize| (0..3).all(|i| (0..3).all(|j| *mask.get(r + i - 1, c + j - 1)));
        let inside = if w < 3 || h < 3 {
            0
        } else {
            (1..h - 1)
                .flat_map(|r| (1..w - 1).map(move |c| (r, c)))
                .filter(|&(r, c)| interior(r, c))
                .count()
        };
        let stride = (inside * k).div_ceil(MAX_SAMPLES).max(1);
        NoiseSampler {
            mask: mask.clone(),
            k,
            stride,
            seen: 0,
            next: 1,
            tail: (Vec::new(), 0),
            samples: Vec::with_capacity((inside * k / stride).min(MAX_SAMPLES) + 1),
            levels: Levels::new(mask, k),
            offset: 0.0,
        }
    }

    /// The sampler of the samples less a camera's black level `level` (image units), as
    /// a Lambertian solve takes it off: the noise's level dependence σ²(I) is then on
    /// the intensity the solve fits. The residuals (Immerkær's mask sums to 0) and the
    /// quantisation step do not change with an offset; the intensities binned do.
    pub fn above(mut self, level: f32) -> Self {
        self.offset = level;
        self
    }

    /// Take the samples of the rows `row0..row0 + band.height` of the images (`band`
    /// of the mask's width; bands fed in order, from the top, without gaps). A band of
    /// another width or K is ignored, as `estimate` ignores a stack of the wrong size.
    pub fn feed(&mut self, band: &ImageStack, row0: usize) {
        self.levels.feed(band, row0);
        let (w, h, k) = (self.mask.width, self.mask.height, self.k);
        if band.width != w || band.k != k || w < 3 || h < 3 || band.height == 0 {
            return;
        }
        let end = row0 + band.height;
        let (tail, t0) = (&self.tail.0, self.tail.1);
        let pixel = |r: usize, c: usize| -> &[f32] {
            if r >= row0 {
                band.pixel(r - row0, c)
            } else {
                let i = ((r - t0) * w + c) * k;
                &tail[i..i + k]
            }
        };
        const N: [[f32; 3]; 3] = [[1.0, -2.0, 1.0], [-2.0, 4.0, -2.0], [1.0, -2.0, 1.0]];
        while self.next + 1 < end.min(h) {
            let r = self.next;
            for c in 1..w - 1 {
                if !(0..3).all(|i| (0..3).all(|j| *self.mask.get(r + i - 1, c + j - 1))) {
                    continue;
                }
                self.seen += 1;
                if self.seen % self.stride != 0 {
                    continue;
                }
                for light in 0..k {
                    let (mut res, mut mean) = (0.0f32, 0.0f32);
                    for (i, row) in N.iter().enumerate() {
                        for (j, &wgt) in row.iter().enumerate() {
                            let v = pixel(r + i - 1, c + j - 1)[light];
                            res += wgt * v;
                            mean += v;
                        }
                    }
                    if res.is_finite() && mean.is_finite() {
                        self.samples.push((mean / 9.0 - self.offset, res.abs()));
                    }
                }
            }
            self.next += 1;
        }
        // keep the last two rows for the neighbourhoods across the next band's edge
        let first = end.saturating_sub(2).max(t0.min(row0));
        let mut kept = Vec::with_capacity(2 * w * k);
        for r in first..end {
            for c in 0..w {
                kept.extend_from_slice(pixel(r, c));
            }
        }
        self.tail = (kept, first);
    }

    /// The model of the samples taken (a zero model when fewer than 100 pixels had a
    /// full 3×3 neighbourhood).
    pub fn finish(self) -> NoiseModel {
        self.finish_with_censor().0
    }

    /// [`Self::finish`], and the censoring bounds of the samples fed
    /// ([`Levels::censor`] with the model's step).
    pub fn finish_with_censor(self) -> (NoiseModel, Censor) {
        let step = self.levels.step();
        let censor = self.levels.censor(step);
        let model = if self.samples.len() < 100 * self.k.max(1) {
            NoiseModel::constant(0.0)
        } else {
            fit(self.samples)
        };
        (NoiseModel { step, ..model }, censor)
    }
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
        step: 0.0,
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
    fn bands_give_the_model_of_the_whole_stack() {
        let (s, m) = noisy_ramp(0.01, 0.0004);
        let whole = NoiseModel::estimate(&s, &m);
        for rows in [1, 2, 3, 7, 100] {
            let mut sampler = NoiseSampler::new(&m, s.k);
            for r0 in (0..s.height).step_by(rows) {
                let r1 = (r0 + rows).min(s.height);
                let band = ImageStack {
                    width: s.width,
                    height: r1 - r0,
                    k: s.k,
                    data: s.data[r0 * s.width * s.k..r1 * s.width * s.k].to_vec(),
                    names: Vec::new(),
                };
                sampler.feed(&band, r0);
            }
            assert_eq!(sampler.finish(), whole, "bands of {rows} rows");
        }
    }

    #[test]
    fn a_black_level_taken_off_is_the_model_of_the_shifted_stack() {
        // what `normals --lambertian` measured on a copy of the stack less the level
        let (s, m) = noisy_ramp(0.01, 0.0004);
        let level = 0.03;
        let mut shifted = s.clone();
        shifted.data.iter_mut().for_each(|v| *v -= level);
        let copy = NoiseModel::estimate(&shifted, &m);
        let above = NoiseModel::estimate_above(&s, &m, level);
        // to rounding: the offset comes off the 3×3 mean here, off each sample there
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs());
        assert!(
            close(copy.read, above.read) && close(copy.gain, above.gain),
            "{copy:?} {above:?}"
        );
        // and the shift matters: read² + g·I is fitted at intensities lower by the level
        let plain = NoiseModel::estimate(&s, &m);
        assert!(above.read > plain.read, "{above:?} {plain:?}");
    }

    #[test]
    fn quantised_flat_images_have_the_quantisation_variance() {
        // a metal's dark side: most samples at 0, a ramp of 8-bit levels elsewhere
        let (w, h, k) = (60, 50, 3);
        let mut s = ImageStack::zeros(w, h, k);
        for r in 0..h {
            for c in 0..w {
                for (l, v) in s.pixel_flat_mut(r * w + c).iter_mut().enumerate() {
                    let x = (c as f32 - 40.0).max(0.0) * (0.003 + 0.001 * l as f32);
                    *v = (x * 255.0).round() / 255.0 / 0.7; // 8-bit, then ÷ an intensity
                }
            }
        }
        let est = NoiseModel::estimate(&s, &Mask::full(w, h));
        assert!((est.step - 1.0 / 255.0 / 0.7).abs() < 1e-6, "{est:?}");
        let floor = est.step / 12f32.sqrt();
        assert!(est.sigma(0.0) >= floor * 0.999, "{est:?}");
        // float samples: no visible step
        let (f, m) = noisy_ramp(0.01, 0.0);
        assert!(NoiseModel::estimate(&f, &m).step < 1e-5);
    }

    #[test]
    fn constant_noise_has_no_gain() {
        let (s, m) = noisy_ramp(0.02, 0.0);
        let est = NoiseModel::estimate(&s, &m);
        assert!((est.sigma(0.5) - 0.02).abs() < 0.002, "{est:?}");
    }
}
