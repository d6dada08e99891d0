//! Helpers shared by the integrators: input clean-up, connected parts, residuals,
//! offsets and a parallel transpose.

use crate::image::{DepthMap, GrayImage, Image, Mask};
use rayon::prelude::*;
use std::borrow::Cow;

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
    if !mask.data.is_empty() && mask.data.par_iter().all(|&m| m) {
        // One part covering the grid: skip the flood fill (zeroed allocation is cheap).
        return Components {
            labels: vec![0; w * h],
            count: 1,
        };
    }
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

/// Gradients as flat `f32` buffers, 0 outside the mask; non-finite values inside the
/// mask become 0 and are counted. Borrowed (no copy) when nothing needs cleaning.
pub fn sanitize<'a>(
    p: &'a GrayImage,
    q: &'a GrayImage,
    mask: &Mask,
    full: bool,
) -> (Cow<'a, [f32]>, Cow<'a, [f32]>, usize) {
    if full
        && p.data
            .par_iter()
            .chain(q.data.par_iter())
            .all(|v| v.is_finite())
    {
        return (Cow::Borrowed(&p.data), Cow::Borrowed(&q.data), 0);
    }
    let clean = |src: &GrayImage| -> (Vec<f32>, usize) {
        let bad = std::sync::atomic::AtomicUsize::new(0);
        let out = src
            .data
            .par_iter()
            .zip(&mask.data)
            .map(|(&v, &m)| match (m, v.is_finite()) {
                (false, _) => 0.0,
                (true, true) => v,
                (true, false) => {
                    bad.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    0.0
                }
            })
            .collect();
        (out, bad.into_inner())
    };
    let ((pp, bp), (qq, bq)) = rayon::join(|| clean(p), || clean(q));
    // A pixel with both p and q bad counts once.
    let both = if bp > 0 && bq > 0 {
        p.data
            .par_iter()
            .zip(&q.data)
            .zip(&mask.data)
            .filter(|((a, b), &m)| m && !a.is_finite() && !b.is_finite())
            .count()
    } else {
        0
    };
    (Cow::Owned(pp), Cow::Owned(qq), bp + bq - both)
}

/// RMS over the in-mask edges of z_j − z_i − g_e, with the trapezoidal targets of the
/// module documentation.
pub fn edge_residual(z: &[f32], p: &[f32], q: &[f32], mask: &Mask) -> f64 {
    let (w, h) = (mask.width, mask.height);
    let (sum, n) = (0..h)
        .into_par_iter()
        .map(|r| {
            let (mut sum, mut n) = (0.0f64, 0usize);
            for c in 0..w {
                let i = r * w + c;
                if !mask.data[i] {
                    continue;
                }
                if c + 1 < w && mask.data[i + 1] {
                    let e = z[i + 1] as f64 - z[i] as f64 - 0.5 * (p[i] as f64 + p[i + 1] as f64);
                    sum += e * e;
                    n += 1;
                }
                if r + 1 < h && mask.data[i + w] {
                    let e = z[i + w] as f64 - z[i] as f64 + 0.5 * (q[i] as f64 + q[i + w] as f64);
                    sum += e * e;
                    n += 1;
                }
            }
            (sum, n)
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if n == 0 {
        0.0
    } else {
        (sum / n as f64).sqrt()
    }
}

/// Depth of a mask that covers the whole grid: shift `z` to mean 0 in place. `None`
/// when `z` holds a non-finite value.
pub fn center_full(mut z: Vec<f32>, w: usize, h: usize) -> Option<DepthMap> {
    let sum: f64 = z
        .par_chunks(w.max(1))
        .map(|row| row.iter().map(|&v| v as f64).sum::<f64>())
        .sum();
    if !sum.is_finite() {
        return None;
    }
    let mean = (sum / z.len().max(1) as f64) as f32;
    z.par_iter_mut().for_each(|v| *v -= mean);
    Some(Image {
        width: w,
        height: h,
        data: z,
    })
}

/// Shift every connected part to mean 0 and put NaN outside the mask.
pub fn center_components(z: &[f32], comps: &Components, w: usize, h: usize) -> DepthMap {
    let k = comps.count;
    let (sum, cnt) = z
        .par_chunks(w.max(1))
        .zip(comps.labels.par_chunks(w.max(1)))
        .fold(
            || (vec![0.0f64; k], vec![0usize; k]),
            |(mut s, mut n), (zr, lr)| {
                for (v, &l) in zr.iter().zip(lr) {
                    if l != u32::MAX {
                        s[l as usize] += *v as f64;
                        n[l as usize] += 1;
                    }
                }
                (s, n)
            },
        )
        .reduce(
            || (vec![0.0f64; k], vec![0usize; k]),
            |(mut s, mut n), (s2, n2)| {
                s.iter_mut().zip(s2).for_each(|(a, b)| *a += b);
                n.iter_mut().zip(n2).for_each(|(a, b)| *a += b);
                (s, n)
            },
        );
    let mean: Vec<f64> = sum
        .iter()
        .zip(&cnt)
        .map(|(s, &c)| s / c.max(1) as f64)
        .collect();
    let data = z
        .par_iter()
        .zip(&comps.labels)
        .map(|(&v, &l)| {
            if l == u32::MAX {
                f32::NAN
            } else {
                (v as f64 - mean[l as usize]) as f32
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
