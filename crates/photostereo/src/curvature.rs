//! Curvature of the surface from its normals, for inspection (scratches, dents, bumps
//! show as curvature where the depth map hides them under its overall shape).
//!
//! # Maths
//!
//! In the crate's frame (x right, y up, one pixel = one unit, orthographic) the surface
//! is a graph z(x, y) with unit normal n = (−p, −q, 1)/√(1 + p² + q²). Then
//! ∇z/√(1 + |∇z|²) = −(n_x, n_y), and the mean curvature, signed **positive where the
//! surface bulges toward the camera**, is
//!
//! H = ½ (∂n_x/∂x + ∂n_y/∂y)   (1/pixel).
//!
//! The Gaussian curvature is the area ratio of the Gauss map: the unit sphere's area
//! element in (n_x, n_y) is dn_x dn_y / n_z and the surface's is dx dy / n_z, so
//!
//! K = ∂n_x/∂x · ∂n_y/∂y − ∂n_x/∂y · ∂n_y/∂x   (1/pixel²).
//!
//! A sphere of radius R seen from outside has n = (x, y, z)/R, hence H = 1/R and
//! K = 1/R² everywhere, up to the rim. Both are computed from the normals, not from an
//! integrated depth (no integration error; a depth map's second differences amplify its
//! noise twice). Rows grow downward, so ∂/∂y = −∂/∂row.
//!
//! The normals are first smoothed by a Gaussian of [`Options::sigma`] pixels, normalised
//! over the mask (pixels outside it neither contribute nor receive), then renormalised;
//! derivatives are central differences, one-sided where one neighbour is outside the
//! mask, NaN where both are. Smoothing keeps a linear normal field (a sphere) unchanged
//! away from the mask's edge and trades resolution for noise: features narrower than
//! about 2σ are flattened.

use crate::error::{Error, Result, Setting};
use crate::image::{GrayImage, Image, Mask, NormalMap};
use rayon::prelude::*;

/// Settings of [`solve`].
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Standard deviation of the Gaussian that smooths the normals before
    /// differentiation, pixels; 0 = none. Default 1.
    pub sigma: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options { sigma: 1.0 }
    }
}

impl Options {
    /// Errors ([`Error::Setting`]) for a `sigma` that is negative or not finite.
    pub fn check(&self) -> Result<()> {
        if self.sigma.is_finite() && self.sigma >= 0.0 {
            return Ok(());
        }
        Err(Error::setting(
            Setting::CurvatureScale,
            format!("curvature smoothing scale {} px", self.sigma),
            "it takes a finite number of pixels >= 0 (0 = no smoothing)",
        ))
    }
}

/// Curvature maps (H, W), NaN outside the mask and where no derivative exists.
#[derive(Clone, Debug)]
pub struct Curvature {
    /// Mean curvature H, 1/pixel, positive where the surface bulges toward the camera.
    pub mean: GrayImage,
    /// Gaussian curvature K, 1/pixel², positive on domes and dimples, negative on saddles.
    pub gaussian: GrayImage,
    /// Median of |H| over the pixels where it is finite (0 when none): the map's scale.
    pub median_abs_mean: f32,
    /// 99th percentile of |H| (0 when none): the symmetric range a signed picture uses.
    pub display_limit: f32,
}

/// Mean and Gaussian curvature of the surface whose unit normals are `normals` inside
/// `mask` (see the module docs for the equations).
///
/// Errors: `mask` of another size than `normals`; a `sigma` that is negative or not finite.
///
/// ```
/// use photostereo::curvature::{solve, Options};
/// use photostereo::image::{Image, Mask};
/// // a sphere of radius 40 px filling a 64² image: H = 1/40 everywhere
/// let r = 40.0_f32;
/// let n = Image::from_fn(64, 64, |row, col| {
///     let (x, y) = (col as f32 + 0.5 - 32.0, 32.0 - row as f32 - 0.5);
///     [x / r, y / r, (1.0 - (x * x + y * y) / (r * r)).sqrt()]
/// });
/// let c = solve(&n, &Mask::full(64, 64), &Options::default()).unwrap();
/// assert!((c.mean.get(32, 32) * r - 1.0).abs() < 0.01);
/// assert!((c.gaussian.get(32, 32) * r * r - 1.0).abs() < 0.02);
/// ```
pub fn solve(normals: &NormalMap, mask: &Mask, opts: &Options) -> Result<Curvature> {
    if !mask.same_size(normals) {
        return Err(Error::invalid(
            format!(
                "curvature: a {}x{} mask for {}x{} normals",
                mask.width, mask.height, normals.width, normals.height
            ),
            "give the mask of the normal map (same width and height)",
        ));
    }
    opts.check()?;
    let valid = Image::from_fn(mask.width, mask.height, |r, c| {
        *mask.get(r, c) && normals.get(r, c).iter().all(|v| v.is_finite()) && {
            let n = normals.get(r, c);
            n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 0.25
        }
    });
    let smooth = smooth_normals(normals, &valid, opts.sigma);
    let (mean, gaussian) = curvatures(&smooth, &valid);
    let abs: Vec<f32> = mean.data.iter().map(|h| h.abs()).collect();
    let median_abs_mean = crate::picture::quantile(abs.iter().copied(), 0.5).unwrap_or(0.0);
    let display_limit = crate::picture::quantile(abs.into_iter(), 0.99).unwrap_or(0.0);
    Ok(Curvature {
        mean,
        gaussian,
        median_abs_mean,
        display_limit,
    })
}

/// Normalised Gaussian smoothing of the unit normals over `valid` (separable, radius
/// 3σ), renormalised to unit length; `sigma` 0 returns them unchanged.
///
/// Row by row, in parallel: each output row sums the row-smoothed rows around it, each
/// made when needed (2·3σ + 1 per row), so no full-size intermediate is held (a 4096²
/// capture would need three of 270 MB each); the sums are those of a row pass then a
/// column pass, in the same order.
fn smooth_normals(normals: &NormalMap, valid: &Mask, sigma: f32) -> NormalMap {
    if sigma == 0.0 {
        return normals.clone();
    }
    let radius = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f32> = (-radius..=radius)
        .map(|d| (-(d * d) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let (w, h) = (normals.width, normals.height);
    // weighted sample (n_x, n_y, n_z, weight) at (r, c)
    let sample = |r: usize, c: usize| -> [f32; 4] {
        let n = normals.get(r, c);
        if *valid.get(r, c) {
            [n[0], n[1], n[2], 1.0]
        } else {
            [0.0; 4]
        }
    };
    let mut out = normals.clone();
    out.data
        .par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(r, row)| {
            let mut both = vec![[0.0f32; 4]; w];
            let mut along = vec![[0.0f32; 4]; w];
            for (i, kd) in kernel.iter().enumerate() {
                let rr = r as isize + i as isize - radius;
                if rr < 0 || rr >= h as isize {
                    continue;
                }
                convolve_row(|c| sample(rr as usize, c), w, &kernel, &mut along);
                for (b, a) in both.iter_mut().zip(&along) {
                    for (x, y) in b.iter_mut().zip(a) {
                        *x += kd * y;
                    }
                }
            }
            for (c, (o, s)) in row.iter_mut().zip(&both).enumerate() {
                let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
                if *valid.get(r, c) && len > 0.0 {
                    *o = [s[0] / len, s[1] / len, s[2] / len];
                }
            }
        });
    out
}

/// A 1-D convolution with `kernel` (odd length) of the row `at(c)`, c < w, into `out`;
/// samples beyond the row count as zero.
fn convolve_row(at: impl Fn(usize) -> [f32; 4], w: usize, kernel: &[f32], out: &mut [[f32; 4]]) {
    let radius = (kernel.len() / 2) as isize;
    for (c, o) in out.iter_mut().enumerate() {
        let mut acc = [0.0f32; 4];
        for (i, k) in kernel.iter().enumerate() {
            let cc = c as isize + i as isize - radius;
            if cc >= 0 && cc < w as isize {
                let v = at(cc as usize);
                for (a, x) in acc.iter_mut().zip(v) {
                    *a += k * x;
                }
            }
        }
        *o = acc;
    }
}

/// Mean and Gaussian curvature of unit normals `n` at the `valid` pixels.
fn curvatures(n: &NormalMap, valid: &Mask) -> (GrayImage, GrayImage) {
    let (w, h) = (n.width, n.height);
    let mut mean = Image::filled(w, h, f32::NAN);
    let mut gauss = Image::filled(w, h, f32::NAN);
    for r in 0..h {
        for c in 0..w {
            if !*valid.get(r, c) {
                continue;
            }
            let along_row = derivative(n, valid, r, c, (0, 1));
            let along_col = derivative(n, valid, r, c, (1, 0));
            if let (Some(dc), Some(dr)) = (along_row, along_col) {
                // ∂/∂x = ∂/∂col, ∂/∂y = −∂/∂row
                let (nx_x, ny_x) = (dc[0], dc[1]);
                let (nx_y, ny_y) = (-dr[0], -dr[1]);
                *mean.get_mut(r, c) = 0.5 * (nx_x + ny_y);
                *gauss.get_mut(r, c) = nx_x * ny_y - nx_y * ny_x;
            }
        }
    }
    (mean, gauss)
}

/// Derivative of (n_x, n_y) at (r, c) one step along `step` (row, col): central where
/// both neighbours are valid, one-sided where one is, `None` where neither.
fn derivative(
    n: &NormalMap,
    valid: &Mask,
    r: usize,
    c: usize,
    step: (usize, usize),
) -> Option<[f32; 2]> {
    let at = |rr: Option<usize>, cc: Option<usize>| {
        let (rr, cc) = (rr?, cc?);
        (rr < n.height && cc < n.width && *valid.get(rr, cc)).then(|| *n.get(rr, cc))
    };
    let next = at(Some(r + step.0), Some(c + step.1));
    let prev = at(r.checked_sub(step.0), c.checked_sub(step.1));
    let here = *n.get(r, c);
    let (a, b, span) = match (prev, next) {
        (Some(p), Some(q)) => (p, q, 2.0),
        (None, Some(q)) => (here, q, 1.0),
        (Some(p), None) => (p, here, 1.0),
        (None, None) => return None,
    };
    Some([(b[0] - a[0]) / span, (b[1] - a[1]) / span])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit normals of a sphere of radius `radius` centred in a `size`² image, the mask
    /// its visible disc shrunk by `margin` pixels.
    fn sphere(size: usize, radius: f32, margin: f32) -> (NormalMap, Mask) {
        let half = size as f32 / 2.0;
        let xy = |r: usize, c: usize| (c as f32 + 0.5 - half, half - r as f32 - 0.5);
        let n = Image::from_fn(size, size, |r, c| {
            let (x, y) = xy(r, c);
            let z2 = radius * radius - x * x - y * y;
            if z2 > 0.0 {
                [x / radius, y / radius, z2.sqrt() / radius]
            } else {
                [0.0; 3]
            }
        });
        let m = Image::from_fn(size, size, |r, c| {
            let (x, y) = xy(r, c);
            (x * x + y * y).sqrt() < radius - margin
        });
        (n, m)
    }

    #[test]
    fn sphere_has_mean_curvature_one_over_radius_and_gaussian_its_square() {
        for sigma in [0.0, 1.0, 2.5] {
            let (n, m) = sphere(128, 50.0, 1.0);
            let c = solve(&n, &m, &Options { sigma }).unwrap();
            // the centre: the inner half of the disc
            for r in 0..128 {
                for col in 0..128 {
                    let (x, y) = (col as f32 - 63.5, 63.5 - r as f32);
                    if (x * x + y * y).sqrt() < 25.0 {
                        let hr = c.mean.get(r, col) * 50.0;
                        let kr = c.gaussian.get(r, col) * 2500.0;
                        assert!((hr - 1.0).abs() < 0.01, "sigma {sigma}: H R = {hr}");
                        assert!((kr - 1.0).abs() < 0.02, "sigma {sigma}: K R^2 = {kr}");
                    }
                }
            }
            assert!((c.median_abs_mean * 50.0 - 1.0).abs() < 0.03);
        }
    }

    #[test]
    fn a_dimple_is_negative_and_a_plane_is_flat() {
        let (mut n, m) = sphere(64, 40.0, 1.0);
        for v in n.data.iter_mut() {
            // the inside of the sphere seen from the camera: a bowl
            v[0] = -v[0];
            v[1] = -v[1];
        }
        let c = solve(&n, &m, &Options::default()).unwrap();
        assert!((c.mean.get(32, 32) * 40.0 + 1.0).abs() < 0.01);
        assert!((c.gaussian.get(32, 32) * 1600.0 - 1.0).abs() < 0.02);
        let tilted = Image::filled(16, 16, [0.6f32, 0.0, 0.8]);
        let c = solve(&tilted, &Mask::full(16, 16), &Options::default()).unwrap();
        assert!(c.mean.data.iter().all(|h| h.abs() < 1e-6));
    }

    #[test]
    fn outside_the_mask_is_nan_and_lone_pixels_have_no_curvature() {
        let n = Image::filled(5, 5, [0.0f32, 0.0, 1.0]);
        let mut m = Mask::full(5, 5);
        *m.get_mut(2, 2) = false;
        *m.get_mut(0, 0) = false;
        let c = solve(&n, &m, &Options::default()).unwrap();
        assert!(c.mean.get(2, 2).is_nan() && c.gaussian.get(0, 0).is_nan());
        assert_eq!(*c.mean.get(1, 1), 0.0);
        let mut lone = Mask::filled(5, 5, false);
        *lone.get_mut(2, 2) = true;
        let c = solve(&n, &lone, &Options::default()).unwrap();
        assert!(c.mean.data.iter().all(|h| h.is_nan()));
    }

    #[test]
    fn empty_images_wrong_sizes_and_bad_scales_are_errors_not_panics() {
        let empty = Image::filled(0, 0, [0.0f32; 3]);
        let c = solve(&empty, &Mask::full(0, 0), &Options::default()).unwrap();
        assert!(c.mean.data.is_empty() && c.median_abs_mean == 0.0);
        let n = Image::filled(4, 3, [0.0f32, 0.0, 1.0]);
        assert!(solve(&n, &Mask::full(3, 4), &Options::default()).is_err());
        for sigma in [-1.0, f32::NAN, f32::INFINITY] {
            let err = solve(&n, &Mask::full(4, 3), &Options { sigma }).unwrap_err();
            assert!(matches!(err, Error::Setting { .. }), "{err}");
        }
    }
}
