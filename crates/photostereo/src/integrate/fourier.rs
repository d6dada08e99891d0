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
use super::spectrum::{half_angle_terms, inverse_eigenvalue};
use crate::error::Result;

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
        return Ok(solve_periodic(w, h, |r, row| {
            divergence_row(p, q, w, h, r, row)
        }));
    }
    // Mirror about the right and bottom edges (p odd across a vertical edge, q across a
    // horizontal one). The periodic divergence of the mirrored field is the mirror image
    // of the Neumann divergence of the original one, so build that directly.
    let (we, he) = (2 * w, 2 * h);
    let b = super::dct::neumann_divergence(p, q, w, h);
    let z = solve_periodic(we, he, |r, row| {
        let src = &b[(if r < h { r } else { he - 1 - r }) * w..][..w];
        row[..w].copy_from_slice(src);
        row[w..]
            .iter_mut()
            .zip(src.iter().rev())
            .for_each(|(d, s)| *d = *s);
    });
    let mut out = Vec::with_capacity(w * h);
    for r in 0..h {
        out.extend_from_slice(&z[r * we..r * we + w]);
    }
    Ok(out)
}

/// Row r of the periodic divergence of the trapezoidal edge targets: central
/// differences of p along rows and of −q along columns, wrapping around.
fn divergence_row(p: &[f32], q: &[f32], w: usize, h: usize, r: usize, row: &mut [f32]) {
    let up = &q[(if r == 0 { h - 1 } else { r - 1 }) * w..][..w];
    let down = &q[(if r + 1 == h { 0 } else { r + 1 }) * w..][..w];
    let pr = &p[r * w..][..w];
    if w < 3 {
        for (c, v) in row.iter_mut().enumerate() {
            let left = pr[if c == 0 { w - 1 } else { c - 1 }];
            let right = pr[if c + 1 == w { 0 } else { c + 1 }];
            *v = 0.5 * ((right - left) - (down[c] - up[c]));
        }
        return;
    }
    // Interior columns through zipped slices (no index checks), so that it vectorises.
    let (inner, ahead, behind) = (&mut row[1..w - 1], &pr[2..], &pr[..w - 2]);
    let vertical = down[1..w - 1].iter().zip(&up[1..w - 1]);
    for ((v, (a, b)), (d, u)) in inner.iter_mut().zip(ahead.iter().zip(behind)).zip(vertical) {
        *v = 0.5 * ((a - b) - (d - u));
    }
    row[0] = 0.5 * ((pr[1] - pr[w - 1]) - (down[0] - up[0]));
    row[w - 1] = 0.5 * ((pr[0] - pr[w - 2]) - (down[w - 1] - up[w - 1]));
}

/// Solve L z = div on the periodic W × H grid by FFT; `fill_row(r, row)` writes row r
/// of the divergence.
fn solve_periodic(w: usize, h: usize, fill_row: impl Fn(usize, &mut [f32]) + Sync) -> Vec<f32> {
    let fft = Fft2::new(w, h);
    // λ = 2cos(2πk/W) + 2cos(2πl/H) − 4 = −(s_k + s_l) with s_k = 4 sin²(πk/W): a sum
    // of two non-negative terms, accurate in f32 even at the lowest frequencies (the
    // cosine form cancels there).
    let s_c = half_angle_terms(fft.wc(), w, 1.0);
    let s_r = half_angle_terms(h, h, 1.0);
    fft.filter(fill_row, |k, l| inverse_eigenvalue(s_c[k], s_r[l]))
}
