//! Sub-pixel circle from a model of the blurred rim (refines a circle found by the
//! edge points of module `edges` or `contrast`).
//!
//! Mid-level crossings are biased on real photographs: the optics blur the rim
//! (Gaussian σ ≈ 0.5–1 px), and the sphere's radiance is not a plateau next to its
//! rim — under orthographic projection the normal turns through 90° there, so the
//! radiance changes like √s with the depth s inside the rim, and a shiny ball's rim is
//! dark. Here the image near the rim is fitted with the image formation itself:
//!
//! * **Profile across the rim**, as a function of s = ρ − d (d the distance of a point
//!   from the circle's centre, ρ the rim's radius; s > 0 inside):
//!   F(s) = b₀ + b₁·s outside (background with a gradient), a₀ + a₁·√s + a₂·s inside.
//!   The normal's angle from the view axis is φ with cos φ = 1 − s/R, a smooth function
//!   of √s, so a radiance smooth over the normal sphere is smooth in √s.
//! * **Imaging**: each pixel is the mean, over 4 × 4 sub-pixel points (their radial
//!   offsets at the sector's angle), of F convolved with a Gaussian of standard
//!   deviation σ (the optics' blur; σ → 0 is a perfect area-sampling camera). A
//!   point-sampled render (each pixel the scene at its centre, a staircase silhouette)
//!   is the same with all offsets 0; it is chosen when it fits better with a blur
//!   under 0.1 px (otherwise the two footprints differ by little more than σ).
//! * **Fit**: the rim is cut into angular sectors (about 6 px of arc each); in each,
//!   the five linear coefficients come from least squares and the rim's offset e
//!   (ρ = R + e) minimises the residual (scan, then golden section). σ is shared by
//!   all sectors and chosen to minimise the total residual (golden section). The
//!   sector points (R + e_i at the sector's angle) are fitted with the robust circle
//!   fit ([`super::fit::fit_robust`], RANSAC at 0.5 px: a stand, a touching object or
//!   a highlight at the rim drop out) and the whole is repeated about the new centre.
//! * **Uncertainty**: the covariance of that circle fit, s²(JᵀJ)⁻¹ with s² the
//!   sectors' residual variance; the standard deviations of the centre (√(var cx +
//!   var cy)) and of the radius are reported.
//!
//! The caller ([`super::detect`]) runs the fit on the maximum and on the mean image,
//! with and without the a₂·s term: the full model's fit of smaller uncertainty wins
//! ("the image that shows the edge best"), and half the largest disagreement between
//! the four fits is added to its uncertainty — a systematic term that shows when the
//! rim is ambiguous (on DiLiGenT's ball: 0.19 px; on renders: 0.01–0.03 px).
//!
//! References: Canny-free edge models of this kind go back to M. Hueckel, "An operator
//! which locates edges in digitized pictures", JACM 1971, and to the blurred-step edge
//! model of A. Nalwa & T. Binford, "On detecting edges", IEEE PAMI 1986; the sphere's
//! √s shading near an occluding contour follows from Ikeuchi & Horn, "Numerical shape
//! from shading and occluding boundaries", AI 1981.

use super::edges::View;
use super::fit::{circle_sd, fit_robust, FitOptions};
use super::Circle;
use rayon::prelude::*;
use std::borrow::Cow;

/// What the rim model found.
#[derive(Clone, Debug)]
pub(crate) struct RimFit {
    pub circle: Circle,
    /// Gaussian blur of the rim (pixels, on top of the pixel's area).
    pub sigma_px: f64,
    /// 1-σ uncertainty of the centre (pixels).
    pub centre_sd_px: f64,
    /// 1-σ uncertainty of the radius (pixels).
    pub radius_sd_px: f64,
    /// RMS distance of the sector points to the circle (pixels).
    pub rms_px: f64,
    /// The pixels fit better as point samples of the scene (a render) than as area
    /// samples (a camera).
    pub point_sampled: bool,
    /// Sectors used in the final circle fit / sectors fitted.
    pub sectors_used: usize,
    pub sectors: usize,
}

impl RimFit {
    /// The larger of the centre's and the radius' standard deviations (pixels).
    pub fn uncertainty_px(&self) -> f64 {
        self.centre_sd_px.max(self.radius_sd_px)
    }
}

/// Sub-pixel points per pixel side.
const SUB: usize = 4;
/// Largest |e| searched per sector (pixels).
const E_MAX: f64 = 2.0;
/// Largest band inside the rim used (pixels).
const INSIDE_MAX_PX: f64 = 10.0;
/// Band outside the rim used (pixels).
const OUT_PX: f64 = 5.0;
/// A point-sampled footprint is chosen only with a blur below this (pixels).
const POINT_MAX_BLUR_PX: f64 = 0.1;
/// Sector points farther than this from the circle are outliers (pixels).
const SECTOR_TOL_PX: f64 = 0.5;

/// Refine `init` on `img` (a window of the image; `init` in window coordinates) with
/// the full profile model (`linear`) or without the a₂·s term.
/// `None` when too few sectors fit (rim mostly outside the window, no contrast).
pub(crate) fn refine(img: &View, init: Circle, linear: bool) -> Option<RimFit> {
    if init.radius < 6.0 {
        return None;
    }
    let mut circle = init;
    let mut model = None;
    let mut last = None;
    for _ in 0..3 {
        let (sigma, point) = *model.get_or_insert_with(|| {
            // the pixel's footprint: its area (a camera) or its centre (a point-sampled
            // render), whichever fits better at its best blur
            let fits = [false, true]
                .map(|point| Band::new(img, &circle, point).map(|b| (b.best_sigma(linear), point)));
            // a point-sampled render has no blur at all; with blur the two footprints
            // differ by little more than σ, so the area (a camera) is kept
            match fits {
                [Some(((sa, ca), _)), Some(((sp, cp), _))] => {
                    if sp < POINT_MAX_BLUR_PX && cp < ca {
                        (sp, true)
                    } else {
                        (sa, false)
                    }
                }
                [Some(((sa, _), _)), None] => (sa, false),
                _ => (0.0, false),
            }
        });
        let band = Band::new(img, &circle, point)?;
        let mut fit = band.fit_circle(sigma, linear)?;
        fit.point_sampled = point;
        let moved = distance(&fit.circle, &circle);
        circle = fit.circle;
        last = Some(fit);
        if moved < 0.01 {
            break;
        }
    }
    let fit = last?;
    (distance(&fit.circle, &init) < E_MAX).then_some(fit)
}

/// The larger of the centres' distance and the radii's difference (pixels).
pub(crate) fn distance(a: &Circle, b: &Circle) -> f64 {
    (a.cx - b.cx)
        .hypot(a.cy - b.cy)
        .max((a.radius - b.radius).abs())
}

/// RMS residual (image units) of the full rim model with the rim on `circle` (every
/// sector's offset 0), and with each sector's offset fitted; each at its own best blur
/// (area footprint). `None` when too few sectors lie in the image.
pub(crate) fn check(img: &View, circle: &Circle) -> Option<(f64, f64)> {
    let band = Band::new(img, circle, false)?;
    let rms = |free: bool| {
        let sigma = golden(|s| band.mean_square(s, free), 0.0, 2.5, 10);
        band.mean_square(sigma, free).sqrt()
    };
    Some((rms(false), rms(true)))
}

/// Pixels near the rim, grouped by angular sector.
struct Band {
    circle: Circle,
    sectors: Vec<Sector>,
    /// Each pixel samples the scene at its centre: every sector's offsets are 0, and so
    /// its footprint is the same in every sector.
    point: bool,
}

/// One angular sector of the band.
struct Sector {
    /// Central angle (radians, image coordinates: atan2(row, col) about the centre).
    angle: f64,
    /// Radial offsets of the 4 × 4 sub-pixel points from the pixel's centre (pixels).
    offsets: [f64; SUB * SUB],
    pixels: Vec<SectorPixel>,
}

/// A pixel's value and the distance of its centre from the band's centre.
struct SectorPixel {
    value: f64,
    d: f64,
}

impl Band {
    /// `point`: each pixel samples the scene at its centre (else over its area).
    fn new(img: &View, circle: &Circle, point: bool) -> Option<Self> {
        use std::f64::consts::TAU;
        let r = circle.radius;
        let inside_px = (0.15 * r).clamp(3.0, INSIDE_MAX_PX);
        let n = ((TAU * r / 6.0).round() as usize).clamp(12, 120);
        let mut sectors: Vec<Sector> = (0..n)
            .map(|i| {
                let angle = (i as f64 + 0.5) / n as f64 * TAU;
                let offsets = std::array::from_fn(|k| {
                    let (i, j) = ((k / SUB) as f64, (k % SUB) as f64);
                    let (ox, oy) = ((j + 0.5) / SUB as f64 - 0.5, (i + 0.5) / SUB as f64 - 0.5);
                    if point {
                        0.0
                    } else {
                        ox * angle.cos() + oy * angle.sin()
                    }
                });
                Sector {
                    angle,
                    offsets,
                    pixels: Vec::new(),
                }
            })
            .collect();
        let (lo, hi) = (r - inside_px, r + OUT_PX);
        let rows = (circle.cy - hi).floor().max(0.0) as usize
            ..((circle.cy + hi).ceil().max(0.0) as usize).min(img.height);
        for row in rows {
            let cols = (circle.cx - hi).floor().max(0.0) as usize
                ..((circle.cx + hi).ceil().max(0.0) as usize).min(img.width);
            for col in cols {
                let (dx, dy) = (col as f64 + 0.5 - circle.cx, row as f64 + 0.5 - circle.cy);
                let d = dx.hypot(dy);
                let value = img.data[row * img.width + col] as f64;
                if d < lo || d > hi || !value.is_finite() {
                    continue;
                }
                let a = dy.atan2(dx).rem_euclid(TAU);
                let s = ((a / TAU * n as f64) as usize).min(n - 1);
                sectors[s].pixels.push(SectorPixel { value, d });
            }
        }
        // a sector needs most of its band: the rest is cut by the window
        let full = (hi * hi - lo * lo) * std::f64::consts::PI / n as f64;
        sectors.retain(|s| s.pixels.len() as f64 > 0.8 * full);
        (sectors.len() >= 8).then_some(Band {
            circle: *circle,
            sectors,
            point,
        })
    }

    /// Blur σ minimising the summed residual of every other sector (golden section on
    /// σ ∈ [0, 2.5] px), and that residual.
    fn best_sigma(&self, linear: bool) -> (f64, f64) {
        let total = |sigma: f64| -> f64 {
            let basis = Basis::new(sigma, linear);
            let shared = self.shared_footprint(&basis);
            // sectors fitted in parallel, summed in order (the same sum on any thread count)
            let costs: Vec<f64> = (self.sectors.par_iter().step_by(2))
                .map(|s| {
                    self.sector_fit(&basis, shared.as_ref(), s)
                        .map_or(0.0, |f| f.1)
                })
                .collect();
            costs.iter().sum()
        };
        let sigma = golden(total, 0.0, 2.5, 10);
        (sigma, total(sigma))
    }

    /// Mean squared residual per pixel over all sectors at blur `sigma` (full model),
    /// with the rim on the band's circle or (`free`) each sector's offset fitted.
    fn mean_square(&self, sigma: f64, free: bool) -> f64 {
        let basis = Basis::new(sigma, true);
        let shared = self.shared_footprint(&basis);
        let (mut sum, mut n) = (0.0, 0usize);
        for s in &self.sectors {
            let fixed = || {
                let foot = footprint(&basis, shared.as_ref(), s);
                residual(&foot, &s.pixels, self.circle.radius)
            };
            let c = if free {
                self.sector_fit(&basis, shared.as_ref(), s)
                    .map_or_else(fixed, |f| f.1)
            } else {
                fixed()
            };
            if c.is_finite() {
                sum += c * s.pixels.len() as f64;
                n += s.pixels.len();
            }
        }
        if n == 0 {
            f64::INFINITY
        } else {
            sum / n as f64
        }
    }

    /// The sector points at blur `sigma`, fitted by the robust circle fit.
    fn fit_circle(&self, sigma: f64, linear: bool) -> Option<RimFit> {
        let basis = Basis::new(sigma, linear);
        let shared = self.shared_footprint(&basis);
        let points: Vec<[f64; 2]> = self
            .sectors
            .par_iter()
            .filter_map(|s| {
                let (e, _) = self.sector_fit(&basis, shared.as_ref(), s)?;
                let rho = self.circle.radius + e;
                Some([
                    self.circle.cx + rho * s.angle.cos(),
                    self.circle.cy + rho * s.angle.sin(),
                ])
            })
            .collect();
        if points.len() < 8 {
            return None;
        }
        let opts = FitOptions {
            inlier_tol_px: SECTOR_TOL_PX,
            ..FitOptions::default()
        };
        let fit = fit_robust(&points, &opts).ok()?;
        let used: Vec<[f64; 2]> = points
            .iter()
            .zip(&fit.inliers)
            .filter(|(_, &k)| k)
            .map(|(p, _)| *p)
            .collect();
        if used.len() < 8 || used.len() * 2 < points.len() {
            return None;
        }
        let (centre_sd_px, radius_sd_px) = circle_sd(&used, &fit.circle)?;
        Some(RimFit {
            circle: fit.circle,
            sigma_px: sigma,
            point_sampled: false,
            centre_sd_px,
            radius_sd_px,
            rms_px: fit.rms_residual_px,
            sectors_used: used.len(),
            sectors: self.sectors.len(),
        })
    }

    /// The footprint that every sector shares when the band is point-sampled (built once
    /// per blur instead of once per sector); `None` for an area footprint.
    fn shared_footprint(&self, basis: &Basis) -> Option<Footprint> {
        let first = self.sectors.first().filter(|_| self.point)?;
        Some(Footprint::new(basis, &first.offsets))
    }

    /// Offset e of the rim in one sector and the residual sum of squares there, with the
    /// band's `shared` footprint, or else the sector's own.
    fn sector_fit(
        &self,
        basis: &Basis,
        shared: Option<&Footprint>,
        sector: &Sector,
    ) -> Option<(f64, f64)> {
        let table = footprint(basis, shared, sector);
        let cost = |e: f64| residual(&table, &sector.pixels, self.circle.radius + e);
        // coarse scan, then golden section around the best
        let step = 0.25;
        let n = (2.0 * E_MAX / step) as usize;
        let (mut best_e, mut best_c) = (0.0, f64::INFINITY);
        for i in 0..=n {
            let e = -E_MAX + i as f64 * step;
            let c = cost(e);
            if c < best_c {
                (best_e, best_c) = (e, c);
            }
        }
        if !best_c.is_finite() {
            return None;
        }
        let e = golden(cost, best_e - step, best_e + step, 12);
        if e.abs() >= E_MAX - 0.05 {
            return None;
        }
        Some((e, cost(e)))
    }
}

/// The basis seen through a pixel of the sector: the mean over its 4 × 4 sub-pixel
/// points, tabulated in s (the pixel centre's depth inside the rim).
#[derive(Clone)]
struct Footprint {
    table: Vec<[f64; 5]>,
}

const FOOT_LO: f64 = -(OUT_PX + E_MAX + 1.0);
const FOOT_HI: f64 = INSIDE_MAX_PX + E_MAX + 1.0;
const FOOT_STEP: f64 = 0.05;

impl Footprint {
    fn new(basis: &Basis, offsets: &[f64; SUB * SUB]) -> Self {
        let n = ((FOOT_HI - FOOT_LO) / FOOT_STEP) as usize + 2;
        let table = (0..n)
            .map(|i| {
                let s = FOOT_LO + i as f64 * FOOT_STEP;
                let mut v = [0.0f64; 5];
                for o in offsets {
                    // a sub-pixel point farther out by o is o less deep
                    let b = basis.at(s - o);
                    for k in 0..5 {
                        v[k] += b[k];
                    }
                }
                v.map(|x| x / (SUB * SUB) as f64)
            })
            .collect();
        Footprint { table }
    }

    #[inline]
    fn at(&self, s: f64) -> [f64; 5] {
        let f = ((s - FOOT_LO) / FOOT_STEP).clamp(0.0, (self.table.len() - 2) as f64);
        let i = f as usize;
        let t = f - i as f64;
        let (a, b) = (self.table[i], self.table[i + 1]);
        std::array::from_fn(|k| a[k] + t * (b[k] - a[k]))
    }
}

/// The footprint of `sector`: the band's `shared` one, or else the sector's own.
fn footprint<'a>(
    basis: &Basis,
    shared: Option<&'a Footprint>,
    sector: &Sector,
) -> Cow<'a, Footprint> {
    shared.map_or_else(
        || Cow::Owned(Footprint::new(basis, &sector.offsets)),
        Cow::Borrowed,
    )
}

/// Residual sum of squares (per pixel) of the linear least-squares fit of the profile
/// model with the rim at radius `rho`.
fn residual(foot: &Footprint, rows: &[SectorPixel], rho: f64) -> f64 {
    let n = rows.len();
    if n < 12 {
        return f64::INFINITY;
    }
    // centre the values for conditioning
    let mean = rows.iter().map(|p| p.value).sum::<f64>() / n as f64;
    // AᵀA is symmetric: its upper triangle is accumulated and mirrored (the same products
    // in the same order, so the same sums as the full square)
    let mut ata = [[0.0f64; 5]; 5];
    let mut atb = [0.0f64; 5];
    let mut btb = 0.0;
    for p in rows {
        let v = foot.at(rho - p.d);
        let y = p.value - mean;
        for i in 0..5 {
            for j in i..5 {
                ata[i][j] += v[i] * v[j];
            }
            atb[i] += v[i] * y;
        }
        btb += y * y;
    }
    let ata = std::array::from_fn(|i| std::array::from_fn(|j| ata[i.min(j)][i.max(j)]));
    let Some(x) = solve5(ata, atb) else {
        return f64::INFINITY;
    };
    // rss = bᵀb − xᵀAᵀb at the least-squares solution
    let explained: f64 = x.iter().zip(&atb).map(|(a, b)| a * b).sum();
    (btb - explained).max(0.0) / n as f64
}

/// Gaussian-blurred profile basis: outside 1, s; inside 1, √s, s (s = ρ − d, > 0 inside),
/// tabulated on a fine grid of s.
struct Basis {
    sigma: f64,
    /// With the a₂·s term inside (off: a₀ + a₁√s only).
    linear: bool,
    table: Vec<[f64; 5]>,
}

const TABLE_HALF: f64 = 16.0;
const TABLE_STEP: f64 = 0.01;

impl Basis {
    fn new(sigma: f64, linear: bool) -> Self {
        let n = (2.0 * TABLE_HALF / TABLE_STEP) as usize + 1;
        let table = if sigma < 1e-3 {
            Vec::new()
        } else {
            (0..n)
                .map(|i| blurred(-TABLE_HALF + i as f64 * TABLE_STEP, sigma))
                .collect()
        };
        Basis {
            sigma,
            linear,
            table,
        }
    }

    /// The five basis values at s (the last one 0 without the linear term).
    #[inline]
    fn at(&self, s: f64) -> [f64; 5] {
        let mut b = self.lookup(s);
        if !self.linear {
            b[4] = 0.0;
        }
        b
    }

    #[inline]
    fn lookup(&self, s: f64) -> [f64; 5] {
        if self.sigma < 1e-3 {
            return blurred(s, 0.0);
        }
        let f = ((s + TABLE_HALF) / TABLE_STEP).clamp(0.0, (self.table.len() - 2) as f64);
        let i = f as usize;
        let t = f - i as f64;
        let (a, b) = (self.table[i], self.table[i + 1]);
        std::array::from_fn(|k| a[k] + t * (b[k] - a[k]))
    }
}

/// E[f_k(s + σZ)], Z standard normal, for the five basis functions.
fn blurred(s: f64, sigma: f64) -> [f64; 5] {
    if sigma < 1e-3 {
        let out = s < 0.0;
        return if out {
            [1.0, s, 0.0, 0.0, 0.0]
        } else {
            [0.0, 0.0, 1.0, s.sqrt(), s]
        };
    }
    let z = s / sigma;
    let (cdf, pdf) = (normal_cdf(z), normal_pdf(z));
    [
        1.0 - cdf,
        s * (1.0 - cdf) - sigma * pdf,
        cdf,
        blurred_sqrt(s, sigma),
        s * cdf + sigma * pdf,
    ]
}

/// E[√(s + σZ) · 1{s + σZ > 0}] by Simpson's rule in u = √(s + σz) (smooth integrand).
fn blurred_sqrt(s: f64, sigma: f64) -> f64 {
    let hi = s + 8.0 * sigma;
    if hi <= 0.0 {
        return 0.0;
    }
    let (u0, u1) = ((s - 8.0 * sigma).max(0.0).sqrt(), hi.sqrt());
    let m = 64;
    let h = (u1 - u0) / m as f64;
    let f = |u: f64| {
        let z = (u * u - s) / sigma;
        u * normal_pdf(z) * 2.0 * u / sigma
    };
    let mut acc = f(u0) + f(u1);
    for i in 1..m {
        acc += f(u0 + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    acc * h / 3.0
}

fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (std::f64::consts::TAU).sqrt()
}

/// Standard normal CDF through erfc (Numerical Recipes' Chebyshev fit, |ε| < 1.2e-7).
pub(crate) fn normal_cdf(z: f64) -> f64 {
    let x = -z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let y = t
        * (-x * x - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    let erfc = if x >= 0.0 { y } else { 2.0 - y };
    0.5 * erfc
}

/// Golden-section minimum of `f` on [a, b] after `iters` steps.
pub(crate) fn golden(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, iters: usize) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = b - g * (b - a);
    let mut x2 = a + g * (b - a);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..iters {
        if f1 <= f2 {
            b = x2;
            (x2, f2) = (x1, f1);
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            (x1, f1) = (x2, f2);
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
    }
    0.5 * (a + b)
}

/// Solve a 5×5 symmetric system (Gaussian elimination, partial pivoting, tiny ridge).
fn solve5(mut a: [[f64; 5]; 5], mut b: [f64; 5]) -> Option<[f64; 5]> {
    let norm = (0..5).map(|i| a[i][i]).fold(0.0, f64::max);
    if norm.is_nan() || norm <= 0.0 {
        return None;
    }
    for (i, row) in a.iter_mut().enumerate() {
        row[i] += 1e-10 * norm;
    }
    for col in 0..5 {
        let piv = (col..5).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() <= 1e-14 * norm {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..5 {
            let f = a[row][col] / a[col][col];
            let pivot_row = a[col];
            for (dst, src) in a[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *dst -= f * src;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 5];
    for row in (0..5).rev() {
        let s: f64 = (row + 1..5).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_sampled_band_fits_alike_with_its_shared_footprint() {
        // a bright disk of radius 30 sampled at pixel centres
        let (w, c) = (80usize, 40.0);
        let data: Vec<f32> = (0..w * w)
            .map(|i| {
                let (x, y) = ((i % w) as f64 + 0.5 - c, (i / w) as f64 + 0.5 - c);
                if x.hypot(y) < 30.0 {
                    0.8
                } else {
                    0.1
                }
            })
            .collect();
        let view = View {
            width: w,
            height: w,
            data: &data,
        };
        let circle = Circle {
            cx: c + 0.3,
            cy: c - 0.2,
            radius: 29.6,
        };
        let band = Band::new(&view, &circle, true).expect("band");
        let basis = Basis::new(0.4, true);
        let shared = band.shared_footprint(&basis).expect("point band shares");
        let mut fitted = 0;
        for s in &band.sectors {
            let own = band.sector_fit(&basis, None, s);
            assert_eq!(band.sector_fit(&basis, Some(&shared), s), own);
            fitted += usize::from(own.is_some());
        }
        assert!(
            fitted >= 8,
            "{fitted} of {} sectors fitted",
            band.sectors.len()
        );
        assert!(Band::new(&view, &circle, false)
            .unwrap()
            .shared_footprint(&basis)
            .is_none());
    }

    #[test]
    fn blurred_basis_matches_quadrature() {
        // E[f(s + σZ)] by brute-force quadrature over z
        for &(s, sigma) in &[(-0.7, 0.6), (0.0, 0.8), (0.4, 0.5), (2.5, 1.2)] {
            let mut acc = [0.0f64; 5];
            let n = 200_000;
            for i in 0..n {
                let z = -9.0 + 18.0 * (i as f64 + 0.5) / n as f64;
                let w = normal_pdf(z) * 18.0 / n as f64;
                let b = blurred(s + sigma * z, 0.0);
                for k in 0..5 {
                    acc[k] += w * b[k];
                }
            }
            let got = blurred(s, sigma);
            for k in 0..5 {
                assert!(
                    (got[k] - acc[k]).abs() < 1e-5,
                    "k {k} s {s}: {} vs {}",
                    got[k],
                    acc[k]
                );
            }
        }
    }
}
