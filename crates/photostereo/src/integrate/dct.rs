//! DCT Poisson integration (Simchony, Chellappa & Shao 1990).
//!
//! Least squares over the edges of the full rectangle (none crosses the border) gives
//! the Neumann graph Laplacian system L z = b with
//! b(r, c) = gx(r, c) − gx(r, c−1) + gy(r, c) − gy(r−1, c), where
//! gx(r, c) = (p(r, c) + p(r, c+1))/2 is the target of z(r, c+1) − z(r, c),
//! gy(r, c) = −(q(r, c) + q(r+1, c))/2 that of z(r+1, c) − z(r, c), and terms of edges
//! outside the rectangle are 0. The 2-D DCT-II diagonalises L with eigenvalues
//! λ = 2cos(πk/W) + 2cos(πl/H) − 4; z = DCT-III(DCT-II(b)/λ), mean fixed by setting the (0, 0) coefficient to 0.
//! The DCTs run through `realfft` (Makhoul's reordering): rows, then blocks of columns
//! kept in cache, then rows back, in parallel and in place (see `fft2` for the passes).

use super::fft2::columns_in_place;
use super::spectrum::{half_angle_terms, inverse_eigenvalue};
use rayon::prelude::*;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::f64::consts::PI;
use std::sync::Arc;

/// DCT-II of length n through one real FFT of the same length (Makhoul 1980):
/// v = (x0, x2, x4, …, x5, x3, x1), X_k = Re(e^{−iπk/2n} · DFT(v)_k). This is the same
/// unnormalised DCT-II as `rustdct` (X_k = Σ x_j cos(πk(2j+1)/2n)), at the cost of the
/// AVX real FFT, i.e. the FFT floor.
struct Dct {
    n: usize,
    r2c: Arc<dyn RealToComplex<f32>>,
    c2r: Arc<dyn ComplexToReal<f32>>,
    /// e^{−iπk/2n}, k = 0 ..= n/2.
    twiddle: Vec<Complex<f32>>,
}

/// Per-thread buffers of a [`Dct`].
struct Buffers {
    v: Vec<f32>,
    spec: Vec<Complex<f32>>,
    scratch: Vec<Complex<f32>>,
}

impl Dct {
    fn new(n: usize) -> Self {
        let mut planner = RealFftPlanner::<f32>::new();
        let twiddle = (0..=n / 2)
            .map(|k| {
                let a = -PI * k as f64 / (2.0 * n as f64);
                Complex::new(a.cos() as f32, a.sin() as f32)
            })
            .collect();
        Dct {
            n,
            r2c: planner.plan_fft_forward(n),
            c2r: planner.plan_fft_inverse(n),
            twiddle,
        }
    }

    fn buffers(&self) -> Buffers {
        let len = self.r2c.get_scratch_len().max(self.c2r.get_scratch_len());
        Buffers {
            v: vec![0.0; self.n],
            spec: vec![Complex::default(); self.n / 2 + 1],
            scratch: vec![Complex::default(); len],
        }
    }

    /// In-place unnormalised DCT-II.
    fn forward(&self, x: &mut [f32], b: &mut Buffers) {
        let n = self.n;
        self.permuted_spectrum(x, b);
        for k in 0..=n / 2 {
            let y = self.twiddle[k] * b.spec[k];
            x[k] = y.re;
            if k > 0 && n - k > n / 2 {
                // X_{n−k} = −Im(e^{−iπk/2n} V_k).
                x[n - k] = -y.im;
            }
        }
    }

    /// In-place exact inverse of [`Dct::forward`] (a DCT-III scaled by 2/n).
    fn inverse(&self, x: &mut [f32], b: &mut Buffers) {
        let n = self.n;
        // V_k = e^{iπk/2n} (X_k − i X_{n−k}), X_n := 0.
        for k in 0..=n / 2 {
            let xr = x[k];
            let xi = if k == 0 { 0.0 } else { x[n - k] };
            b.spec[k] = self.twiddle[k].conj() * Complex::new(xr, -xi);
        }
        self.finish_inverse(x, b);
    }

    /// In place, `inverse(G ⊙ forward(x))` for a gain G(k) per DCT coefficient, without
    /// forming the coefficients: with Y_k = e^{−iπk/2n} V_k (so X_k = Re Y_k and
    /// X_{n−k} = −Im Y_k), the filtered spectrum is V'_k = e^{iπk/2n}(G(k) Re Y_k +
    /// i G(n−k) Im Y_k). One real FFT each way, like `forward` then `inverse`.
    fn filter(&self, x: &mut [f32], gain: impl Fn(usize) -> f32, b: &mut Buffers) {
        let n = self.n;
        self.permuted_spectrum(x, b);
        for (k, (v, t)) in b.spec.iter_mut().zip(&self.twiddle).enumerate() {
            let y = *t * *v;
            let re = y.re * gain(k);
            let im = if k == 0 {
                0.0
            } else if n - k > n / 2 {
                y.im * gain(n - k)
            } else {
                // k = n/2 of an even n: X_{n/2} is its own partner (see `inverse`).
                -re
            };
            *v = t.conj() * Complex::new(re, im);
        }
        self.finish_inverse(x, b);
    }

    /// V = DFT(v) into `b.spec`, v = (x0, x2, x4, …, x5, x3, x1) (Makhoul's reordering).
    fn permuted_spectrum(&self, x: &[f32], b: &mut Buffers) {
        let n = self.n;
        for j in 0..n.div_ceil(2) {
            b.v[j] = x[2 * j];
        }
        for j in 0..n / 2 {
            b.v[n - 1 - j] = x[2 * j + 1];
        }
        let res = self
            .r2c
            .process_with_scratch(&mut b.v, &mut b.spec, &mut b.scratch);
        debug_assert!(res.is_ok());
    }

    /// The end of an inverse: spectrum in `b.spec` → real FFT → undo the reordering
    /// into x, scaled by 1/n.
    fn finish_inverse(&self, x: &mut [f32], b: &mut Buffers) {
        let n = self.n;
        b.spec[0].im = 0.0;
        if n % 2 == 0 {
            b.spec[n / 2].im = 0.0;
        }
        let res = self
            .c2r
            .process_with_scratch(&mut b.spec, &mut b.v, &mut b.scratch);
        debug_assert!(res.is_ok());
        let scale = 1.0 / n as f32;
        for j in 0..n.div_ceil(2) {
            x[2 * j] = b.v[j] * scale;
        }
        for j in 0..n / 2 {
            x[2 * j + 1] = b.v[n - 1 - j] * scale;
        }
    }
}

/// Solve the Neumann Poisson problem on the W × H rectangle; arbitrary offset.
pub(crate) fn integrate(p: &[f32], q: &[f32], w: usize, h: usize) -> Vec<f32> {
    solve_neumann(w, h, |r, row| neumann_divergence_row(p, q, w, h, r, row))
}

/// The Neumann divergence b of the module documentation on the whole grid.
pub(crate) fn neumann_divergence(p: &[f32], q: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut b = vec![0.0f32; w * h];
    b.par_chunks_mut(w)
        .enumerate()
        .for_each(|(r, row)| neumann_divergence_row(p, q, w, h, r, row));
    b
}

/// Row r of the Neumann divergence: b(r, c) = gx(r, c) − gx(r, c−1) + gy(r, c) − gy(r−1, c),
/// terms of edges outside the rectangle left out. With the trapezoidal targets the
/// interior terms telescope to central differences, which are computed with zipped
/// slices so that the loops vectorise.
fn neumann_divergence_row(p: &[f32], q: &[f32], w: usize, h: usize, r: usize, row: &mut [f32]) {
    let pr = &p[r * w..][..w];
    // Horizontal edges: gx(c) − gx(c−1) = (p(c+1) − p(c−1))/2 inside, one edge at the ends.
    if w == 1 {
        row[0] = 0.0;
    } else {
        row[0] = 0.5 * (pr[0] + pr[1]);
        row[w - 1] = -0.5 * (pr[w - 2] + pr[w - 1]);
        for (v, (a, b)) in row[1..w - 1]
            .iter_mut()
            .zip(pr[2..].iter().zip(&pr[..w - 2]))
        {
            *v = 0.5 * (a - b);
        }
    }
    // Vertical edges: gy(r) − gy(r−1) with gy(r) = −(q(r) + q(r+1))/2, i.e.
    // (q(r−1) − q(r+1))/2 inside, one edge on the first and last rows.
    let at = |rr: usize| &q[rr * w..][..w];
    match (r > 0, r + 1 < h) {
        (true, true) => {
            for (v, (a, b)) in row.iter_mut().zip(at(r - 1).iter().zip(at(r + 1))) {
                *v += 0.5 * (a - b);
            }
        }
        (false, true) => {
            for (v, (a, b)) in row.iter_mut().zip(at(r).iter().zip(at(r + 1))) {
                *v -= 0.5 * (a + b);
            }
        }
        (true, false) => {
            for (v, (a, b)) in row.iter_mut().zip(at(r - 1).iter().zip(at(r))) {
                *v += 0.5 * (a + b);
            }
        }
        (false, false) => {}
    }
}

/// Solve L z = b (Neumann Laplacian of the W × H grid) with 2-D DCTs; `fill_row(r, row)`
/// writes row r of b. Rows are transformed in parallel, then blocks of columns (forward,
/// divide by λ, inverse, in cache), then rows back; see [`super::fft2`] for the passes.
fn solve_neumann(w: usize, h: usize, fill_row: impl Fn(usize, &mut [f32]) + Sync) -> Vec<f32> {
    let (dw, dh) = (Dct::new(w), Dct::new(h));
    let mut b = vec![0.0f32; w * h];
    b.par_chunks_mut(w).enumerate().for_each_init(
        || dw.buffers(),
        |buf, (r, row)| {
            fill_row(r, row);
            dw.forward(row, buf);
        },
    );
    // λ = 2cos(πk/W) + 2cos(πl/H) − 4 = −(s_k + s_l), s_k = 4 sin²(πk/2W) (no
    // cancellation at low frequencies, see `fourier`).
    let s_c = half_angle_terms(w, w, 2.0);
    let s_r = half_angle_terms(h, h, 2.0);
    columns_in_place(
        &mut b,
        w,
        h,
        || dh.buffers(),
        |k, col, buf| {
            let s_k = s_c[k];
            dh.filter(col, |l| inverse_eigenvalue(s_k, s_r[l]), buf);
        },
    );
    b.par_chunks_mut(w)
        .for_each_init(|| dw.buffers(), |buf, row| dw.inverse(row, buf));
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn makhoul_dct_matches_the_definition_and_inverts() {
        for n in [1usize, 2, 5, 8, 13, 64] {
            let x: Vec<f32> = (0..n).map(|j| ((j * 37 % 11) as f32 - 5.0) * 0.3).collect();
            let dct = Dct::new(n);
            let mut buf = dct.buffers();
            let mut y = x.clone();
            dct.forward(&mut y, &mut buf);
            for (k, &yk) in y.iter().enumerate() {
                let want: f64 = (0..n)
                    .map(|j| {
                        x[j] as f64 * (PI * k as f64 * (2 * j + 1) as f64 / (2 * n) as f64).cos()
                    })
                    .sum();
                assert!(
                    (yk as f64 - want).abs() < 1e-4,
                    "n={n} k={k}: {yk} vs {want}"
                );
            }
            let coefficients = y.clone();
            dct.inverse(&mut y, &mut buf);
            for (a, b) in x.iter().zip(&y) {
                assert!((a - b).abs() < 1e-5, "n={n}: {a} vs {b}");
            }
            // The fused filter equals forward, scale each coefficient, inverse.
            let gain = |k: usize| 1.0 / (1.0 + k as f32);
            let mut want: Vec<f32> = coefficients
                .iter()
                .enumerate()
                .map(|(k, c)| c * gain(k))
                .collect();
            dct.inverse(&mut want, &mut buf);
            let mut got = x.clone();
            dct.filter(&mut got, gain, &mut buf);
            for (a, b) in want.iter().zip(&got) {
                assert!((a - b).abs() < 1e-5, "n={n}: filter {b} vs {a}");
            }
        }
    }
}
