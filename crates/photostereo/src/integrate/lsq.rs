//! Masked least-squares integration with a sparse Cholesky factorisation.
//!
//! Unknowns: the depth of the N pixels inside the mask. Edges: pairs of 4-neighbours
//! both inside the mask, e = (i, j) with j right of or below i, target g_e from the
//! trapezoidal rule (module documentation of [`super`]) and weight
//! w_e = (w_i + w_j)/2. Minimising Σ w_e (z_j − z_i − g_e)² gives
//!
//! L z = b,  L = Σ_e w_e (e_j − e_i)(e_j − e_i)ᵀ,  b = Σ_e w_e g_e (e_j − e_i),
//!
//! a weighted graph Laplacian, singular once per connected part (the free offset).
//! Adding 1 to the diagonal of one pixel per part (the first in raster order) makes it
//! positive definite without changing the edge residuals: the optimum simply puts that
//! pixel at 0. The matrix (lower triangle, built directly in compressed-column form) is
//! factorised by `faer`'s supernodal sparse Cholesky with an AMD ordering, in f64.

use super::support::Components;
use crate::error::{Error, Result};
use crate::image::{GrayImage, Mask};
use crate::progress::Progress;
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{MatMut, Side};

const NONE: usize = usize::MAX;

/// Pixel weights: 1 without a map, otherwise sanitised and floored.
fn pixel_weights(weights: Option<&GrayImage>, mask: &Mask) -> Vec<f64> {
    let Some(wm) = weights else {
        return vec![1.0; mask.len()];
    };
    let clean = |v: f32| {
        if v.is_finite() && v > 0.0 {
            v as f64
        } else {
            0.0
        }
    };
    let max = wm
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(_, &m)| m)
        .map(|(&v, _)| clean(v))
        .fold(0.0, f64::max);
    let floor = if max > 0.0 { 1e-4 * max } else { 1.0 };
    wm.data.iter().map(|&v| clean(v).max(floor)).collect()
}

/// Solve the masked problem; returns depth on the whole grid (0 outside the mask).
pub(crate) fn integrate(
    p: &[f32],
    q: &[f32],
    mask: &Mask,
    weights: Option<&GrayImage>,
    comps: &Components,
    progress: &dyn Progress,
) -> Result<Vec<f32>> {
    let (w, h) = (mask.width, mask.height);
    progress.start("lsq: assemble, factorise, solve", 3);
    let wt = pixel_weights(weights, mask);
    // Unknown index of every mask pixel, raster order.
    let mut index = vec![NONE; w * h];
    let mut pixels = Vec::with_capacity(mask.count());
    for (i, &m) in mask.data.iter().enumerate() {
        if m {
            index[i] = pixels.len();
            pixels.push(i);
        }
    }
    let n = pixels.len();
    let mut pinned = vec![false; comps.count];
    let mut diag = vec![0.0f64; n];
    let mut rhs = vec![0.0f64; n];
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::with_capacity(3 * n);
    let mut vals = Vec::with_capacity(3 * n);
    // First pass: diagonal and right-hand side from every edge.
    let edge = |i: usize, j: usize, g: f64, diag: &mut [f64], rhs: &mut [f64]| {
        let we = 0.5 * (wt[i] + wt[j]);
        let (a, b) = (index[i], index[j]);
        diag[a] += we;
        diag[b] += we;
        rhs[a] -= we * g;
        rhs[b] += we * g;
        we
    };
    let mut off = Vec::with_capacity(2 * n);
    for &i in &pixels {
        let (r, c) = (i / w, i % w);
        let right = if c + 1 < w && mask.data[i + 1] {
            Some(i + 1)
        } else {
            None
        };
        let down = if r + 1 < h && mask.data[i + w] {
            Some(i + w)
        } else {
            None
        };
        let er = right.map(|j| {
            (
                index[j],
                edge(i, j, 0.5 * (p[i] as f64 + p[j] as f64), &mut diag, &mut rhs),
            )
        });
        let ed = down.map(|j| {
            (
                index[j],
                edge(
                    i,
                    j,
                    -0.5 * (q[i] as f64 + q[j] as f64),
                    &mut diag,
                    &mut rhs,
                ),
            )
        });
        off.push((er, ed));
    }
    for (k, &i) in pixels.iter().enumerate() {
        let part = comps.labels[i] as usize;
        if !pinned[part] {
            pinned[part] = true;
            diag[k] += 1.0;
        }
    }
    // Lower triangle in compressed-column form: column k holds rows k, right, down
    // (all ≥ k and ascending, since right = k+1 and down comes later in raster order).
    col_ptr.push(0usize);
    for (k, (er, ed)) in off.iter().enumerate() {
        row_idx.push(k);
        vals.push(diag[k]);
        for &(j, we) in er.iter().chain(ed.iter()) {
            row_idx.push(j);
            vals.push(-we);
        }
        col_ptr.push(row_idx.len());
    }
    progress.advance(1);
    let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
    let a = SparseColMatRef::new(sym, &vals);
    let llt = a.sp_cholesky(Side::Lower).map_err(|e| {
        Error::invalid(
            "lsq integration",
            format!("sparse Cholesky failed ({e:?}); check the weights for huge values"),
        )
    })?;
    progress.advance(1);
    llt.solve_in_place(MatMut::from_column_major_slice_mut(&mut rhs, n, 1));
    progress.advance(1);
    progress.finish();
    let mut z = vec![0.0f32; w * h];
    for (k, &i) in pixels.iter().enumerate() {
        z[i] = rhs[k] as f32;
    }
    Ok(z)
}
