//! Frankot–Chellappa integration on the periodic pixel grid, optionally on the
//! mirrored (2W × 2H) gradient field.
//!
//! Least squares over all edges of the periodic grid gives L z = div g with
//! div g(r, c) = (p(r, c+1) − p(r, c−1))/2 − (q(r+1, c) − q(r−1, c))/2 (indices modulo
//! the size), the divergence of the trapezoidal edge targets. The 2-D DFT diagonalises
//! the periodic Laplacian L with eigenvalues λ = 2cos(2πk/W) + 2cos(2πl/H) − 4, so
//! Z = DFT(div g)/λ and Z(0, 0) := 0. For small frequencies this is the textbook
//! Z = (−iω_c P + iω_r Q)/(ω_c² + ω_r²) in our conventions (see [`super::Method`]).

use super::fft2::Fft2;
use crate::error::Result;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Solve on the periodic grid (or on its mirror image when `reflect`); returns the
/// W × H depth (arbitrary offset).
pub(crate) fn integrate(
    p: &[f32],
    q: &[f32],
    w: usize,
    h: usize,
    reflect: bool,
) -> Result<Vec<f32>> {
    if !reflect {
        return Ok(solve_periodic(divergence(p, q, w, h), w, h));
    }
    // Mirror about the right and bottom edges (p odd across a vertical edge, q across a
    // horizontal one). The periodic divergence of the mirrored field is the mirror image
    // of the Neumann divergence of the original one, so build that directly.
    let (we, he) = (2 * w, 2 * h);
    let b = super::dct::neumann_divergence(p, q, w, h);
    let mut div = vec![0.0f32; we * he];
    div.par_chunks_mut(we).enumerate().for_each(|(r, row)| {
        let src = &b[(if r < h { r } else { he - 1 - r }) * w..][..w];
        row[..w].copy_from_slice(src);
        row[w..]
            .iter_mut()
            .zip(src.iter().rev())
            .for_each(|(d, s)| *d = *s);
    });
    let z = solve_periodic(div, we, he);
    let mut out = Vec::with_capacity(w * h);
    for r in 0..h {
        out.extend_from_slice(&z[r * we..r * we + w]);
    }
    Ok(out)
}

/// Periodic divergence of the trapezoidal edge targets: central differences of p along
/// rows and of −q along columns, wrapping around.
fn divergence(p: &[f32], q: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut div = vec![0.0f32; w * h];
    div.par_chunks_mut(w).enumerate().for_each(|(r, row)| {
        let up = &q[(if r == 0 { h - 1 } else { r - 1 }) * w..][..w];
        let down = &q[(if r + 1 == h { 0 } else { r + 1 }) * w..][..w];
        let pr = &p[r * w..][..w];
        for (c, v) in row.iter_mut().enumerate() {
            let left = pr[if c == 0 { w - 1 } else { c - 1 }];
            let right = pr[if c + 1 == w { 0 } else { c + 1 }];
            *v = 0.5 * ((right - left) - (down[c] - up[c]));
        }
    });
    div
}

/// Solve L z = div on the periodic W × H grid by FFT.
fn solve_periodic(mut div: Vec<f32>, w: usize, h: usize) -> Vec<f32> {
    let fft = Fft2::new(w, h);
    let mut spec = fft.forward(&mut div);
    drop(div);
    let cos_r: Vec<f64> = (0..h)
        .map(|l| 2.0 * (2.0 * PI * l as f64 / h as f64).cos())
        .collect();
    spec.par_chunks_mut(h).enumerate().for_each(|(k, col)| {
        let ck = 2.0 * (2.0 * PI * k as f64 / w as f64).cos() - 4.0;
        for (l, v) in col.iter_mut().enumerate() {
            let lambda = ck + cos_r[l];
            *v = if lambda.abs() < 1e-12 {
                Default::default()
            } else {
                *v * (1.0 / lambda) as f32
            };
        }
    });
    fft.inverse(&mut spec)
}
