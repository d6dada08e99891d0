//! Checks that the sphere a calibration uses is what it is said to be, so that a wrong
//! circle, a target given as the sphere or a matte sphere given as chrome do not pass
//! silently (each gives a table or lights that are wrong everywhere, with nothing in the
//! numbers downstream to show it).
//!
//! * [`check_given_circle`]: a circle given by hand against the circle found in the
//!   images and the rim's residual ([`super::check_circle`]). The rim residual alone
//!   catches an offset of about 1 px but not a large one (its free fit follows whatever
//!   edge lies near the circle: 20 px off scores 1.02×); the circle found catches any
//!   offset beyond its own uncertainty. The warning says how far the table's normals
//!   move: the mean angle between the normals the two circles give the same pixel.
//! * [`check_shape`]: the outline of the lit region (or of the sphere's mask) ray by ray
//!   from the circle's centre: on a sphere it lies on the circle all round; on a blob or
//!   a vase found as a "circle" it leaves it in many directions.
//! * [`check_mirror`]: a chrome sphere shows each light as a small highlight; a matte
//!   sphere's brightest region covers a large part of the disk.

use super::{check_circle, detect, Circle, DetectOptions, Detection};
use crate::image::{GrayImage, ImageStack, Mask};
use crate::stats::median;
use std::ops::Range;

/// A given circle's offset (centre or radius, pixels) from the one found in the images
/// that counts as a misfit when it also exceeds 3 σ of the found circle.
pub const GIVEN_OFFSET_PX: f64 = 1.0;

/// Rim residual ratio above which a given circle is said not to follow the rim (the
/// true circle of renders: 1.04–1.30; 1 px off a synth sphere of radius 30: 1.94;
/// DiLiGenT's ball on the circle of its true normals, 0.5–0.75 px inside the
/// photographed rim: 3.0).
pub const RIM_RATIO_WARN: f64 = 1.5;

/// How a given circle compares with the images ([`check_given_circle`]).
#[derive(Clone, Debug)]
pub struct GivenCircleCheck {
    /// The circle given.
    pub given: Circle,
    /// The circle found in the images with the same search settings, and its 1-σ
    /// uncertainty (pixels); `None` when none was found.
    pub found: Option<(Circle, f64)>,
    /// Rim residual on the given circle over that of the rim fitted freely
    /// ([`super::RimCheck::ratio`]); `None` for a circle too small to check.
    pub rim_ratio: Option<f64>,
    /// Mean and largest angle (degrees) between the normals the given and the found
    /// circle give the pixels inside both.
    pub normal_shift_deg: Option<(f64, f64)>,
}

impl GivenCircleCheck {
    /// Distance of the centres and radius difference (given − found), pixels.
    pub fn offsets(&self) -> Option<(f64, f64)> {
        self.found.map(|(f, _)| {
            let g = self.given;
            ((g.cx - f.cx).hypot(g.cy - f.cy), g.radius - f.radius)
        })
    }

    /// Whether the circle found is farther from the given one than it is uncertain.
    fn off_found(&self) -> bool {
        match (self.offsets(), self.found) {
            (Some((d, dr)), Some((_, sigma))) => d.max(dr.abs()) > GIVEN_OFFSET_PX.max(3.0 * sigma),
            _ => false,
        }
    }

    /// One line: the comparison with the circle found and the rim's residual ratio.
    pub fn describe(&self) -> String {
        let rim = match self.rim_ratio {
            Some(r) => {
                format!("rim residual {r:.2}x that of the rim fitted freely (about 1 on the rim)")
            }
            None => "rim not checked (circle too small)".into(),
        };
        match (self.found, self.offsets(), self.normal_shift_deg) {
            (Some((f, s)), Some((d, dr)), shift) => format!(
                "given circle against the images' rim: {rim}; circle found {:.2}, {:.2}, {:.2} ± {s:.2} px: \
                 centre {d:.2} px away, radius {dr:+.2} px{}",
                f.cx,
                f.cy,
                f.radius,
                shift.map_or(String::new(), |(m, _)| format!(", normals {m:.2}° apart on average"))
            ),
            _ => format!("given circle against the images' rim: {rim}; no circle found to compare"),
        }
    }

    /// A warning when the circle does not follow the sphere's rim: it is farther from the
    /// circle found than that one's uncertainty and [`GIVEN_OFFSET_PX`], or its rim
    /// residual is above [`RIM_RATIO_WARN`]. The message grows with the misfit: it says
    /// by how much the table's normals move.
    pub fn warning(&self) -> Option<String> {
        let rim_bad = self.rim_ratio.is_some_and(|r| r > RIM_RATIO_WARN);
        if !rim_bad && !self.off_found() {
            return None;
        }
        let mut why = Vec::new();
        if let (true, Some((d, dr))) = (self.off_found(), self.offsets()) {
            why.push(format!(
                "its centre is {d:.1} px and its radius {dr:+.1} px from the circle found in the images"
            ));
        }
        if let Some(r) = self.rim_ratio.filter(|_| rim_bad) {
            why.push(format!("the rim's residual on it is {r:.2}x the best fit"));
        }
        let effect = match self.normal_shift_deg {
            Some((m, x)) => format!(
                "; the table's normals would be {m:.1}° off on average ({x:.0}° at worst) if the circle found is right"
            ),
            None => String::new(),
        };
        Some(format!(
            "the given circle does not follow the sphere's rim in the images: {}{effect}. \
             Check the circle on the overlay, or let the circle be found in the images",
            why.join(", and ")
        ))
    }
}

/// Compare a circle given by hand with the images of the sphere: the circle found with
/// `opts` (its `circle` ignored), the rim residual, and how far the normals move.
pub fn check_given_circle(
    stack: &ImageStack,
    given: &Circle,
    opts: &DetectOptions,
) -> GivenCircleCheck {
    let free = DetectOptions {
        circle: None,
        ..opts.clone()
    };
    let found = detect(stack, &free)
        .ok()
        .map(|d| (d.circle, d.uncertainty_px));
    let normal_shift_deg =
        found.and_then(|(f, _)| normal_shift(given, &f, stack.width, stack.height));
    GivenCircleCheck {
        given: *given,
        found,
        rim_ratio: check_circle(stack, given).map(|c| c.ratio()),
        normal_shift_deg,
    }
}

/// Mean and largest angle (degrees) between the normals circles `a` and `b` give the
/// pixels whose centres lie inside both (orthographic sphere: n = (x, −y, √(1 − x² − y²))
/// with x, y the offset from the centre over the radius).
pub fn normal_shift(a: &Circle, b: &Circle, width: usize, height: usize) -> Option<(f64, f64)> {
    let normal = |c: &Circle, x: f64, y: f64| -> Option<[f64; 3]> {
        let (u, v) = ((x - c.cx) / c.radius, (y - c.cy) / c.radius);
        let s = 1.0 - u * u - v * v;
        (s > 0.0).then(|| [u, -v, s.sqrt()])
    };
    let (mut sum, mut max, mut n) = (0.0, 0.0f64, 0usize);
    for r in 0..height {
        for col in 0..width {
            let (x, y) = (col as f64 + 0.5, r as f64 + 0.5);
            if let (Some(p), Some(q)) = (normal(a, x, y), normal(b, x, y)) {
                let ang = angle_deg(&p, &q);
                sum += ang;
                max = max.max(ang);
                n += 1;
            }
        }
    }
    (n > 0).then(|| (sum / n as f64, max))
}

/// The angle between two unit vectors, by atan2 of the cross and dot products (exact
/// near 0°, where acos loses digits).
fn angle_deg(p: &[f64; 3], q: &[f64; 3]) -> f64 {
    let cross = [
        p[1] * q[2] - p[2] * q[1],
        p[2] * q[0] - p[0] * q[2],
        p[0] * q[1] - p[1] * q[0],
    ];
    let dot = p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    let c = (cross[0].powi(2) + cross[1].powi(2) + cross[2].powi(2)).sqrt();
    c.atan2(dot).to_degrees()
}

/// Directions sampled around the circle by [`check_shape`].
const SHAPE_RAYS: usize = 90;

/// Share of the directions in which the outline may leave the circle before
/// [`ShapeCheck::warning`] says this is not a sphere. Measured (2026-12-03, with their
/// masks): the shared Mitsuba spheres, DiLiGenT's ball, the real chrome sphere and a
/// synthetic metal sphere 0%; the shared Mitsuba blob targets given as the sphere 29%, the
/// synthetic vase 53%. A stand under a real sphere takes a few directions (20° of arc is 6%).
pub const OFF_CIRCLE_WARN: f64 = 0.10;

/// How the outline of the lit region (or of the sphere's mask) follows a circle found
/// ([`check_shape`]).
#[derive(Clone, Copy, Debug)]
pub struct ShapeCheck {
    /// Share of the directions from the centre in which the outline lies farther from
    /// the circle than max(2 px, 3% of the radius).
    pub off_circle: f64,
    /// Median over the directions of |outline radius − circle radius| (pixels).
    pub median_gap_px: f64,
    /// RMS distance of the edge points to the circle found (pixels).
    pub fit_rms_px: f64,
    /// What the outline is: "lit region" or "mask".
    pub outline_of: &'static str,
}

impl ShapeCheck {
    /// One line: how closely the outline follows the circle.
    pub fn describe(&self) -> String {
        format!(
            "outline of the {} off the circle in {:.0}% of {SHAPE_RAYS} directions, median gap {:.2} px",
            self.outline_of,
            100.0 * self.off_circle,
            self.median_gap_px
        )
    }

    /// A warning when the outline leaves the circle in more than [`OFF_CIRCLE_WARN`] of
    /// the directions.
    pub fn warning(&self) -> Option<String> {
        (self.off_circle > OFF_CIRCLE_WARN).then(|| {
            format!(
                "this is not a sphere: the outline of its {} leaves the circle found in {:.0}% of \
                 the directions from its centre (a sphere's follows it all round; fit rms {:.2} px). A table \
                 from it gives wrong normals everywhere: calibrate on images of a sphere of the target's \
                 material, and check the overlay (a sphere in a corner of the target's images: search \
                 it in a window around it, not in the target's mask)",
                self.outline_of,
                100.0 * self.off_circle,
                self.fit_rms_px
            )
        })
    }
}

/// Follow `SHAPE_RAYS` rays from the detection's centre outward from half its radius
/// to 1.5 radii; where each leaves the region (`mask` when given, else the pixels of
/// the maximum image above a fifth of the median inside 0.8 radii or, where lower and
/// the rim stands clear of the background, halfway between the two; the maximum image
/// smoothed by a Gaussian of 1.5 px where noise hides the rim pixel by pixel but not in
/// the medians of its ring and of the background), compare with the radius.
pub fn check_shape(det: &Detection, mask: Option<&Mask>) -> ShapeCheck {
    // the lit region's image, circle and level (without a mask only)
    let lit = mask
        .is_none()
        .then(|| lit_region(&det.max_image, &det.circle));
    let (img, c, level) = match &lit {
        Some((Some((window, c)), level)) => (window, *c, *level),
        Some((None, level)) => (&det.max_image, det.circle, *level),
        None => (&det.max_image, det.circle, 0.0),
    };
    let inside = |x: f64, y: f64| -> bool {
        if x < 0.0 || y < 0.0 || x >= img.width as f64 || y >= img.height as f64 {
            return false;
        }
        let (col, row) = (x as usize, y as usize);
        match mask {
            Some(m) => *m.get(row, col),
            None => *img.get(row, col) > level,
        }
    };
    let tol = (0.03 * c.radius).max(2.0);
    let mut off = 0;
    let mut gaps = Vec::with_capacity(SHAPE_RAYS);
    for i in 0..SHAPE_RAYS {
        let a = std::f64::consts::TAU * i as f64 / SHAPE_RAYS as f64;
        let (dx, dy) = (a.cos(), a.sin());
        let mut rho = 0.5 * c.radius;
        while rho < 1.5 * c.radius && inside(c.cx + rho * dx, c.cy + rho * dy) {
            rho += 0.25;
        }
        let gap = (rho - c.radius).abs();
        if gap > tol {
            off += 1;
        }
        gaps.push(gap);
    }
    let mid = gaps.len() / 2;
    let median_gap_px = *gaps.select_nth_unstable_by(mid, f64::total_cmp).1;
    ShapeCheck {
        off_circle: off as f64 / SHAPE_RAYS as f64,
        median_gap_px,
        fit_rms_px: det.rms_residual_px,
        outline_of: if mask.is_some() { "mask" } else { "lit region" },
    }
}

/// The level above which a pixel of the maximum image counts as lit: a fifth of the
/// median inside 0.8 radii, or, where lower, halfway between the background (the ring
/// at 1.05–1.2 radii) and the sphere's rim (the ring at 0.9–0.98 radii) when the rim
/// stands clear of the background's spread (more than six median absolute deviations
/// above it). Why: a rough metal sphere's rim is dark under every light (on Mitsuba's
/// aluminium in 8 bits, 4 grey levels against 110 inside: a fifth of the median ends the
/// lit region at 0.75 radii, and the sphere was called "not a sphere"), yet still
/// brighter than the background behind it. `contrast` is `img`'s [`rim_contrast`].
fn lit_level(img: &GrayImage, c: &Circle, contrast: Option<Contrast>) -> f32 {
    let interior = 0.2 * median(&mut ring_values(img, c, 0.0, 0.8)).unwrap_or(0.0);
    match contrast {
        Some((b, rim, spread)) if rim - b > RIM_CLEAR_MADS * spread => {
            interior.min(0.5 * (b + rim))
        }
        _ => interior,
    }
}

/// The image the lit region is traced in: the maximum image's window smoothed by
/// [`smoothed_if_noisy`] with the circle in its frame (`None`: the maximum image itself
/// and its circle), and the lit level there ([`lit_level`]).
type LitRegion = (Option<(GrayImage, Circle)>, f32);

/// The [`LitRegion`] of the maximum image `img` and circle `c`: each image's
/// [`rim_contrast`] is measured once, for both the choice and the level.
fn lit_region(img: &GrayImage, c: &Circle) -> LitRegion {
    let contrast = rim_contrast(img, c);
    match smoothed_if_noisy(img, c, contrast) {
        Some((window, shifted, smoothed)) => {
            let level = lit_level(&window, &shifted, Some(smoothed));
            (Some((window, shifted)), level)
        }
        None => (None, lit_level(img, c, contrast)),
    }
}

/// How many median absolute deviations of the background the rim must stand above it for
/// [`lit_level`] to trace the rim.
const RIM_CLEAR_MADS: f32 = 6.0;

/// Standard deviation (pixels) of the smoothing of [`smoothed_if_noisy`].
const NOISY_SMOOTH_PX: f64 = 1.5;

/// Medians of the background ring and of the rim ring of [`rim_contrast`], and the
/// background's median absolute deviation.
type Contrast = (f32, f32, f32);

/// Medians of the background ring (1.05–1.2 radii) and of the rim ring (0.9–0.98 radii)
/// of the maximum image, and the background's median absolute deviation.
fn rim_contrast(img: &GrayImage, c: &Circle) -> Option<Contrast> {
    let mut back = ring_values(img, c, 1.05, 1.2);
    let b = median(&mut back)?;
    let rim = median(&mut ring_values(img, c, 0.9, 0.98))?;
    let mut dev: Vec<f32> = back.iter().map(|v| (v - b).abs()).collect();
    Some((b, rim, median(&mut dev).unwrap_or(0.0)))
}

/// The window of the maximum image around the circle (1.6 radii) smoothed by a Gaussian
/// of [`NOISY_SMOOTH_PX`], the circle in its frame and the window's [`rim_contrast`],
/// where noise hides the rim: by `contrast` (the image's) it stands above the background
/// in the medians but less than [`RIM_CLEAR_MADS`] of the background's spread above it
/// pixel by pixel, and clear of it after the smoothing.
/// Why: the maximum of noisy images lifts the background towards a dark rim. Measured on
/// Mitsuba's aluminium with 1% Gaussian noise (16 lights): rim 0.025 against background
/// 0.017 ± 0.0035 (2.3 deviations), so the lit region ended at 0.77 radii and the sphere
/// was "not a sphere" in 100% of the directions; smoothed, 0% (median gap 0.28 px).
fn smoothed_if_noisy(
    img: &GrayImage,
    c: &Circle,
    contrast: Option<Contrast>,
) -> Option<(GrayImage, Circle, Contrast)> {
    let (b, rim, spread) = contrast?;
    if rim <= b || rim - b > RIM_CLEAR_MADS * spread {
        return None;
    }
    let reach = 1.6 * c.radius;
    let (cols, rows) = (span(c.cx, reach, img.width), span(c.cy, reach, img.height));
    let (w, h) = (cols.len(), rows.len());
    let (values, _) = super::detect::window_values(img, None, (cols.start, rows.start, w, h));
    let smooth = super::contrast::gaussian_blur(&values, w, h, NOISY_SMOOTH_PX);
    let window = GrayImage::from_vec(w, h, smooth).ok()?;
    let shifted = Circle {
        cx: c.cx - cols.start as f64,
        cy: c.cy - rows.start as f64,
        radius: c.radius,
    };
    let (b, rim, spread) = rim_contrast(&window, &shifted)?;
    (rim - b > RIM_CLEAR_MADS * spread).then_some((window, shifted, (b, rim, spread)))
}

/// The pixel indices within `reach` of `centre` along an axis of `n` pixels.
fn span(centre: f64, reach: f64, n: usize) -> Range<usize> {
    let first = ((centre - reach).floor().max(0.0) as usize).min(n);
    first..((centre + reach).ceil().max(0.0) as usize).clamp(first, n)
}

/// The maximum image's values at `lo`–`hi` radii from the circle's centre, row by row
/// (only the rows and columns of the ring's bounding box are visited).
fn ring_values(img: &GrayImage, c: &Circle, lo: f64, hi: f64) -> Vec<f32> {
    let reach = hi * c.radius + 1.0;
    let mut v: Vec<f32> = Vec::new();
    for r in span(c.cy, reach, img.height) {
        for col in span(c.cx, reach, img.width) {
            let (x, y) = (col as f64 + 0.5 - c.cx, r as f64 + 0.5 - c.cy);
            let rho = x.hypot(y) / c.radius;
            if (lo..hi).contains(&rho) {
                v.push(*img.get(r, col));
            }
        }
    }
    v
}

/// Median share of the disk above half of each image's peak inside the disk above which
/// [`MirrorCheck::warning`] says the sphere shows no mirror highlights (a chrome
/// sphere's highlight covers well under 1% of the disk; a Lambertian sphere's brightest
/// half covers a cap of 60°, a quarter of the disk or more).
pub const HIGHLIGHT_SHARE_WARN: f64 = 0.05;

/// How small the brightest spot of each image of a chrome sphere is ([`check_mirror`]).
#[derive(Clone, Copy, Debug)]
pub struct MirrorCheck {
    /// Median over the images of the share of the disk's pixels above half that image's
    /// peak inside the disk.
    pub highlight_share: f64,
}

impl MirrorCheck {
    /// A warning when the brightest spots are too wide for mirror highlights.
    pub fn warning(&self) -> Option<String> {
        (self.highlight_share > HIGHLIGHT_SHARE_WARN).then(|| {
            format!(
                "no mirror highlights on the chrome sphere: the brightest spot of its images covers \
                 {:.0}% of the disk (a mirror's covers under 1%). This looks like a matte or rough sphere, \
                 and the light directions from its brightest points are wrong: calibrate the lights on a \
                 matte sphere as Lambertian shading, or give the light directions",
                100.0 * self.highlight_share
            )
        })
    }
}

/// The share of the disk above half the peak, per image, inside 0.95 radii; the median
/// over the images.
pub fn check_mirror(stack: &ImageStack, c: &Circle) -> MirrorCheck {
    let mut pixels = Vec::new();
    for r in 0..stack.height {
        for col in 0..stack.width {
            let (x, y) = (col as f64 + 0.5 - c.cx, r as f64 + 0.5 - c.cy);
            if x.hypot(y) < 0.95 * c.radius {
                pixels.push(r * stack.width + col);
            }
        }
    }
    let mut shares: Vec<f64> = (0..stack.k)
        .map(|k| {
            let v = |i: usize| stack.pixel_flat(i)[k];
            let peak = pixels.iter().map(|&i| v(i)).fold(0.0f32, f32::max);
            if peak <= 0.0 {
                return 0.0;
            }
            let above = pixels.iter().filter(|&&i| v(i) > 0.5 * peak).count();
            above as f64 / pixels.len().max(1) as f64
        })
        .collect();
    if shares.is_empty() {
        return MirrorCheck {
            highlight_share: 0.0,
        };
    }
    let mid = shares.len() / 2;
    let share = *shares.select_nth_unstable_by(mid, f64::total_cmp).1;
    MirrorCheck {
        highlight_share: share,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_circles_give_no_normal_shift_and_an_offset_one_that_grows() {
        let a = Circle {
            cx: 50.0,
            cy: 50.0,
            radius: 40.0,
        };
        let (m0, x0) = normal_shift(&a, &a, 100, 100).unwrap();
        assert!(m0 < 1e-9 && x0 < 1e-9, "{m0} {x0}");
        let shift = |d: f64| {
            let b = Circle { cx: 50.0 + d, ..a };
            normal_shift(&a, &b, 100, 100).unwrap().0
        };
        let (s1, s3, s10) = (shift(1.0), shift(3.0), shift(10.0));
        assert!(s1 > 0.5 && s3 > s1 && s10 > s3, "{s1} {s3} {s10}");
    }

    /// A maximum image like that of a rough metal sphere under noise: bright cap to 0.75
    /// radii, a dim rim (0.025) on a background of 0.017, Gaussian noise of `noise`.
    fn dim_rimmed_disc(noise: f64) -> (GrayImage, Circle) {
        let c = Circle {
            cx: 80.0,
            cy: 80.0,
            radius: 60.0,
        };
        let mut rng = crate::synth::random::SplitMix64::new(7);
        let img = GrayImage::from_fn(160, 160, |r, col| {
            let rho = (col as f64 + 0.5 - c.cx).hypot(r as f64 + 0.5 - c.cy) / c.radius;
            let v = match rho {
                x if x < 0.75 => 0.35,
                x if x < 1.0 => 0.025,
                _ => 0.017,
            };
            (v + noise * rng.normal()) as f32
        });
        (img, c)
    }

    #[test]
    fn a_rim_hidden_by_noise_is_traced_in_the_smoothed_image() {
        let (clean, c) = dim_rimmed_disc(0.0);
        assert!(smoothed_if_noisy(&clean, &c, rim_contrast(&clean, &c)).is_none());
        let level = lit_level(&clean, &c, rim_contrast(&clean, &c));
        assert!(level > 0.017 && level < 0.025, "{level}");

        let (noisy, c) = dim_rimmed_disc(0.005);
        // pixel by pixel the rim is lost: the lit level stays a fifth of the cap's
        assert!((lit_level(&noisy, &c, rim_contrast(&noisy, &c)) - 0.07).abs() < 0.005);
        let (window, inside, smoothed) =
            smoothed_if_noisy(&noisy, &c, rim_contrast(&noisy, &c)).expect("smoothed");
        assert_eq!(Some(smoothed), rim_contrast(&window, &inside));
        let level = lit_level(&window, &inside, Some(smoothed));
        assert!(level > 0.018 && level < 0.024, "{level}");
        // the window is the circle's neighbourhood, the circle moved into its frame
        assert_eq!((window.width, window.height), (160, 160));
        assert!((inside.cx - c.cx).abs() < 1e-12 && inside.radius == c.radius);

        // noise that drowns the rim even smoothed: no smoothing, and the cap's level
        let (drowned, c) = dim_rimmed_disc(0.05);
        assert!(smoothed_if_noisy(&drowned, &c, rim_contrast(&drowned, &c)).is_none());
    }

    #[test]
    fn the_angle_is_exact_near_zero() {
        let p = [0.0, 0.0, 1.0];
        let t = 1e-7f64;
        let q = [t.sin(), 0.0, t.cos()];
        assert!((angle_deg(&p, &q) - t.to_degrees()).abs() < 1e-15);
    }
}
