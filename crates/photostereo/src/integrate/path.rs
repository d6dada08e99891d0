//! Path integration: cumulative trapezoidal sums of the gradient from a reference
//! pixel, along two different spanning trees of the grid.
//!
//! * rows first: along the reference row, then up and down every column;
//! * columns first: along the reference column, then left and right along every row.
//!
//! For integrable gradients both give the same depth; for real (noisy, non-integrable)
//! data they differ, and their RMS difference measures the path dependence that the
//! least-squares methods remove. Noise accumulates as a random walk along the path.

use super::support::{center_components, label_components, sanitize};
use crate::error::Result;
use crate::image::{DepthMap, GrayImage, Mask};

/// Which spanning tree to integrate along.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// Along the reference row, then along every column.
    RowsFirst,
    /// Along the reference column, then along every row.
    ColumnsFirst,
}

/// The mask pixel nearest the image centre (ties: first in raster order).
pub fn reference_pixel(mask: &Mask) -> Option<(usize, usize)> {
    let (cx, cy) = (mask.width as f64 / 2.0, mask.height as f64 / 2.0);
    let mut best: Option<((usize, usize), f64)> = None;
    for r in 0..mask.height {
        for c in 0..mask.width {
            if !mask.get(r, c) {
                continue;
            }
            let d = (c as f64 + 0.5 - cx).powi(2) + (r as f64 + 0.5 - cy).powi(2);
            if best.is_none_or(|(_, b)| d < b) {
                best = Some(((r, c), d));
            }
        }
    }
    best.map(|(rc, _)| rc)
}

/// Integrate along one line of `n` samples starting at `start` with value `z0`;
/// `slope(k)` is dz/dk at sample k and `set(k, z)` stores the result.
fn line(
    n: usize,
    start: usize,
    z0: f64,
    slope: impl Fn(usize) -> f64,
    mut set: impl FnMut(usize, f64),
) {
    set(start, z0);
    let mut z = z0;
    for k in start + 1..n {
        z += 0.5 * (slope(k - 1) + slope(k));
        set(k, z);
    }
    z = z0;
    for k in (0..start).rev() {
        z -= 0.5 * (slope(k) + slope(k + 1));
        set(k, z);
    }
}

/// One path integral over the whole grid (gradients 0 outside the mask), z = 0 at
/// `reference`.
pub(crate) fn integrate_order(
    p: &[f32],
    q: &[f32],
    w: usize,
    h: usize,
    reference: (usize, usize),
    order: Order,
) -> Vec<f64> {
    let (r0, c0) = reference;
    let mut z = vec![0.0f64; w * h];
    let (p, q) = (|i: usize| p[i] as f64, |i: usize| q[i] as f64);
    // ∂z/∂col = p, ∂z/∂row = −q.
    match order {
        Order::RowsFirst => {
            line(w, c0, 0.0, |c| p(r0 * w + c), |c, v| z[r0 * w + c] = v);
            for c in 0..w {
                let start = z[r0 * w + c];
                line(h, r0, start, |r| -q(r * w + c), |r, v| z[r * w + c] = v);
            }
        }
        Order::ColumnsFirst => {
            line(h, r0, 0.0, |r| -q(r * w + c0), |r, v| z[r * w + c0] = v);
            for r in 0..h {
                let start = z[r * w + c0];
                line(w, c0, start, |c| p(r * w + c), |c, v| z[r * w + c] = v);
            }
        }
    }
    z
}

/// Average of the two orders and the RMS of their difference over the mask.
pub(crate) fn integrate(p: &[f32], q: &[f32], mask: &Mask) -> (Vec<f32>, f32) {
    let (w, h) = (mask.width, mask.height);
    let reference = reference_pixel(mask).unwrap_or((h / 2, w / 2));
    let a = integrate_order(p, q, w, h, reference, Order::RowsFirst);
    let b = integrate_order(p, q, w, h, reference, Order::ColumnsFirst);
    let (mut sum, mut n) = (0.0, 0usize);
    let mut avg = vec![0.0f32; w * h];
    for i in 0..w * h {
        avg[i] = (0.5 * (a[i] + b[i])) as f32;
        if mask.data[i] {
            sum += (a[i] - b[i]).powi(2);
            n += 1;
        }
    }
    (avg, (sum / n.max(1) as f64).sqrt() as f32)
}

/// A single path integral (one order only), each connected part of the mask shifted
/// to mean 0, NaN outside: the baseline the other methods are compared against.
pub fn single_path(p: &GrayImage, q: &GrayImage, mask: &Mask, order: Order) -> Result<DepthMap> {
    mask.check_size(p.width, p.height, "integration mask")?;
    mask.check_size(q.width, q.height, "integration mask")?;
    mask.check_not_empty("integration mask")?;
    let (w, h) = (mask.width, mask.height);
    let (pp, qq, _) = sanitize(p, q, mask, false);
    let reference = reference_pixel(mask).unwrap_or((h / 2, w / 2));
    let z: Vec<f32> = integrate_order(&pp, &qq, w, h, reference, order)
        .into_iter()
        .map(|v| v as f32)
        .collect();
    Ok(center_components(&z, &label_components(mask), w, h))
}
