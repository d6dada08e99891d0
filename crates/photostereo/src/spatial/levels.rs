//! The sample levels of a capture, measured on the images themselves: the quantisation
//! step Δ (see [`super::noise`]) and, per image, the floor and the clipping level that
//! make a sample a bound rather than a measurement ([`Censor`]).
//!
//! Δ: in each image the smallest positive difference between two distinct sample values
//! of the mask (all levels are multiples of Δ, and a natural image uses neighbouring
//! levels), from a regular subsample of at most [`MAX_STEP_SAMPLES`] mask pixels; the
//! median over the images that have at least [`MIN_DISTINCT`] distinct values, 0 when
//! none has (no quantisation floor, no censoring: nothing measured it). Float images
//! give a negligible Δ.
//!
//! Everything here is accumulated by row bands ([`Levels::feed`]), so that a capture
//! read band by band gets the bounds of the whole stack, bit for bit.

use crate::image::{ImageStack, Mask};
use crate::stats::median_smallest_gap;

/// At most this many mask pixels per image are kept for the quantisation step: enough
/// to meet neighbouring levels of an 8-bit image many times over (on a 16-bit image the
/// step found may be a few Δ, still a negligible floor), and at most 200 KB per image
/// held by the banded run's sampler (compacted as it goes).
pub const MAX_STEP_SAMPLES: usize = 50_000;

/// An image with fewer distinct values in the mask says nothing about the step: a
/// render of flat faces has three (a 16-bit V-groove's smallest difference was 478
/// levels, taken for the step: every sample then looked ±138 levels noisy, and the faces,
/// each at its image's smallest value, were censored as the floor).
pub const MIN_DISTINCT: usize = 16;

/// The levels of the `mask` samples, fed by row bands, top to bottom.
#[derive(Clone, Debug)]
pub struct Levels {
    mask: Mask,
    /// Every `stride`-th mask pixel (row-major) is kept for the step.
    stride: usize,
    /// Mask pixels seen so far.
    seen: usize,
    /// Per image: the values kept for the step (sorted and deduplicated from time to
    /// time, which leaves the smallest positive difference unchanged), and the length
    /// after the last compaction.
    values: Vec<(Vec<f32>, usize)>,
    /// Per image: smallest and largest finite sample, and how many samples equal the
    /// largest.
    low: Vec<f32>,
    high: Vec<(f32, usize)>,
}

impl Levels {
    /// The levels of the `mask` pixels of `k` images of the mask's size.
    pub fn new(mask: &Mask, k: usize) -> Self {
        Levels {
            mask: mask.clone(),
            stride: mask.count().div_ceil(MAX_STEP_SAMPLES).max(1),
            seen: 0,
            values: vec![(Vec::new(), 0); k],
            low: vec![f32::INFINITY; k],
            high: vec![(f32::NEG_INFINITY, 0); k],
        }
    }

    /// The levels of the whole `stack` at once.
    pub fn of(stack: &ImageStack, mask: &Mask) -> Self {
        let mut l = Levels::new(mask, stack.k);
        l.feed(stack, 0);
        l
    }

    /// Take the rows `row0..row0 + band.height` (bands in order, from the top, without
    /// gaps). A band of another width or K is ignored.
    pub fn feed(&mut self, band: &ImageStack, row0: usize) {
        let w = self.mask.width;
        if band.width != w || band.k != self.values.len() || row0 >= self.mask.height {
            return;
        }
        let rows = band.height.min(self.mask.height - row0);
        for r in 0..rows {
            for c in 0..w {
                if !*self.mask.get(row0 + r, c) {
                    continue;
                }
                let keep = self.seen % self.stride == 0;
                self.seen += 1;
                for (l, &v) in band.pixel(r, c).iter().enumerate() {
                    self.take(l, v, keep);
                }
            }
        }
    }

    fn take(&mut self, l: usize, v: f32, keep: bool) {
        if !v.is_finite() {
            return;
        }
        self.low[l] = self.low[l].min(v);
        let hi = &mut self.high[l];
        if v > hi.0 {
            *hi = (v, 1);
        } else if v == hi.0 {
            hi.1 += 1;
        }
        if keep {
            let (vals, compacted) = &mut self.values[l];
            vals.push(v);
            if vals.len() > 2 * *compacted + 4096 {
                sort_dedup(vals);
                *compacted = vals.len();
            }
        }
    }

    /// The quantisation step Δ (module docs).
    pub fn step(&self) -> f32 {
        let mut per_image: Vec<Vec<f32>> = self.values.iter().map(|(v, _)| v.clone()).collect();
        median_smallest_gap(per_image.iter_mut(), MIN_DISTINCT)
    }

    /// The censoring bounds for quantisation step `step`: the floor of each image is its
    /// smallest sample; an image is clipped when its largest value is taken by at least
    /// 3 samples and 0.1% of the mask (a float render reaches its maximum once).
    pub fn censor(&self, step: f32) -> Censor {
        let half = 0.5 * step;
        let n = self.mask.count();
        let clipped = |c: usize| step > 0.0 && c >= 3 && c * 1000 >= n;
        Censor {
            low: self.low.iter().map(|v| v + half).collect(),
            high: (self.high.iter())
                .map(|&(v, c)| if clipped(c) { v - half } else { f32::INFINITY })
                .collect(),
            step,
        }
    }
}

fn sort_dedup(v: &mut Vec<f32>) {
    v.sort_unstable_by(f32::total_cmp);
    v.dedup();
}

/// The censoring bounds of each image: a sample at its image's floor (the darkest value
/// of the mask: 0, or the black level) says only "at most half a step above the floor",
/// one at its image's clipping level says only "at least this". Samples at or below
/// `low[k]` sit at the floor, samples at or above `high[k]` are clipped.
#[derive(Clone, Debug, PartialEq)]
pub struct Censor {
    /// Per image: floor of the mask's samples plus half a step.
    pub low: Vec<f32>,
    /// Per image: clipping level minus half a step (∞ when nothing is clipped).
    pub high: Vec<f32>,
    /// The quantisation step.
    pub step: f32,
}

impl Censor {
    /// Bounds from the `mask` samples of `stack` with quantisation step `step`
    /// ([`Levels::censor`]).
    pub fn new(stack: &ImageStack, mask: &Mask, step: f32) -> Censor {
        Levels::of(stack, mask).censor(step)
    }

    /// No sample censored (images of K lights).
    pub fn none(k: usize) -> Censor {
        Censor {
            low: vec![f32::NEG_INFINITY; k],
            high: vec![f32::INFINITY; k],
            step: 0.0,
        }
    }

    /// Whether sample `t` of image `l` is censored and the prediction `pred` agrees with
    /// its bound (within a step): it then carries no measurement.
    #[inline]
    pub fn holds(&self, l: usize, t: f32, pred: f32) -> bool {
        (t <= self.low[l] && pred <= self.low[l] + self.step)
            || (t >= self.high[l] && pred >= self.high[l] - self.step)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 8-bit levels ÷ 0.7, a floor of zeros on the left and 5% of the pixels clipped in
    /// image 0.
    fn quantised() -> (ImageStack, Mask) {
        let (w, h, k) = (60, 50, 3);
        let mut s = ImageStack::zeros(w, h, k);
        for r in 0..h {
            for c in 0..w {
                for (l, v) in s.pixel_flat_mut(r * w + c).iter_mut().enumerate() {
                    let x = (c as f32 - 20.0).max(0.0) * (0.02 + 0.001 * (l + r) as f32);
                    let x = if l == 0 { x.min(1.0) } else { x.min(0.99) };
                    *v = (x * 255.0).round() / 255.0 / 0.7;
                }
            }
        }
        (s, Mask::full(w, h))
    }

    #[test]
    fn floor_clipping_and_step_of_quantised_images() {
        let (s, m) = quantised();
        let lv = Levels::of(&s, &m);
        let step = lv.step();
        assert!((step - 1.0 / 255.0 / 0.7).abs() < 1e-6, "{step}");
        let c = lv.censor(step);
        assert_eq!(c.low, vec![0.5 * step; 3]);
        assert!((c.high[0] - (1.0 / 0.7 - 0.5 * step)).abs() < 1e-6, "{c:?}");
        // 0.99 × 255 = 252.45 → 252 is reached by many pixels in images 1 and 2 too:
        // a plateau at the top is clipping, whatever its level
        assert!(c.high[1].is_finite() && c.high[2].is_finite(), "{c:?}");
        assert!(c.holds(0, 0.0, 0.0) && !c.holds(0, 0.0, 3.0 * step));
        assert!(c.holds(0, 1.0 / 0.7, 1.5) && !c.holds(0, 1.0 / 0.7, 1.0));
        assert!(!c.holds(0, 0.5, 0.5));
    }

    #[test]
    fn a_few_valued_image_does_not_measure_the_step() {
        // three flat faces of a 16-bit render: 634 levels between the closest two
        let (w, h) = (30, 10);
        let mut s = ImageStack::zeros(w, h, 1);
        for (i, v) in s.data.iter_mut().enumerate() {
            *v = [906.0, 1540.0, 22371.0][(i % w) / 10] / 65535.0;
        }
        let lv = Levels::of(&s, &Mask::full(w, h));
        assert_eq!(lv.step(), 0.0);
        // no step, so nothing is censored: a face at its image's smallest value measures
        let c = lv.censor(0.0);
        assert!(!c.holds(0, 906.0 / 65535.0, 906.0 / 65535.0 + 1e-3));
        assert!(c.high[0].is_infinite());
    }

    #[test]
    fn bands_give_the_levels_of_the_whole_stack() {
        let (s, m) = quantised();
        let whole = Levels::of(&s, &m);
        for rows in [1, 3, 7, 100] {
            let mut lv = Levels::new(&m, s.k);
            for r0 in (0..s.height).step_by(rows) {
                let r1 = (r0 + rows).min(s.height);
                let band = ImageStack {
                    width: s.width,
                    height: r1 - r0,
                    k: s.k,
                    data: s.data[r0 * s.width * s.k..r1 * s.width * s.k].to_vec(),
                    names: Vec::new(),
                };
                lv.feed(&band, r0);
            }
            assert_eq!(lv.step(), whole.step(), "bands of {rows} rows");
            assert_eq!(lv.censor(0.01), whole.censor(0.01), "bands of {rows} rows");
        }
    }
}
