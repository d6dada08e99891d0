//! The silhouette from the **lit arcs**: each image's rim where that image lights it,
//! located by the blurred step's outer tail alone. A cross-check of the rim model
//! (module `rim`), whose fit on the maximum and mean images must model the shading
//! next to the rim; here nothing inside the rim beyond a level is modelled.
//!
//! # Method ([`fit`])
//!
//! * **Profiles**: about a starting circle (centre c, radius R), along each of 360
//!   rays (1°) and in each image k, the bilinear profile p_k(t) at offsets
//!   t ∈ [−4, 4] px from the rim (0.05 px apart). Its inner level a = mean of p over
//!   t ∈ [−2, −1], its background b = median of p over t ∈ [2, 4].
//! * **Lit arcs**: a ray keeps the images whose contrast a − b is at least half the best
//!   contrast on that ray (the images that light the rim there: a shiny ball's rim is
//!   dark under the others). Their profiles, normalised to (p − b)/(a − b), are averaged
//!   in 72 sectors of 5°.
//! * **Outer tail**: outside an edge at t = e blurred by a Gaussian of σ, the profile
//!   is g·Φ((e − t)/σ) plus contributions of the inside that decay like the Gaussian's
//!   tail; it is fitted on the 2 px from the sector's half-level crossing outward:
//!   g by least squares, e by golden section, σ shared by all sectors (a grid of
//!   0.05 px). The inner level's own shape (the shading next to the rim, the material's
//!   darkening at grazing view) does not enter.
//! * **Circle**: the 72 points (R + e at each sector's angle) by the robust circle fit
//!   ([`super::fit::fit_robust`]).
//!
//! σ includes the pixel's area and the bilinear sampling (0.5 px on a blur-free
//! render). Measured on the Mitsuba renders of a sphere of radius 100 px: radius
//! −0.010 / −0.025 px, centre < 0.001 px. Under optical blur the shading next to the
//! rim leaks into the tail and pulls the edge inward: on `sphere_rim`'s synthetic
//! spheres radius −0.11 / −0.17 / −0.17 px at σ 0.5 / 0.75 / 1 px, −0.48 px with a
//! dark rim — a lower bound on the radius, not a detector.
//!
//! # The rim model on the lit arcs ([`rim_model`])
//!
//! The lit profiles also make a **composite image** near the rim — each pixel the mean
//! normalised value of the images that light the rim at its angle — on which the rim
//! model of module `rim` (blurred step, a₀ + a₁√s + a₂s inside) is fitted. It sees the
//! rim where it is lit, never the dark rim of the maximum image's other images: on
//! `sphere_rim`'s synthetic spheres within 0.025 px under blur σ 0.5–1 px, a stand, a
//! grey background and 8 bits; −0.06 px with a dark rim, −0.08 px with all defects
//! (the rim model on the maximum image: +0.13 / +0.14 px there).

use super::edges::View;
use super::fit::{fit_robust, FitOptions};
use super::rim::{golden, normal_cdf};
use super::Circle;
use crate::image::ImageStack;
use rayon::prelude::*;

/// What the lit-arc fit found.
#[derive(Clone, Debug)]
pub struct LitArcFit {
    /// The silhouette's circle (pixels).
    pub circle: Circle,
    /// Blur of the edge, pixel area and sampling included (pixels).
    pub sigma_px: f64,
    /// RMS distance of the sector points to the circle (pixels).
    pub rms_px: f64,
    /// Sectors with a lit profile (of 72).
    pub sectors_used: usize,
}

const RAYS: usize = 360;
const SECTORS: usize = 72;
const STEP: f64 = 0.05;
const HALF: f64 = 4.0;
const SAMPLES: usize = 161; // 2·HALF/STEP + 1

/// Fit the silhouette's circle from the lit arcs about `start` (see the module docs).
/// `None` when fewer than 24 sectors have a lit profile or the fit fails.
pub fn fit(stack: &ImageStack, start: &Circle) -> Option<LitArcFit> {
    if stack.k == 0 || start.radius < 3.0 * HALF {
        return None;
    }
    let sectors = sector_profiles(stack, start);
    let used: Vec<(usize, &Vec<f64>)> = sectors
        .iter()
        .enumerate()
        .filter_map(|(i, p)| p.as_ref().map(|p| (i, p)))
        .collect();
    if used.len() < 24 {
        return None;
    }
    let tails: Vec<(usize, usize, &Vec<f64>)> = used
        .iter()
        .filter_map(|&(i, p)| half_crossing(p).map(|c| (i, c, p)))
        .collect();
    if tails.len() < 24 {
        return None;
    }
    let total =
        |sigma: f64| -> f64 { tails.iter().map(|&(_, c, p)| fit_tail(p, c, sigma).1).sum() };
    let sigma = (4..=32)
        .map(|i| 0.05 * i as f64)
        .min_by(|a, b| total(*a).total_cmp(&total(*b)))?;
    let points: Vec<[f64; 2]> = tails
        .iter()
        .map(|&(i, c, p)| {
            let e = fit_tail(p, c, sigma).0;
            let phi = ((i as f64 + 0.5) * 360.0 / SECTORS as f64).to_radians();
            let rho = start.radius + e;
            [start.cx + rho * phi.cos(), start.cy + rho * phi.sin()]
        })
        .collect();
    let opts = FitOptions {
        inlier_tol_px: 0.5,
        ..FitOptions::default()
    };
    let f = fit_robust(&points, &opts).ok()?;
    Some(LitArcFit {
        circle: f.circle,
        sigma_px: sigma,
        rms_px: f.rms_residual_px,
        sectors_used: f.inlier_count(),
    })
}

/// Offset (px from the starting rim) of profile sample `i`.
fn offset(i: usize) -> f64 {
    -HALF + STEP * i as f64
}

/// The K images as separate planes (row-major).
fn planes(stack: &ImageStack) -> Vec<Vec<f32>> {
    (0..stack.k)
        .into_par_iter()
        .map(|k| stack.image(k).data)
        .collect()
}

/// The images that light the rim along a ray: contrast positive and at least half the
/// best on that ray (`ray` as from [`ray_profiles`]).
fn lit(ray: &[(f64, f64, Vec<f64>)]) -> impl Iterator<Item = usize> + '_ {
    let best = ray.iter().map(|r| r.0).fold(0.0, f64::max);
    (0..ray.len()).filter(move |&k| ray[k].0 > 0.0 && ray[k].0 >= 0.5 * best)
}

/// Per sector, the mean normalised profile of its lit rays and images (`None` where
/// no ray of the sector lies in the image or nothing is lit).
fn sector_profiles(stack: &ImageStack, c: &Circle) -> Vec<Option<Vec<f64>>> {
    let planes = planes(stack);
    let rays: Vec<Vec<(f64, f64, Vec<f64>)>> = (0..RAYS)
        .into_par_iter()
        .map(|j| ray_profiles(stack, &planes, c, j))
        .collect();
    let per = RAYS / SECTORS;
    (0..SECTORS)
        .map(|s| {
            let mut acc = vec![0.0; SAMPLES];
            let mut n = 0usize;
            for ray in &rays[s * per..(s + 1) * per] {
                for k in lit(ray) {
                    acc.iter_mut().zip(&ray[k].2).for_each(|(a, v)| *a += v);
                    n += 1;
                }
            }
            (n > 0).then(|| acc.iter().map(|a| a / n as f64).collect())
        })
        .collect()
}

/// Contrast, background and normalised profile of each image along ray `j` (empty when the ray
/// leaves the image).
fn ray_profiles(
    stack: &ImageStack,
    planes: &[Vec<f32>],
    c: &Circle,
    j: usize,
) -> Vec<(f64, f64, Vec<f64>)> {
    let phi = (j as f64 * 360.0 / RAYS as f64).to_radians();
    let (du, dv) = (phi.cos(), phi.sin());
    let outer = c.radius + HALF + 1.0;
    let (w, h) = (stack.width as f64, stack.height as f64);
    let (ex, ey) = (c.cx + outer * du, c.cy + outer * dv);
    if !(0.0..w).contains(&ex) || !(0.0..h).contains(&ey) {
        return Vec::new();
    }
    planes
        .iter()
        .map(|plane| {
            let view = View {
                width: stack.width,
                height: stack.height,
                data: plane,
            };
            let p: Vec<f64> = (0..SAMPLES)
                .map(|i| {
                    let rho = c.radius + offset(i);
                    view.bilinear(c.cx + rho * du, c.cy + rho * dv)
                })
                .collect();
            let inner = p[40..=60].iter().sum::<f64>() / 21.0;
            let mut bg = p[120..].to_vec();
            bg.sort_by(f64::total_cmp);
            let b = bg[bg.len() / 2];
            let con = inner - b;
            let norm = p.iter().map(|v| (v - b) / con.max(1e-12)).collect();
            (con, b, norm)
        })
        .collect()
}

/// Index of the last sample before the normalised profile falls below 0.5 (outward),
/// searched from 2 px inside; `None` without a crossing.
fn half_crossing(p: &[f64]) -> Option<usize> {
    (40..SAMPLES - 1).rfind(|&i| p[i] >= 0.5 && p[i + 1] < 0.5)
}

/// Edge offset e and residual of g·Φ((e − t)/σ) on the 2 px outward from sample `c`.
fn fit_tail(p: &[f64], c: usize, sigma: f64) -> (f64, f64) {
    let start = c.saturating_sub(10);
    let idx = start..(start + 40).min(SAMPLES);
    let sse = |e: f64| -> f64 {
        let (mut gy, mut gg) = (0.0, 0.0);
        for i in idx.clone() {
            let g = normal_cdf((e - offset(i)) / sigma);
            gy += g * p[i];
            gg += g * g;
        }
        let a = gy / gg.max(1e-300);
        idx.clone()
            .map(|i| (p[i] - a * normal_cdf((e - offset(i)) / sigma)).powi(2))
            .sum()
    };
    let t0 = offset(c);
    let e = golden(sse, t0 - 1.0, t0 + 1.0, 40);
    (e, sse(e))
}

/// The rim model (module `rim`, full profile) fitted on the **lit-arc composite**: near
/// the rim each pixel is the mean, over the images that light the rim at its angle
/// (contrast at least half the best on that 1° ray), of (I_k − b_k)/(a_k − b_k).
/// Returns the circle, the blur and the fit's 1-σ uncertainty (pixels).
pub fn rim_model(stack: &ImageStack, start: &Circle) -> Option<(Circle, f64, f64)> {
    if stack.k == 0 || start.radius < 3.0 * HALF {
        return None;
    }
    let planes = planes(stack);
    // per ray: (image, background, contrast) of the lit images
    let lit: Vec<Vec<(usize, f64, f64)>> = (0..RAYS)
        .into_par_iter()
        .map(|j| {
            let ray = ray_profiles(stack, &planes, start, j);
            lit(&ray).map(|k| (k, ray[k].1, ray[k].0)).collect()
        })
        .collect();
    let (w, h) = (stack.width, stack.height);
    let composite: Vec<f32> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let (dx, dy) = (x - start.cx, y - start.cy);
            let d = dx.hypot(dy);
            if d < start.radius - 12.0 || d > start.radius + 7.0 {
                return 0.0;
            }
            let j = (dy.atan2(dx).to_degrees().rem_euclid(360.0).round() as usize) % RAYS;
            let sel = &lit[j];
            if sel.is_empty() {
                return 0.0;
            }
            let s: f64 = sel
                .iter()
                .map(|&(k, b, con)| (planes[k][i] as f64 - b) / con)
                .sum();
            (s / sel.len() as f64) as f32
        })
        .collect();
    let view = View {
        width: w,
        height: h,
        data: &composite,
    };
    let f = super::rim::refine(&view, *start, true)?;
    Some((f.circle, f.sigma_px, f.uncertainty_px()))
}
