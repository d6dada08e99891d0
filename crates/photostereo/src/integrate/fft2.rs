//! 2-D real FFT on a row-major `f32` grid: real-to-complex FFTs of the rows (`realfft`),
//! a parallel transpose, complex FFTs of the columns (`rustfft`), all rows processed in
//! parallel with `rayon`. The spectrum is kept transposed: row k holds column frequency
//! k (0 ..= W/2) for every row frequency l (0 .. H).

use super::support::transpose;
use crate::image::{GrayImage, Image};
use rayon::prelude::*;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Plans of a W × H real 2-D FFT.
pub(crate) struct Fft2 {
    w: usize,
    h: usize,
    r2c: Arc<dyn RealToComplex<f32>>,
    c2r: Arc<dyn ComplexToReal<f32>>,
    col_fwd: Arc<dyn Fft<f32>>,
    col_inv: Arc<dyn Fft<f32>>,
}

impl Fft2 {
    /// Plan a transform of `w` columns by `h` rows.
    pub fn new(w: usize, h: usize) -> Self {
        let mut real = RealFftPlanner::<f32>::new();
        let mut cplx = FftPlanner::<f32>::new();
        Fft2 {
            w,
            h,
            r2c: real.plan_fft_forward(w),
            c2r: real.plan_fft_inverse(w),
            col_fwd: cplx.plan_fft_forward(h),
            col_inv: cplx.plan_fft_inverse(h),
        }
    }

    /// Number of column frequencies, W/2 + 1.
    pub fn wc(&self) -> usize {
        self.w / 2 + 1
    }

    /// Forward transform (unnormalised); `data` is used as scratch. Returns the
    /// transposed spectrum, `wc()` rows of `h` values.
    pub fn forward(&self, data: &mut [f32]) -> Vec<Complex<f32>> {
        let (w, h, wc) = (self.w, self.h, self.wc());
        let mut rows = vec![Complex::default(); wc * h];
        rows.par_chunks_mut(wc)
            .zip(data.par_chunks_mut(w))
            .for_each_init(
                || self.r2c.make_scratch_vec(),
                |scratch, (out, inp)| {
                    let res = self.r2c.process_with_scratch(inp, out, scratch);
                    debug_assert!(res.is_ok());
                },
            );
        let mut cols = transpose(&rows, h, wc);
        drop(rows);
        let len = self.col_fwd.get_inplace_scratch_len();
        cols.par_chunks_mut(h).for_each_init(
            || vec![Complex::default(); len],
            |scratch, col| self.col_fwd.process_with_scratch(col, scratch),
        );
        cols
    }

    /// Inverse of [`Fft2::forward`], normalised (forward then inverse is the identity).
    pub fn inverse(&self, spec: &mut [Complex<f32>]) -> Vec<f32> {
        let (w, h, wc) = (self.w, self.h, self.wc());
        let len = self.col_inv.get_inplace_scratch_len();
        spec.par_chunks_mut(h).for_each_init(
            || vec![Complex::default(); len],
            |scratch, col| self.col_inv.process_with_scratch(col, scratch),
        );
        let mut rows = transpose(spec, wc, h);
        let scale = 1.0 / (w * h) as f32;
        let mut out = vec![0.0f32; w * h];
        out.par_chunks_mut(w)
            .zip(rows.par_chunks_mut(wc))
            .for_each_init(
                || self.c2r.make_scratch_vec(),
                |scratch, (o, inp)| {
                    // The DC (and Nyquist) bins of a real signal are real; drop round-off.
                    inp[0].im = 0.0;
                    if w % 2 == 0 {
                        inp[wc - 1].im = 0.0;
                    }
                    let res = self.c2r.process_with_scratch(inp, o, scratch);
                    debug_assert!(res.is_ok());
                    o.iter_mut().for_each(|v| *v *= scale);
                },
            );
        out
    }
}

/// The FFT floor of the benchmarks: one forward and one inverse 2-D real FFT of the
/// image with the same code the Fourier integrator uses. Returns the round trip
/// (equal to the input up to `f32` round-off).
pub fn fft_floor(image: &GrayImage) -> GrayImage {
    let fft = Fft2::new(image.width, image.height);
    let mut data = image.data.clone();
    let mut spec = fft.forward(&mut data);
    Image {
        width: image.width,
        height: image.height,
        data: fft.inverse(&mut spec),
    }
}
