//! DCT Poisson integration (Simchony, Chellappa & Shao 1990).
//!
//! Least squares over the edges of the full rectangle (none crosses the border) gives
//! the Neumann graph Laplacian system L z = b with
//! b(r, c) = gx(r, c) − gx(r, c−1) + gy(r, c) − gy(r−1, c), where
//! gx(r, c) = (p(r, c) + p(r, c+1))/2 is the target of z(r, c+1) − z(r, c),
//! gy(r, c) = −(q(r, c) + q(r+1, c))/2 that of z(r+1, c) − z(r, c), and terms of edges
//! outside the rectangle are 0. The 2-D DCT-II diagonalises L with eigenvalues
//! λ = 2cos(πk/W) + 2cos(πl/H) − 4; z = DCT-III(DCT-II(b)/λ), mean fixed by λ(0,0) := ∞.

use super::support::transpose;
use rayon::prelude::*;
use rustdct::{DctPlanner, TransformType2And3};
use std::f64::consts::PI;
use std::sync::Arc;

/// Solve the Neumann Poisson problem on the W × H rectangle; arbitrary offset.
pub(crate) fn integrate(p: &[f32], q: &[f32], w: usize, h: usize) -> Vec<f32> {
    let b = neumann_divergence(p, q, w, h);
    solve_neumann(b, w, h)
}

fn neumann_divergence(p: &[f32], q: &[f32], w: usize, h: usize) -> Vec<f32> {
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

/// Apply a DCT-II (`forward`) or DCT-III to every row of length `n`, in parallel.
fn rows(data: &mut [f32], n: usize, plan: &Arc<dyn TransformType2And3<f32>>, forward: bool) {
    data.par_chunks_mut(n).for_each_init(
        || vec![0.0f32; plan.get_scratch_len()],
        |scratch, row| {
            if forward {
                plan.process_dct2_with_scratch(row, scratch);
            } else {
                plan.process_dct3_with_scratch(row, scratch);
            }
        },
    );
}

/// Solve L z = b (Neumann Laplacian of the W × H grid) with 2-D DCTs.
pub(crate) fn solve_neumann(mut b: Vec<f32>, w: usize, h: usize) -> Vec<f32> {
    let mut planner = DctPlanner::<f32>::new();
    let (pw, ph) = (planner.plan_dct2(w), planner.plan_dct2(h));
    rows(&mut b, w, &pw, true);
    let mut t = transpose(&b, h, w);
    drop(b);
    rows(&mut t, h, &ph, true);
    let cos_r: Vec<f64> = (0..h)
        .map(|l| 2.0 * (PI * l as f64 / h as f64).cos())
        .collect();
    t.par_chunks_mut(h).enumerate().for_each(|(k, col)| {
        let ck = 2.0 * (PI * k as f64 / w as f64).cos() - 4.0;
        for (l, v) in col.iter_mut().enumerate() {
            let lambda = ck + cos_r[l];
            *v = if k == 0 && l == 0 {
                0.0
            } else {
                (*v as f64 / lambda) as f32
            };
        }
    });
    rows(&mut t, h, &ph, false);
    let mut z = transpose(&t, w, h);
    drop(t);
    rows(&mut z, w, &pw, false);
    let scale = 4.0 / (w * h) as f32;
    z.par_iter_mut().for_each(|v| *v *= scale);
    z
}
