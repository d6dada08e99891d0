//! Helpers shared by the integrators: input clean-up, connected parts, residuals,
//! offsets and a parallel transpose.

use crate::image::{DepthMap, GrayImage, Image, Mask};
use rayon::prelude::*;

/// 4-connected parts of a mask.
#[derive(Clone, Debug)]
pub struct Components {
    /// Per pixel: part index (0-based), or `u32::MAX` outside the mask.
    pub labels: Vec<u32>,
    /// Number of parts.
    pub count: usize,
}

/// Label the 4-connected parts of `mask` (flood fill, raster order of first pixels).
pub fn label_components(mask: &Mask) -> Components {
    let (w, h) = (mask.width, mask.height);
    let mut labels = vec![u32::MAX; w * h];
    let mut count = 0u32;
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !mask.data[start] || labels[start] != u32::MAX {
            continue;
        }
        labels[start] = count;
        stack.push(start);
        while let Some(i) = stack.pop() {
            let (r, c) = (i / w, i % w);
            let mut visit = |j: usize| {
                if mask.data[j] && labels[j] == u32::MAX {
                    labels[j] = count;
                    stack.push(j);
                }
            };
            if c > 0 {
                visit(i - 1);
            }
            if c + 1 < w {
                visit(i + 1);
            }
            if r > 0 {
                visit(i - w);
            }
            if r + 1 < h {
                visit(i + w);
            }
        }
        count += 1;
    }
    Components {
        labels,
        count: count as usize,
    }
}

/// Gradients as `f64`, 0 outside the mask; non-finite values inside the mask become 0
/// and are counted.
pub fn sanitize(p: &GrayImage, q: &GrayImage, mask: &Mask) -> (Vec<f64>, Vec<f64>, usize) {
    let n = p.len();
    let mut pp = vec![0.0; n];
    let mut qq = vec![0.0; n];
    let mut bad = 0;
    for i in 0..n {
        if !mask.data[i] {
            continue;
        }
        let (a, b) = (p.data[i], q.data[i]);
        if a.is_finite() && b.is_finite() {
            pp[i] = a as f64;
            qq[i] = b as f64;
        } else {
            bad += 1;
        }
    }
    (pp, qq, bad)
}

/// RMS over the in-mask edges of z_j − z_i − g_e, with the trapezoidal targets of the
/// module documentation.
pub fn edge_residual(z: &[f64], p: &[f64], q: &[f64], mask: &Mask) -> f64 {
    let (w, h) = (mask.width, mask.height);
    let (mut sum, mut n) = (0.0, 0usize);
    for r in 0..h {
        for c in 0..w {
            let i = r * w + c;
            if !mask.data[i] {
                continue;
            }
            if c + 1 < w && mask.data[i + 1] {
                let e = z[i + 1] - z[i] - 0.5 * (p[i] + p[i + 1]);
                sum += e * e;
                n += 1;
            }
            if r + 1 < h && mask.data[i + w] {
                let e = z[i + w] - z[i] + 0.5 * (q[i] + q[i + w]);
                sum += e * e;
                n += 1;
            }
        }
    }
    if n == 0 {
        0.0
    } else {
        (sum / n as f64).sqrt()
    }
}

/// Shift every connected part to mean 0 and put NaN outside the mask.
pub fn center_components(z: &[f64], comps: &Components, w: usize, h: usize) -> DepthMap {
    let mut sum = vec![0.0f64; comps.count];
    let mut cnt = vec![0usize; comps.count];
    for (v, &l) in z.iter().zip(&comps.labels) {
        if l != u32::MAX {
            sum[l as usize] += v;
            cnt[l as usize] += 1;
        }
    }
    let mean: Vec<f64> = sum
        .iter()
        .zip(&cnt)
        .map(|(s, &c)| s / c.max(1) as f64)
        .collect();
    let data = z
        .iter()
        .zip(&comps.labels)
        .map(|(v, &l)| {
            if l == u32::MAX {
                f32::NAN
            } else {
                (v - mean[l as usize]) as f32
            }
        })
        .collect();
    Image {
        width: w,
        height: h,
        data,
    }
}

/// Transpose a `rows` × `cols` row-major buffer into `cols` × `rows`, in parallel.
pub fn transpose<T: Copy + Send + Sync + Default>(src: &[T], rows: usize, cols: usize) -> Vec<T> {
    const B: usize = 32;
    let mut out = vec![T::default(); src.len()];
    out.par_chunks_mut(B * rows)
        .enumerate()
        .for_each(|(blk, chunk)| {
            let c0 = blk * B;
            let nc = chunk.len() / rows;
            for r0 in (0..rows).step_by(B) {
                let r1 = (r0 + B).min(rows);
                for r in r0..r1 {
                    let row = &src[r * cols + c0..r * cols + c0 + nc];
                    for (k, &v) in row.iter().enumerate() {
                        chunk[k * rows + r] = v;
                    }
                }
            }
        });
    out
}
