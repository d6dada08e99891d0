//! What a camera does to the exposed radiance before it is stored: optical blur, a black
//! level, noise, and clipping with quantisation to the sensor's bit depth.
//!
//! Order (that of a real sensor): the lens blurs the exposed radiance e·I (a Gaussian of
//! σ = `blur_sigma` pixels, over each whole image, background included); the black level
//! b is added; Gaussian noise is added; the sum is clipped to [0, 1] (full scale) and
//! rounded to 2^bits − 1 levels. A 0 then says "at most half a step above −b", a 1 says
//! "at least full scale" (censored samples), as in 8-bit captures.
//!
//! The blur is separable, with the image mirrored about its border (half-sample
//! symmetric extension, as the DCT-II): with a symmetric kernel that operator is a
//! symmetric matrix whose rows sum to 1, so its columns do too and the sum of every
//! image is preserved exactly (up to rounding).

use super::random::SplitMix64;
use crate::error::{Error, Result};
use crate::image::ImageStack;
use rayon::prelude::*;

/// How samples are formed from the exposed radiance (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Bits per stored sample: `Some(8)` or `Some(16)` clip every sample to [0, 1]
    /// (full scale) and round it to 2^bits − 1 levels; `None` keeps floats, unclipped.
    pub bits: Option<u32>,
    /// Standard deviation (pixels) of a Gaussian optical blur of every image, applied
    /// before the black level, the noise and the quantisation; 0 = sharp.
    pub blur_sigma: f32,
    /// Offset added to every sample (fraction of full scale, in [0, 1)), before the
    /// noise and the quantisation: the dark level of a real sensor. 0 = none.
    pub black_level: f32,
}

impl Default for Camera {
    /// Float samples, no blur, no black level (the exact radiance).
    fn default() -> Self {
        Camera {
            bits: None,
            blur_sigma: 0.0,
            black_level: 0.0,
        }
    }
}

impl Camera {
    /// Sharp, no black level, samples clipped and rounded to `bits` (8 or 16).
    pub fn quantized(bits: u32) -> Self {
        Camera {
            bits: Some(bits),
            ..Camera::default()
        }
    }

    /// Full-scale levels of the quantisation (255, 65535), `None` for floats.
    pub fn levels(&self) -> Option<f64> {
        self.bits.map(|b| ((1u64 << b) - 1) as f64)
    }

    /// Check the bit depth (8 or 16), the blur (finite, 0 ≤ σ ≤ 100 px) and the black
    /// level (in [0, 1)).
    pub fn validate(&self) -> Result<()> {
        if let Some(b) = self.bits {
            if b != 8 && b != 16 {
                return Err(Error::invalid(
                    format!("camera bit depth {b}"),
                    "use 8 or 16 bits per sample (or float samples)",
                ));
            }
        }
        if !(self.blur_sigma.is_finite() && (0.0..=100.0).contains(&self.blur_sigma)) {
            return Err(Error::invalid(
                format!("camera blur sigma {}", self.blur_sigma),
                "use a blur standard deviation in pixels between 0 and 100",
            ));
        }
        if !(self.black_level.is_finite() && (0.0..1.0).contains(&self.black_level)) {
            return Err(Error::invalid(
                format!("camera black level {}", self.black_level),
                "use a black level between 0 and 1 (fraction of full scale), below 1",
            ));
        }
        Ok(())
    }
}

/// Turn the exposed radiance in `stack` into samples: blur, black level, Gaussian noise
/// of standard deviation `noise_sigma` (one SplitMix64 stream per image row, seeded by
/// `seed`, samples drawn row by row, pixel by pixel, light by light), clipping and
/// quantisation (see the module docs). `stack` and `noise_sigma` are in units of the
/// camera's full scale (1 = the brightest level); `render` calls this on its exposed
/// radiance, and tests use it to put other images through the same camera.
pub fn develop(stack: &mut ImageStack, camera: &Camera, noise_sigma: f32, seed: u64) {
    if camera.blur_sigma > 0.0 {
        blur(stack, camera.blur_sigma);
    }
    let levels = camera.levels();
    let (black, sigma) = (camera.black_level as f64, noise_sigma as f64);
    if black == 0.0 && sigma == 0.0 && levels.is_none() {
        return;
    }
    let row_len = (stack.width * stack.k).max(1);
    stack
        .data
        .par_chunks_mut(row_len)
        .enumerate()
        .for_each(|(r, row)| {
            let mut rng = SplitMix64::for_stream(seed, r as u64);
            for v in row.iter_mut() {
                let mut x = *v as f64 + black;
                if sigma > 0.0 {
                    x += sigma * rng.normal();
                }
                if let Some(l) = levels {
                    x = (x.clamp(0.0, 1.0) * l).round() / l;
                }
                *v = x as f32;
            }
        });
}

/// Normalised Gaussian kernel of standard deviation `sigma`, radius ⌈3σ⌉ (at least 1).
fn kernel(sigma: f32) -> Vec<f64> {
    let radius = (3.0 * sigma as f64).ceil().max(1.0) as usize;
    let s2 = 2.0 * (sigma as f64).powi(2);
    let mut k: Vec<f64> = (0..=2 * radius)
        .map(|i| {
            let d = i as f64 - radius as f64;
            (-d * d / s2).exp()
        })
        .collect();
    let sum: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    k
}

/// Index `i` (any integer) mirrored into 0..n (half-sample symmetric, period 2n).
fn mirror(i: isize, n: usize) -> usize {
    let p = 2 * n as isize;
    let j = i.rem_euclid(p);
    if j < n as isize {
        j as usize
    } else {
        (p - 1 - j) as usize
    }
}

/// Separable Gaussian blur of every image of `stack`, mirrored at the border.
fn blur(stack: &mut ImageStack, sigma: f32) {
    let (w, h, k) = (stack.width, stack.height, stack.k);
    if w == 0 || h == 0 || k == 0 {
        return;
    }
    let ker = kernel(sigma);
    let rad = (ker.len() / 2) as isize;
    // along rows: each row chunk (w·k samples, pixel-major) on its own
    let mut tmp = vec![0f64; w * h * k];
    tmp.par_chunks_mut(w * k)
        .zip(stack.data.par_chunks(w * k))
        .for_each(|(out, row)| {
            for c in 0..w {
                for (t, &kv) in ker.iter().enumerate() {
                    let src = mirror(c as isize + t as isize - rad, w);
                    let (o, s) = (&mut out[c * k..(c + 1) * k], &row[src * k..(src + 1) * k]);
                    o.iter_mut().zip(s).for_each(|(o, s)| *o += kv * *s as f64);
                }
            }
        });
    // along columns, back into the stack
    let tmp = &tmp;
    stack
        .data
        .par_chunks_mut(w * k)
        .enumerate()
        .for_each(|(r, out)| {
            let mut acc = vec![0f64; w * k];
            for (t, &kv) in ker.iter().enumerate() {
                let src = mirror(r as isize + t as isize - rad, h);
                let s = &tmp[src * w * k..(src + 1) * w * k];
                acc.iter_mut().zip(s).for_each(|(a, s)| *a += kv * s);
            }
            out.iter_mut().zip(&acc).for_each(|(o, a)| *o = *a as f32);
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize, k: usize) -> ImageStack {
        let mut s = ImageStack::zeros(w, h, k);
        for (i, v) in s.data.iter_mut().enumerate() {
            *v = ((i * 7919) % 1000) as f32 / 1000.0;
        }
        s
    }

    #[test]
    fn quantisation_rounds_to_the_bit_depth_and_clips() {
        for bits in [8u32, 16] {
            let levels = ((1u64 << bits) - 1) as f32;
            let mut s = ramp(9, 7, 3);
            s.data[0] = 1.7;
            s.data[1] = -0.2;
            let before = s.data.clone();
            develop(&mut s, &Camera::quantized(bits), 0.0, 0);
            assert_eq!(
                (s.data[0], s.data[1]),
                (1.0, 0.0),
                "clipped at full scale and 0"
            );
            for (a, b) in s.data.iter().zip(&before).skip(2) {
                let step = (a * levels).round() / levels;
                assert!((a - step).abs() < 1e-6, "{a} is on a {bits}-bit level");
                assert!(
                    (a - b).abs() <= 0.5 / levels + 1e-6,
                    "{a} vs {b}: within ½ step"
                );
            }
        }
        // one step of 8 bits is 1/255: 0.5/255 + ε rounds up, 0.5/255 − ε down
        let mut s = ImageStack::zeros(2, 1, 1);
        s.data = vec![0.5 / 255.0 + 1e-4, 0.5 / 255.0 - 1e-4];
        develop(&mut s, &Camera::quantized(8), 0.0, 0);
        assert_eq!(s.data, vec![1.0 / 255.0, 0.0]);
    }

    #[test]
    fn blur_preserves_the_sum_and_spreads_a_point() {
        let mut s = ramp(23, 17, 2);
        s.data[8 * 23 * 2] = 30.0; // a bright point at the left border
        let sums = |s: &ImageStack| -> Vec<f64> {
            (0..2)
                .map(|l| s.data.iter().skip(l).step_by(2).map(|v| *v as f64).sum())
                .collect()
        };
        let before = sums(&s);
        blur(&mut s, 2.5);
        for (a, b) in sums(&s).iter().zip(&before) {
            assert!((a - b).abs() < 1e-4 * b, "sum {a} vs {b}");
        }
        // a single point becomes a Gaussian of the given σ: variance σ² along each axis
        let (w, h) = (41, 41);
        let mut p = ImageStack::zeros(w, h, 1);
        p.data[20 * w + 20] = 1.0;
        blur(&mut p, 1.5);
        let var: f64 = (0..w * h)
            .map(|i| p.data[i] as f64 * ((i % w) as f64 - 20.0).powi(2))
            .sum();
        assert!((var - 2.25).abs() < 0.01, "variance {var}");
        assert!(
            (p.data[20 * w + 20] as f64 - 1.0 / (2.0 * std::f64::consts::PI * 2.25)).abs() < 2e-3
        );
    }

    #[test]
    fn black_level_offsets_then_clips() {
        let mut s = ImageStack::zeros(3, 1, 1);
        s.data = vec![0.0, 0.5, 0.99];
        let cam = Camera {
            bits: Some(8),
            black_level: 0.03,
            ..Camera::default()
        };
        develop(&mut s, &cam, 0.0, 0);
        let q = |v: f32| (v * 255.0).round() / 255.0;
        assert_eq!(s.data, vec![q(0.03), q(0.53), 1.0]);
        // float samples: offset only, nothing clipped
        let mut f = ImageStack::zeros(2, 1, 1);
        f.data = vec![0.0, 1.5];
        let cam = Camera {
            black_level: 0.1,
            ..Camera::default()
        };
        develop(&mut f, &cam, 0.0, 0);
        assert_eq!(f.data, vec![0.1, 1.6]);
    }

    #[test]
    fn bad_cameras_are_refused() {
        for cam in [
            Camera::quantized(12),
            Camera {
                blur_sigma: -1.0,
                ..Camera::default()
            },
            Camera {
                black_level: 1.0,
                ..Camera::default()
            },
        ] {
            let e = cam.validate().unwrap_err().to_string();
            assert!(e.contains("camera"), "{e}");
        }
        assert!(Camera::quantized(8).validate().is_ok());
    }
}
