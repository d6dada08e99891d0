//! Helpers shared by the integrators: input clean-up, connected parts, residuals,
//! offsets.

use crate::image::{DepthMap, GrayImage, Image, Mask, NormalMap};
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
    if !mask.data.is_empty() && all_set_par(&mask.data) {
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
    sanitize_cow(Cow::Borrowed(&p.data), Cow::Borrowed(&q.data), mask, full)
}

/// [`sanitize`] of gradients the caller may hand over: owned ones are cleaned in place
/// (no second copy of the two planes: at 4096² that is 134 MB less at the peak of the
/// integration), borrowed ones copied only when something needs cleaning.
pub(crate) fn sanitize_cow<'a>(
    p: Cow<'a, [f32]>,
    q: Cow<'a, [f32]>,
    mask: &Mask,
    full: bool,
) -> (Cow<'a, [f32]>, Cow<'a, [f32]>, usize) {
    if full && all_finite_par(&p) && all_finite_par(&q) {
        return (p, q, 0);
    }
    // A pixel with p or q bad (or both) counts once.
    let bad = p
        .par_iter()
        .zip(&q[..])
        .zip(&mask.data)
        .filter(|((a, b), &m)| m && !(a.is_finite() && b.is_finite()))
        .count();
    let clean = |v: &mut [f32]| {
        v.par_iter_mut().zip(&mask.data).for_each(|(v, &m)| {
            if !m || !v.is_finite() {
                *v = 0.0;
            }
        })
    };
    let (mut p, mut q) = (p.into_owned(), q.into_owned());
    rayon::join(|| clean(&mut p), || clean(&mut q));
    (Cow::Owned(p), Cow::Owned(q), bad)
}

/// What one pass over the solved depth measures.
#[derive(Clone, Copy, Debug)]
pub struct EdgeResidual {
    /// RMS over the in-mask edges of z_j − z_i − g_e (trapezoidal targets of the module
    /// documentation), pixels.
    pub rms: f64,
    /// Σ z over the mask (for the mean offset, without another pass over z).
    pub depth_sum: f64,
}

/// The edge residual and the depth sum over the mask, in one pass.
pub fn edge_residual(z: &[f32], p: &[f32], q: &[f32], mask: &Mask) -> EdgeResidual {
    let (w, h) = (mask.width, mask.height);
    let (sum, n, depth_sum) = (0..h)
        .into_par_iter()
        .map_init(
            || vec![0.0f32; w],
            |e, r| {
                let row = |rr: usize| rr * w..(rr + 1) * w;
                let (a, m) = (row(r), &mask.data[row(r)]);
                let below = (r + 1 < h).then(|| row(r + 1));
                let full = all_set(m) && below.clone().is_none_or(|b| all_set(&mask.data[b]));
                if !full || w < 2 {
                    return masked_row_residual(z, p, q, mask, r);
                }
                // Whole rows inside the mask: branch-free loops over zipped slices.
                let (zr, pr) = (&z[a.clone()], &p[a.clone()]);
                let depth_sum = sum_row(zr);
                let (z1, p1) = (
                    zr[1..].iter().zip(&zr[..w - 1]),
                    pr[1..].iter().zip(&pr[..w - 1]),
                );
                for (v, ((za, zb), (pa, pb))) in e.iter_mut().zip(z1.zip(p1)) {
                    *v = za - zb - 0.5 * (pa + pb);
                }
                let mut sum = sum_squares(&e[..w - 1]);
                let mut n = w - 1;
                if let Some(b) = below {
                    let (zb, qa, qb) = (&z[b.clone()], &q[a], &q[b]);
                    for (v, ((za, zt), (qt, qd))) in
                        e.iter_mut().zip(zb.iter().zip(zr).zip(qa.iter().zip(qb)))
                    {
                        *v = za - zt + 0.5 * (qt + qd);
                    }
                    sum += sum_squares(e);
                    n += w;
                }
                (sum, n, depth_sum)
            },
        )
        .reduce(|| (0.0, 0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    EdgeResidual {
        rms: if n == 0 { 0.0 } else { (sum / n as f64).sqrt() },
        depth_sum,
    }
}

/// Σ f(v) over `values`: 16 `f32` lanes (vectorised) per run of 1024 values, runs
/// added in `f64` (relative error ~1e-6 of Σ|f(v)|, plenty for a mean offset or an RMS).
fn lane_sum(values: &[f32], f: impl Fn(f32) -> f32) -> f64 {
    values
        .chunks(1024)
        .map(|run| {
            let mut lanes = [0.0f32; 16];
            let mut it = run.chunks_exact(16);
            for c in &mut it {
                for (l, &v) in lanes.iter_mut().zip(c) {
                    *l += f(v);
                }
            }
            let tail: f32 = it.remainder().iter().map(|&v| f(v)).sum();
            (lanes.iter().sum::<f32>() + tail) as f64
        })
        .sum()
}

fn sum_squares(values: &[f32]) -> f64 {
    lane_sum(values, |v| v * v)
}

/// The residual terms of row r (edges to the right and down) where the mask is partial,
/// their count, and Σ z over the row's mask pixels.
fn masked_row_residual(
    z: &[f32],
    p: &[f32],
    q: &[f32],
    mask: &Mask,
    r: usize,
) -> (f64, usize, f64) {
    let (w, h) = (mask.width, mask.height);
    let (mut sum, mut n, mut depth_sum) = (0.0f64, 0usize, 0.0f64);
    for c in 0..w {
        let i = r * w + c;
        if !mask.data[i] {
            continue;
        }
        depth_sum += z[i] as f64;
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
    (sum, n, depth_sum)
}

fn sum_row(values: &[f32]) -> f64 {
    lane_sum(values, |v| v)
}

/// Whether every flag is set (branch-free, so that it vectorises).
pub fn all_set(flags: &[bool]) -> bool {
    flags.iter().fold(true, |a, &b| a & b)
}

/// Whether every flag of a large buffer is set, in parallel.
pub fn all_set_par(flags: &[bool]) -> bool {
    flags.par_chunks(1 << 16).all(all_set)
}

/// Whether any flag of a large buffer is set, in parallel.
pub fn any_set_par(flags: &[bool]) -> bool {
    flags
        .par_chunks(1 << 16)
        .any(|c| c.iter().fold(false, |a, &b| a | b))
}

/// Whether every value of a large buffer is finite, in parallel and vectorised.
pub fn all_finite_par(values: &[f32]) -> bool {
    values
        .par_chunks(1 << 16)
        .all(|c| c.iter().fold(true, |a, v| a & v.is_finite()))
}

/// Depth of a mask that covers the whole grid, given Σ z: shift `z` to mean 0 in place.
/// `None` when `z` holds a non-finite value (then the sum is not finite). A mean below
/// 1e-6 px, which the Fourier solvers leave by construction (their (0, 0) coefficient is
/// 0), is left alone: it is below the `f32` resolution of depths beyond 8 px.
pub fn center_full(mut z: Vec<f32>, w: usize, h: usize, sum: f64) -> Option<DepthMap> {
    if !sum.is_finite() {
        return None;
    }
    let mean = (sum / z.len().max(1) as f64) as f32;
    if mean.abs() >= 1e-6 {
        z.par_iter_mut().for_each(|v| *v -= mean);
    }
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

/// Gradients (p, q) of a normal map inside the mask (0 outside), and the number of
/// normals that had to be clamped (see the module documentation of `integrate`).
pub fn gradients(normals: &NormalMap, mask: &Mask, min_nz: f32) -> (GrayImage, GrayImage, usize) {
    let (w, h) = (normals.width, normals.height);
    let mut p = GrayImage::filled(w, h, 0.0);
    let mut q = GrayImage::filled(w, h, 0.0);
    let mut clamped = 0;
    for (i, n) in normals.data.iter().enumerate() {
        if !mask.data.get(i).copied().unwrap_or(false) {
            continue;
        }
        if n.iter().any(|v| v.is_nan()) {
            clamped += 1;
            continue;
        }
        let nz = if n[2] > min_nz {
            n[2]
        } else {
            clamped += 1;
            min_nz.max(f32::MIN_POSITIVE)
        };
        p.data[i] = (-n[0] / nz).clamp(-1e6, 1e6);
        q.data[i] = (-n[1] / nz).clamp(-1e6, 1e6);
    }
    (p, q, clamped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn owned_gradients_are_cleaned_in_place_like_borrowed_ones() {
        let mask: Mask = Image::from_fn(4, 3, |r, c| (r + c) % 3 != 0);
        let p = Image::from_fn(4, 3, |r, c| match (r, c) {
            (0, 1) => f32::NAN,
            (1, 1) => f32::INFINITY,
            (2, 1) => f32::NAN,
            _ => (r * 4 + c) as f32 * 0.5,
        });
        let q = Image::from_fn(4, 3, |r, c| match (r, c) {
            (0, 1) => f32::NAN,
            (2, 3) => f32::NEG_INFINITY,
            _ => -((r + c) as f32),
        });
        let (bp, bq, bad) = sanitize(&p, &q, &mask, false);
        let owned = sanitize_cow(
            Cow::Owned(p.data.clone()),
            Cow::Owned(q.data.clone()),
            &mask,
            false,
        );
        assert_eq!(
            (&bp[..], &bq[..], bad),
            (&owned.0[..], &owned.1[..], owned.2)
        );
        // (0,1) bad in both counts once; (1,1) in p; (2,3) in q; (2,1) is outside the mask
        assert_eq!(bad, 3);
        for i in 0..12 {
            let keep = mask.data[i] && p.data[i].is_finite();
            assert_eq!(bp[i], if keep { p.data[i] } else { 0.0 }, "p at {i}");
        }
        // a full mask of finite values is handed back as it came
        let full = Mask::full(4, 3);
        let clean = Image::from_fn(4, 3, |r, c| (r + c) as f32);
        let (a, _, n) = sanitize(&clean, &clean, &full, true);
        assert!(matches!(a, Cow::Borrowed(_)) && n == 0);
    }
}
