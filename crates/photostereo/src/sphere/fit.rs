//! Robust circle fitting to 2-D points.
//!
//! Three stages, as in Chernov, *Circular and Linear Regression* (CRC, 2010):
//!
//! 1. **Algebraic fit** (Kåsa 1976): minimise Σ (x² + y² + D x + E y + F)², a linear
//!    least-squares problem (3×3 normal equations, solved on centred and scaled
//!    coordinates for conditioning). Centre (−D/2, −E/2), radius √(D²/4 + E²/4 − F).
//!    Cheap and exact on exact points, but biased toward small radii on noisy arcs.
//! 2. **RANSAC** (Fischler & Bolles 1981): circles through random point triples; the
//!    one with most points within `inlier_tol` of its rim wins. This removes outliers
//!    (bright blobs touching the sphere, specks of noise) before any least squares.
//! 3. **Geometric refinement**: Gauss–Newton (Levenberg-damped) on the true orthogonal
//!    distances, minimising Σ (‖pᵢ − c‖ − r)² over the inliers; this removes the Kåsa
//!    bias. Inliers are re-selected around the refined circle and the fit repeated.

use super::Circle;
use crate::error::{Error, Result};

/// Settings of [`fit_robust`].
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Number of RANSAC triples drawn (0 = no RANSAC, plain algebraic + geometric fit).
    pub ransac_iterations: usize,
    /// A point is an inlier when its distance to the circle's rim is below this (pixels).
    pub inlier_tol_px: f64,
    /// Seed of the deterministic random generator (results are reproducible).
    pub seed: u64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            ransac_iterations: 500,
            inlier_tol_px: 1.0,
            seed: 0x5EED_C1AC,
        }
    }
}

/// Result of [`fit_robust`].
#[derive(Clone, Debug)]
pub struct CircleFit {
    /// The fitted circle.
    pub circle: Circle,
    /// Root-mean-square orthogonal distance of the inliers to the circle (pixels).
    pub rms_residual_px: f64,
    /// `inliers[i]` is true when point i was used in the final fit.
    pub inliers: Vec<bool>,
}

impl CircleFit {
    /// Number of inliers.
    pub fn inlier_count(&self) -> usize {
        self.inliers.iter().filter(|&&b| b).count()
    }
}

/// Kåsa algebraic circle fit. `None` for fewer than 3 points or collinear points.
pub fn fit_algebraic(points: &[[f64; 2]]) -> Option<Circle> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p[0]).sum::<f64>() / n;
    let my = points.iter().map(|p| p[1]).sum::<f64>() / n;
    let scale = (points
        .iter()
        .map(|p| (p[0] - mx).powi(2) + (p[1] - my).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    if scale.is_nan() || scale <= 0.0 {
        return None;
    }
    // Unknowns (D, E, F) of x² + y² + D x + E y + F = 0 in scaled, centred coordinates.
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for p in points {
        let (x, y) = ((p[0] - mx) / scale, (p[1] - my) / scale);
        let row = [x, y, 1.0];
        let rhs = -(x * x + y * y);
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += row[i] * row[j];
            }
            b[i] += row[i] * rhs;
        }
    }
    let [d, e, f] = solve3(a, b)?;
    let (cx, cy) = (-d / 2.0, -e / 2.0);
    let r2 = cx * cx + cy * cy - f;
    if r2.is_nan() || r2 <= 0.0 {
        return None;
    }
    Some(Circle {
        cx: cx * scale + mx,
        cy: cy * scale + my,
        radius: r2.sqrt() * scale,
    })
}

/// Gauss–Newton (Levenberg-damped) minimisation of Σ (‖pᵢ − c‖ − r)², started at `init`.
pub fn refine_geometric(points: &[[f64; 2]], init: Circle, iterations: usize) -> Option<Circle> {
    if points.len() < 3 {
        return None;
    }
    let mut c = init;
    let mut cost = geometric_cost(points, &c);
    let mut lambda = 1e-6;
    for _ in 0..iterations {
        let mut jtj = [[0.0f64; 3]; 3];
        let mut jtr = [0.0f64; 3];
        for p in points {
            let (dx, dy) = (p[0] - c.cx, p[1] - c.cy);
            let d = (dx * dx + dy * dy).sqrt().max(1e-12);
            let res = d - c.radius;
            let jac = [-dx / d, -dy / d, -1.0];
            for i in 0..3 {
                for j in 0..3 {
                    jtj[i][j] += jac[i] * jac[j];
                }
                jtr[i] += jac[i] * res;
            }
        }
        let mut improved = false;
        for _ in 0..8 {
            let mut damped = jtj;
            for (i, row) in damped.iter_mut().enumerate() {
                row[i] *= 1.0 + lambda;
            }
            let step = solve3(damped, [-jtr[0], -jtr[1], -jtr[2]])?;
            let trial = Circle {
                cx: c.cx + step[0],
                cy: c.cy + step[1],
                radius: c.radius + step[2],
            };
            let trial_cost = geometric_cost(points, &trial);
            if trial.radius > 0.0 && trial_cost <= cost {
                let small = step.iter().map(|s| s.abs()).fold(0.0, f64::max) < 1e-9;
                c = trial;
                cost = trial_cost;
                lambda = (lambda * 0.1).max(1e-12);
                improved = !small;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    Some(c)
}

/// RANSAC over point triples, then algebraic and geometric fits on the inliers.
///
/// Errors with [`Error::SphereNotFound`] when fewer than 3 points are given or no
/// circle can be fitted (all points collinear).
pub fn fit_robust(points: &[[f64; 2]], opts: &FitOptions) -> Result<CircleFit> {
    let not_found = |reason: &str| Error::SphereNotFound {
        what: "edge points".into(),
        reason: reason.into(),
        fix: "give the circle by hand (centre x, y and radius in pixels)".into(),
    };
    if points.len() < 3 {
        return Err(not_found("fewer than 3 edge points"));
    }
    let tol = opts.inlier_tol_px.max(1e-6);
    let start = ransac(points, opts, tol)
        .or_else(|| fit_algebraic(points))
        .ok_or_else(|| not_found("the edge points lie on a line"))?;
    let mut circle = start;
    let mut inliers = inlier_mask(points, &circle, tol);
    for _ in 0..4 {
        let sel: Vec<[f64; 2]> = select(points, &inliers);
        let Some(alg) = fit_algebraic(&sel) else {
            break;
        };
        let Some(refined) = refine_geometric(&sel, alg, 50) else {
            break;
        };
        let next = inlier_mask(points, &refined, tol);
        let same = next == inliers;
        circle = refined;
        inliers = next;
        if same {
            break;
        }
    }
    let sel = select(points, &inliers);
    if sel.len() < 3 {
        return Err(not_found("no three edge points agree on one circle"));
    }
    let rms = (geometric_cost(&sel, &circle) / sel.len() as f64).sqrt();
    Ok(CircleFit {
        circle,
        rms_residual_px: rms,
        inliers,
    })
}

/// Standard deviations (pixels) of the centre (√(var cx + var cy)) and of the radius of
/// the geometric circle fit to `points` (s²(JᵀJ)⁻¹, s² the residual variance with 3 parameters).
pub fn circle_sd(points: &[[f64; 2]], c: &Circle) -> Option<(f64, f64)> {
    let mut jtj = [[0.0f64; 3]; 3];
    let mut ss = 0.0;
    for p in points {
        let (dx, dy) = (p[0] - c.cx, p[1] - c.cy);
        let d = dx.hypot(dy).max(1e-12);
        let j = [-dx / d, -dy / d, -1.0];
        for a in 0..3 {
            for b in 0..3 {
                jtj[a][b] += j[a] * j[b];
            }
        }
        ss += (d - c.radius).powi(2);
    }
    let s2 = ss / (points.len() as f64 - 3.0).max(1.0);
    let col = |i: usize| {
        let mut e = [0.0; 3];
        e[i] = 1.0;
        solve3(jtj, e).map(|x| x[i])
    };
    let (vx, vy, vr) = (col(0)?, col(1)?, col(2)?);
    Some(((s2 * (vx + vy)).sqrt(), (s2 * vr).sqrt()))
}

/// The larger of the two standard deviations of [`circle_sd`] (pixels).
pub fn uncertainty(points: &[[f64; 2]], c: &Circle) -> Option<f64> {
    circle_sd(points, c).map(|(a, b)| a.max(b))
}

/// Circle through three points, `None` when (nearly) collinear.
pub fn circle_through(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Option<Circle> {
    let (bx, by) = (b[0] - a[0], b[1] - a[1]);
    let (cx, cy) = (c[0] - a[0], c[1] - a[1]);
    let d = 2.0 * (bx * cy - by * cx);
    let scale = (bx * bx + by * by).max(cx * cx + cy * cy);
    if d.abs() < 1e-9 * scale.max(1e-12) {
        return None;
    }
    let b2 = bx * bx + by * by;
    let c2 = cx * cx + cy * cy;
    let ux = (cy * b2 - by * c2) / d;
    let uy = (bx * c2 - cx * b2) / d;
    Some(Circle {
        cx: a[0] + ux,
        cy: a[1] + uy,
        radius: (ux * ux + uy * uy).sqrt(),
    })
}

fn ransac(points: &[[f64; 2]], opts: &FitOptions, tol: f64) -> Option<Circle> {
    let n = points.len();
    if opts.ransac_iterations == 0 || n < 3 {
        return None;
    }
    let extent = bounding_extent(points);
    let mut rng = SplitMix(opts.seed);
    let mut best: Option<(usize, Circle)> = None;
    for _ in 0..opts.ransac_iterations {
        let i = rng.below(n);
        let j = rng.below(n);
        let k = rng.below(n);
        if i == j || j == k || i == k {
            continue;
        }
        let Some(c) = circle_through(points[i], points[j], points[k]) else {
            continue;
        };
        if c.radius > 2.0 * extent || c.radius < 2.0 {
            continue;
        }
        let count = points
            .iter()
            .filter(|p| distance_to_rim(p, &c) < tol)
            .count();
        if best.as_ref().is_none_or(|(b, _)| count > *b) {
            best = Some((count, c));
        }
    }
    best.map(|(_, c)| c)
}

fn bounding_extent(points: &[[f64; 2]]) -> f64 {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in points {
        x0 = x0.min(p[0]);
        x1 = x1.max(p[0]);
        y0 = y0.min(p[1]);
        y1 = y1.max(p[1]);
    }
    (x1 - x0).max(y1 - y0).max(1.0)
}

#[inline]
fn distance_to_rim(p: &[f64; 2], c: &Circle) -> f64 {
    (((p[0] - c.cx).powi(2) + (p[1] - c.cy).powi(2)).sqrt() - c.radius).abs()
}

fn inlier_mask(points: &[[f64; 2]], c: &Circle, tol: f64) -> Vec<bool> {
    points.iter().map(|p| distance_to_rim(p, c) < tol).collect()
}

fn select(points: &[[f64; 2]], keep: &[bool]) -> Vec<[f64; 2]> {
    points
        .iter()
        .zip(keep)
        .filter(|(_, &k)| k)
        .map(|(p, _)| *p)
        .collect()
}

fn geometric_cost(points: &[[f64; 2]], c: &Circle) -> f64 {
    points.iter().map(|p| distance_to_rim(p, c).powi(2)).sum()
}

/// Add one equation x·u = v to the 3×3 normal equations (a += x xᵀ, b += x v).
#[inline]
pub(crate) fn accumulate(a: &mut [[f64; 3]; 3], b: &mut [f64; 3], x: [f64; 3], v: f64) {
    for ((row, bi), xi) in a.iter_mut().zip(b.iter_mut()).zip(x) {
        for (aij, xj) in row.iter_mut().zip(x) {
            *aij += xi * xj;
        }
        *bi += xi * v;
    }
}

/// Solve a 3×3 linear system by Gaussian elimination with partial pivoting.
pub(crate) fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    let norm = a.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
    if norm.is_nan() || norm <= 0.0 {
        return None;
    }
    for col in 0..3 {
        let piv = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() <= 1e-13 * norm {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..3 {
            let f = a[row][col] / a[col][col];
            let pivot_row = a[col];
            for (dst, src) in a[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *dst -= f * src;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let s: f64 = (row + 1..3).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Some(x)
}

/// SplitMix64: a tiny deterministic generator (no external crate needed).
pub(crate) struct SplitMix(pub u64);

impl SplitMix {
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arc(c: Circle, n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let t = i as f64 / n as f64 * std::f64::consts::TAU;
                [c.cx + c.radius * t.cos(), c.cy + c.radius * t.sin()]
            })
            .collect()
    }

    #[test]
    fn exact_points_give_the_exact_circle() {
        let truth = Circle {
            cx: 12.3,
            cy: -4.5,
            radius: 33.0,
        };
        let pts = arc(truth, 40);
        let alg = fit_algebraic(&pts).unwrap();
        assert!((alg.cx - truth.cx).abs() < 1e-9 && (alg.radius - truth.radius).abs() < 1e-9);
        let t = circle_through(pts[0], pts[10], pts[25]).unwrap();
        assert!((t.cy - truth.cy).abs() < 1e-9);
        let fit = fit_robust(&pts, &FitOptions::default()).unwrap();
        assert!(fit.rms_residual_px < 1e-9);
        assert_eq!(fit.inlier_count(), 40);
    }

    #[test]
    fn collinear_points_are_rejected() {
        let pts: Vec<[f64; 2]> = (0..10).map(|i| [i as f64, 2.0 * i as f64]).collect();
        assert!(fit_algebraic(&pts).is_none());
        assert!(fit_robust(&pts, &FitOptions::default()).is_err());
    }
}
