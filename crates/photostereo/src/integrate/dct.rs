//! DCT Poisson integration (Simchony, Chellappa & Shao 1990).
//!
//! Least squares over the edges of the full rectangle (none crosses the border) gives
//! the Neumann graph Laplacian system L z = b with
//! b(r, c) = gx(r, c) − gx(r, c−1) + gy(r, c) − gy(r−1, c), where
//! gx(r, c) = (p(r, c) + p(r, c+1))/2 is the target of z(r, c+1) − z(r, c),
//! gy(r, c) = −(q(r, c) + q(r+1, c))/2 that of z(r+1, c) − z(r, c), and terms of edges
//! outside the rectangle are 0. The 2-D DCT-II diagonalises L with eigenvalues
//! λ = 2cos(πk/W) + 2cos(πl/H) − 4; z = DCT-III(DCT-II(b)/λ), mean fixed by setting the (0, 0) coefficient to 0.
//! The DCTs run through `realfft` (Makhoul's reordering), rows then columns, in parallel.

use super::support::transpose;
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
    let b = neumann_divergence(p, q, w, h);
    solve_neumann(b, w, h)
}

pub(crate) fn neumann_divergence(p: &[f32], q: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut b = vec![0.0f32; w * h];
    b.par_chunks_mut(w).enumerate().for_each(|(r, row)| {
        let gx = |c: usize| 0.5 * (p[r * w + c] + p[r * w + c + 1]);
        for (c, v) in row.iter_mut().enumerate() {
            let gy = |rr: usize| -0.5 * (q[rr * w + c] + q[(rr + 1) * w + c]);
            let mut s = 0.0;
            if c + 1 < w {
                s += gx(c);
            }
            if c > 0 {
                s -= gx(c - 1);
            }
            if r + 1 < h {
                s += gy(r);
            }
            if r > 0 {
                s -= gy(r - 1);
            }
            *v = s;
        }
    });
    b
}

/// Apply the forward or inverse DCT to every row of length `dct.n`, in parallel.
fn rows(data: &mut [f32], dct: &Dct, forward: bool) {
    data.par_chunks_mut(dct.n).for_each_init(
        || dct.buffers(),
        |buf, row| {
            if forward {
                dct.forward(row, buf);
            } else {
                dct.inverse(row, buf);
            }
        },
    );
}

/// Solve L z = b (Neumann Laplacian of the W × H grid) with 2-D DCTs.
pub(crate) fn solve_neumann(mut b: Vec<f32>, w: usize, h: usize) -> Vec<f32> {
    let (dw, dh) = (Dct::new(w), Dct::new(h));
    rows(&mut b, &dw, true);
    let mut t = transpose(&b, h, w);
    drop(b);
    rows(&mut t, &dh, true);
    let cos_r: Vec<f64> = (0..h)
        .map(|l| 2.0 * (PI * l as f64 / h as f64).cos())
        .collect();
    t.par_chunks_mut(h).enumerate().for_each(|(k, col)| {
        let ck = 2.0 * (PI * k as f64 / w as f64).cos() - 4.0;
        for (l, v) in col.iter_mut().enumerate() {
            *v = if k == 0 && l == 0 {
                0.0
            } else {
                (*v as f64 / (ck + cos_r[l])) as f32
            };
        }
    });
    rows(&mut t, &dh, false);
    let mut z = transpose(&t, w, h);
    drop(t);
    rows(&mut z, &dw, false);
    z
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
            dct.inverse(&mut y, &mut buf);
            for (a, b) in x.iter().zip(&y) {
                assert!((a - b).abs() < 1e-5, "n={n}: {a} vs {b}");
            }
        }
    }
}
