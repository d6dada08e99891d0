//! Separable 2-D spectral filters on a row-major `f32` grid, without a global transpose.
//!
//! Both Fourier integrators need z = T⁻¹(G · T(b)) for a separable transform T (the 2-D
//! real DFT for Frankot–Chellappa, the 2-D DCT-II for DCT Poisson) and a per-frequency
//! gain G. Instead of transforming rows, transposing the whole grid, transforming
//! columns, filtering, and undoing it all, the work is done in three passes:
//!
//! 1. **rows forward**: every row is produced (e.g. the divergence of that row) and
//!    transformed along x, in parallel;
//! 2. **columns**: blocks of [`BLOCK_BYTES`] worth of adjacent columns are gathered into
//!    a small column-major buffer that stays in cache, transformed along y, multiplied
//!    by G, transformed back along y, and written back in place;
//! 3. **rows inverse**: every row is transformed back along x into the output.
//!
//! Each element is read and written once per pass, all in parallel (`rayon`), the y
//! transforms of a column block run back to back on data already in cache, and no
//! grid-sized buffer is allocated besides the spectrum and the output (fresh pages
//! cost a page fault each, which is a measurable share of a 2048² solve). The
//! real-to-complex row transforms use `realfft`, the column transforms `rustfft`
//! (AVX kernels where the CPU has them).

use crate::image::{GrayImage, Image};
use bytemuck::{zeroed_vec, Zeroable};
use rayon::prelude::*;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Bytes of one column block per row: 256 bytes = four cache lines (32 complex or 64
/// real columns). Rows of a large grid lie in different pages, where the hardware
/// prefetcher stops, so each row visit should read several whole lines; the gathered
/// block (256 B × H, 512 KiB at H = 2048) still fits in L2. 128 to 512 measured alike.
const BLOCK_BYTES: usize = 256;

/// Columns per block for elements of type `T`.
fn block_cols<T>() -> usize {
    (BLOCK_BYTES / std::mem::size_of::<T>()).max(1)
}

/// Padding between the columns of a gathered block, in bytes. Without it a column of
/// 2^n values is a multiple of 4 KiB long, all columns of the block map to the same
/// L1 cache set, and gathering (one value per column per row) thrashes that set.
const PAD_BYTES: usize = 64;

/// The column pass shared by both filters, in place. `data` is row-major with `cols`
/// columns and `h` rows. Blocks of adjacent columns are gathered into a small buffer
/// that stays in cache; `process(c, column, state)` receives each column c (`h`
/// contiguous values) and transforms it in place; the result is written back.
pub(crate) fn columns_in_place<T, S>(
    data: &mut [T],
    cols: usize,
    h: usize,
    init: impl Fn() -> S + Sync + Send,
    process: impl Fn(usize, &mut [T], &mut S) + Sync + Send,
) where
    T: Zeroable + Copy + Send + Sync,
{
    if cols == 0 || h == 0 {
        return;
    }
    let b = block_cols::<T>();
    let stride = h + (PAD_BYTES / std::mem::size_of::<T>()).max(1);
    // Split every row into its block segments, and hand each block's segments (one per
    // row) to one task: disjoint mutable borrows, no unsafe code needed.
    let mut blocks: Vec<Vec<&mut [T]>> = (0..cols.div_ceil(b))
        .map(|_| Vec::with_capacity(h))
        .collect();
    for row in data.chunks_exact_mut(cols).take(h) {
        for (segs, seg) in blocks.iter_mut().zip(row.chunks_mut(b)) {
            segs.push(seg);
        }
    }
    blocks.into_par_iter().enumerate().for_each_init(
        || (zeroed_vec::<T>(b * stride), init()),
        |(buf, state), (j, mut segs)| {
            let bw = segs[0].len();
            for (r, seg) in segs.iter().enumerate() {
                for (c, &v) in seg.iter().enumerate() {
                    buf[c * stride + r] = v;
                }
            }
            for (c, column) in buf.chunks_exact_mut(stride).take(bw).enumerate() {
                process(j * b + c, &mut column[..h], state);
            }
            for (r, seg) in segs.iter_mut().enumerate() {
                for (c, d) in seg.iter_mut().enumerate() {
                    *d = buf[c * stride + r];
                }
            }
        },
    );
}

/// Plans of a W × H real 2-D DFT filter.
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

    /// z = IDFT(G · DFT(b)) on the periodic W × H grid, where `fill_row(r, row)` writes
    /// row r of b and `gain(k, l)` is G at column frequency k (0 ..= W/2) and row
    /// frequency l (0 .. H). G must be the gain of a real filter (G(k, l) = G(k, −l)
    /// where both are stored, as for any function of cos(2πl/H)).
    pub fn filter(
        &self,
        fill_row: impl Fn(usize, &mut [f32]) + Sync,
        gain: impl Fn(usize, usize) -> f32 + Sync,
    ) -> Vec<f32> {
        let (w, h, wc) = (self.w, self.h, self.wc());
        let mut spec = zeroed_vec::<Complex<f32>>(wc * h);
        spec.par_chunks_mut(wc).enumerate().for_each_init(
            || (vec![0.0f32; w], self.r2c.make_scratch_vec()),
            |(row, scratch), (r, out)| {
                fill_row(r, row);
                let res = self.r2c.process_with_scratch(row, out, scratch);
                debug_assert!(res.is_ok());
            },
        );
        let scale = 1.0 / (w * h) as f32;
        let scratch_len = self
            .col_fwd
            .get_inplace_scratch_len()
            .max(self.col_inv.get_inplace_scratch_len());
        columns_in_place(
            &mut spec,
            wc,
            h,
            || vec![Complex::default(); scratch_len],
            |k, col, scratch| {
                self.col_fwd.process_with_scratch(col, scratch);
                for (l, v) in col.iter_mut().enumerate() {
                    *v *= gain(k, l) * scale;
                }
                self.col_inv.process_with_scratch(col, scratch);
            },
        );
        let mut out = vec![0.0f32; w * h];
        out.par_chunks_mut(w)
            .zip(spec.par_chunks_mut(wc))
            .for_each_init(
                || self.c2r.make_scratch_vec(),
                |scratch, (o, row)| {
                    // The DC (and Nyquist) bins of a real signal are real; drop round-off.
                    row[0].im = 0.0;
                    if w % 2 == 0 {
                        row[wc - 1].im = 0.0;
                    }
                    let res = self.c2r.process_with_scratch(row, o, scratch);
                    debug_assert!(res.is_ok());
                },
            );
        out
    }
}

/// The FFT floor of the benchmarks: one forward and one inverse 2-D real FFT of the
/// image, with the same code (and the same passes) the Fourier integrator uses, and a
/// gain of 1. Returns the round trip (equal to the input up to `f32` round-off).
pub fn fft_floor(image: &GrayImage) -> GrayImage {
    let (w, h) = (image.width, image.height);
    let fft = Fft2::new(w, h);
    let data = fft.filter(
        |r, row| row.copy_from_slice(&image.data[r * w..(r + 1) * w]),
        |_, _| 1.0,
    );
    Image {
        width: w,
        height: h,
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn column_pass_sees_whole_columns_and_writes_back_any_shape() {
        for (cols, h) in [(1usize, 1usize), (3, 5), (32, 2), (33, 3), (70, 7)] {
            let mut data: Vec<f32> = (0..cols * h).map(|i| i as f32).collect();
            columns_in_place(
                &mut data,
                cols,
                h,
                || (),
                |c, col, _| {
                    // Each column arrives whole and contiguous: check it, then add 0.5.
                    assert_eq!(col.len(), h);
                    for (r, v) in col.iter_mut().enumerate() {
                        assert_eq!(*v, (r * cols + c) as f32);
                        *v += 0.5;
                    }
                },
            );
            for (i, v) in data.iter().enumerate() {
                assert_eq!(*v, i as f32 + 0.5);
            }
        }
    }

    #[test]
    fn gain_one_is_the_identity_and_a_blur_gain_averages_neighbours() {
        let (w, h) = (12usize, 10usize);
        let x: Vec<f32> = (0..w * h).map(|i| ((i * 7919) % 13) as f32).collect();
        let fft = Fft2::new(w, h);
        let fill = |r: usize, row: &mut [f32]| row.copy_from_slice(&x[r * w..(r + 1) * w]);
        let same = fft.filter(fill, |_, _| 1.0);
        for (a, b) in x.iter().zip(&same) {
            assert!((a - b).abs() < 1e-4, "{a} vs {b}");
        }
        // A real, even gain: the 4-neighbour average (a periodic blur).
        let pi2 = 2.0 * std::f64::consts::PI;
        let blur = fft.filter(fill, |k, l| {
            (0.5 * ((pi2 * k as f64 / w as f64).cos() + (pi2 * l as f64 / h as f64).cos())) as f32
        });
        for r in 0..h {
            for c in 0..w {
                let at = |rr: usize, cc: usize| x[(rr % h) * w + cc % w];
                let want =
                    0.25 * (at(r, c + 1) + at(r, c + w - 1) + at(r + 1, c) + at(r + h - 1, c));
                assert!((blur[r * w + c] - want).abs() < 1e-4, "({r},{c})");
            }
        }
    }
}
