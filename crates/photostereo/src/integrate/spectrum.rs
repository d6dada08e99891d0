//! The eigenvalues of the grid Laplacian that the Fourier (periodic) and cosine
//! (Neumann) solvers divide by, shared by both.

use std::f64::consts::PI;

/// 1/λ of the 2-D Laplacian with λ = −(s_k + s_l) (terms of [`half_angle_terms`]); 0 for
/// the constant mode (λ = 0), which fixes the mean to 0.
#[inline]
pub(crate) fn inverse_eigenvalue(s_k: f32, s_l: f32) -> f32 {
    let minus_lambda = s_k + s_l;
    if minus_lambda > 0.0 {
        -1.0 / minus_lambda
    } else {
        0.0
    }
}

/// s_i = 4 sin²(π·i / (per·n)) for i in 0..count: minus the eigenvalues of the 1-D
/// Laplacian of a periodic grid of n nodes (per = 1: 2 − 2cos(2πi/n)) or of a Neumann
/// grid of n nodes (per = 2: 2 − 2cos(πi/n)).
pub(crate) fn half_angle_terms(count: usize, n: usize, per: f64) -> Vec<f32> {
    (0..count)
        .map(|i| {
            let s = (PI * i as f64 / (per * n as f64)).sin();
            (4.0 * s * s) as f32
        })
        .collect()
}
