//! Detection from contrast edges, for a sphere that is not one bright blob: a dark
//! mirror (chrome) sphere on a dark background shows its rim only where something lit
//! lies behind it, and its brightest pixels are the highlights inside it.
//!
//! 1. The **mean over the K images**, **log-stretched**: L = ln(m + ε), ε = 1/4 of the
//!    window's mean, then a Gaussian blur (σ = 1 px). A rim dark against a dim wall
//!    is then as strong an edge as a bright one against black.
//! 2. **Edge points** (Canny 1986, without hysteresis): Sobel gradient of L,
//!    non-maximum suppression along it, magnitude above Otsu's threshold of the
//!    suppressed magnitudes; sub-pixel position by a parabola through the magnitudes
//!    at −1, 0, +1 px along the gradient. Each point keeps its gradient direction.
//! 3. **RANSAC** over point triples (Fischler & Bolles 1981): a circle scores the
//!    **angular coverage** of its inliers — points within `tol` of its rim whose
//!    gradient is radial (|cos| ≥ 0.95) — in 2° sectors, so that a long straight or
//!    wavy edge cannot outvote a circular arc. The radius must lie in
//!    [8 px, half the window's smaller side] and the circle inside the window.
//! 4. **Geometric refinement** ([`super::fit::refine_geometric`]) on the inliers,
//!    re-selected three times.
//! 5. **Unbiased positions**: the log stretch moves the gradient maximum toward the
//!    dark side of the edge (by about a pixel here), so each inlier is re-located on the
//!    *linear* mean image as the mid-level crossing of its profile along the gradient
//!    (as for the bright-blob detection, module `edges`) and the circle refined again.
//!
//! The result is accepted by the caller only when the inliers cover enough of the rim.

use super::edges::{otsu, subpixel_edge, View};
use super::fit::{circle_through, refine_geometric, uncertainty, SplitMix};
use super::Circle;

/// An edge point with its unit gradient direction (toward increasing L).
#[derive(Clone, Copy, Debug)]
pub(crate) struct EdgePoint {
    pub p: [f64; 2],
    pub dir: [f64; 2],
}

/// A circle found from contrast edges.
#[derive(Clone, Debug)]
pub(crate) struct ContrastFit {
    pub circle: Circle,
    pub rms_residual_px: f64,
    pub inliers: usize,
    pub edge_points: usize,
    /// Fraction of the rim (2° sectors) that holds an inlier.
    pub coverage: f64,
    /// 1-σ uncertainty of the circle (pixels, [`super::fit::uncertainty`]).
    pub uncertainty_px: f64,
}

/// Smallest |cos| between an inlier's gradient and the circle's radial direction.
const RADIAL_COS: f64 = 0.95;
/// Angular sectors of the coverage score.
const SECTORS: usize = 180;

/// Log-stretched, blurred mean image of a `width` × `height` window (values row-major).
pub(crate) fn log_mean(mean: &[f32], width: usize, height: usize) -> Vec<f32> {
    let avg = mean.iter().map(|&v| v.max(0.0) as f64).sum::<f64>() / mean.len().max(1) as f64;
    let eps = (0.25 * avg).max(1e-6) as f32;
    let log: Vec<f32> = mean.iter().map(|&v| (v.max(0.0) + eps).ln()).collect();
    gaussian_blur(&log, width, height, 1.0)
}

/// Separable Gaussian blur of standard deviation `sigma` pixels (clamped borders).
pub(super) fn gaussian_blur(img: &[f32], width: usize, height: usize, sigma: f64) -> Vec<f32> {
    let half = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f32> = (-half..=half)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32)
        .collect();
    let norm: f32 = kernel.iter().sum();
    let pass = |src: &[f32], horizontal: bool| -> Vec<f32> {
        let mut out = vec![0.0f32; src.len()];
        for r in 0..height {
            for c in 0..width {
                let mut acc = 0.0;
                for (j, kv) in kernel.iter().enumerate() {
                    let o = j as isize - half;
                    let (rr, cc) = if horizontal {
                        (r as isize, (c as isize + o).clamp(0, width as isize - 1))
                    } else {
                        ((r as isize + o).clamp(0, height as isize - 1), c as isize)
                    };
                    acc += kv * src[rr as usize * width + cc as usize];
                }
                out[r * width + c] = acc / norm;
            }
        }
        out
    };
    pass(&pass(img, true), false)
}

/// Canny-style sub-pixel edge points of `img` (see the module docs); `keep` restricts
/// them to a mask (None = everywhere).
pub(crate) fn edge_points(img: &View, keep: Option<&[bool]>) -> Vec<EdgePoint> {
    let (w, h) = (img.width, img.height);
    let mut grad = vec![(0.0f64, 0.0f64); w * h];
    let mut mag = vec![0.0f32; w * h];
    for r in 1..h.saturating_sub(1) {
        for c in 1..w.saturating_sub(1) {
            let g = img.sobel(r, c);
            grad[r * w + c] = g;
            mag[r * w + c] = (g.0 * g.0 + g.1 * g.1).sqrt() as f32;
        }
    }
    let magv = View {
        width: w,
        height: h,
        data: &mag,
    };
    let mut cands: Vec<(usize, f64, [f64; 2], [f64; 2])> = Vec::new();
    for r in 2..h.saturating_sub(2) {
        for c in 2..w.saturating_sub(2) {
            let i = r * w + c;
            let m = mag[i] as f64;
            if m <= 0.0 || keep.is_some_and(|k| !k[i]) {
                continue;
            }
            let d = [grad[i].0 / m, grad[i].1 / m];
            let (x, y) = (c as f64 + 0.5, r as f64 + 0.5);
            let before = magv.bilinear(x - d[0], y - d[1]);
            let after = magv.bilinear(x + d[0], y + d[1]);
            if m < before || m <= after {
                continue;
            }
            let curv = before - 2.0 * m + after;
            let s = if curv < 0.0 {
                (0.5 * (before - after) / curv).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            cands.push((i, m, [x + s * d[0], y + s * d[1]], d));
        }
    }
    if cands.is_empty() {
        return Vec::new();
    }
    let values: Vec<f32> = cands.iter().map(|c| c.1 as f32).collect();
    let hi = values.iter().copied().fold(0.0f32, f32::max);
    let t = otsu(&values, &vec![true; values.len()], 0.0, hi) as f64;
    cands
        .into_iter()
        .filter(|c| c.1 > t)
        .map(|(_, _, p, dir)| EdgePoint { p, dir })
        .collect()
}

/// Inlier test: on the rim within `tol` and a radial gradient.
#[inline]
fn is_inlier(e: &EdgePoint, c: &Circle, tol: f64) -> bool {
    let (dx, dy) = (e.p[0] - c.cx, e.p[1] - c.cy);
    let d = (dx * dx + dy * dy).sqrt();
    if (d - c.radius).abs() > tol || d <= 0.0 {
        return false;
    }
    ((dx * e.dir[0] + dy * e.dir[1]) / d).abs() >= RADIAL_COS
}

/// Fraction of the 2° sectors of the rim holding an inlier, and the inlier count.
fn coverage(points: &[EdgePoint], c: &Circle, tol: f64) -> (f64, usize) {
    let mut hit = [false; SECTORS];
    let mut n = 0;
    for e in points.iter().filter(|e| is_inlier(e, c, tol)) {
        let a = (e.p[1] - c.cy).atan2(e.p[0] - c.cx) + std::f64::consts::PI;
        let s = ((a / std::f64::consts::TAU) * SECTORS as f64) as usize;
        hit[s.min(SECTORS - 1)] = true;
        n += 1;
    }
    (
        hit.iter().filter(|&&h| h).count() as f64 / SECTORS as f64,
        n,
    )
}

/// A circle the detection may report: radius at least 8 px, wholly inside the `width` ×
/// `height` window (half a pixel of slack).
pub(crate) fn plausible(c: &Circle, width: usize, height: usize) -> bool {
    let r_max = 0.5 * width.min(height) as f64 + 0.5;
    c.radius >= 8.0
        && c.radius <= r_max
        && c.cx - c.radius >= -0.5
        && c.cy - c.radius >= -0.5
        && c.cx + c.radius <= width as f64 + 0.5
        && c.cy + c.radius <= height as f64 + 0.5
}

/// Circle of best rim coverage in a `width` × `height` window (see the module docs).
pub(crate) fn fit_contrast(
    points: &[EdgePoint],
    width: usize,
    height: usize,
    iterations: usize,
    tol: f64,
) -> Option<ContrastFit> {
    if points.len() < 12 {
        return None;
    }
    let plausible = |c: &Circle| plausible(c, width, height);
    let mut rng = SplitMix(0xC0FF_EE11);
    let mut best: Option<(f64, usize, Circle)> = None;
    for _ in 0..iterations {
        let t = [0, 1, 2].map(|_| points[rng.below(points.len())]);
        let Some(c) = circle_through(t[0].p, t[1].p, t[2].p) else {
            continue;
        };
        if !plausible(&c) || !t.iter().all(|e| is_inlier(e, &c, tol)) {
            continue;
        }
        let (cov, n) = coverage(points, &c, tol);
        if best.is_none_or(|b| (cov, n) > (b.0, b.1)) {
            best = Some((cov, n, c));
        }
    }
    let (_, _, circle) = best?;
    refine_inliers(points, circle, tol, points.len())
}

/// Three rounds of geometric refinement on the inliers of `circle`, then the fit's
/// figures (rms distance of the inliers, rim coverage); `edge_points` is reported as is.
fn refine_inliers(
    points: &[EdgePoint],
    mut circle: Circle,
    tol: f64,
    edge_points: usize,
) -> Option<ContrastFit> {
    let inliers = |c: &Circle| -> Vec<[f64; 2]> {
        points
            .iter()
            .filter(|e| is_inlier(e, c, tol))
            .map(|e| e.p)
            .collect()
    };
    for _ in 0..3 {
        circle = refine_geometric(&inliers(&circle), circle, 50)?;
    }
    let inl = inliers(&circle);
    let ss: f64 = inl
        .iter()
        .map(|p| ((p[0] - circle.cx).hypot(p[1] - circle.cy) - circle.radius).powi(2))
        .sum();
    let (cov, n) = coverage(points, &circle, tol);
    Some(ContrastFit {
        circle,
        rms_residual_px: (ss / inl.len().max(1) as f64).sqrt(),
        inliers: n,
        edge_points,
        coverage: cov,
        uncertainty_px: uncertainty(&inl, &circle).unwrap_or(f64::INFINITY),
    })
}

/// Step 5: re-locate the inliers of `fit` on the linear image `linear` and refine.
pub(crate) fn relocate(
    points: &[EdgePoint],
    fit: &ContrastFit,
    linear: &View,
    tol: f64,
) -> Option<ContrastFit> {
    let c0 = fit.circle;
    let moved: Vec<EdgePoint> = points
        .iter()
        .filter(|e| is_inlier(e, &c0, tol))
        .filter_map(|e| {
            let (r, c) = (e.p[1].floor() as usize, e.p[0].floor() as usize);
            let p = subpixel_edge(linear, r, c, (c0.cx, c0.cy), 0.0)?;
            Some(EdgePoint { p, dir: e.dir })
        })
        .collect();
    refine_inliers(&moved, c0, tol, fit.edge_points)
}
