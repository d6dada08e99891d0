//! Calibration sphere: its occluding circle, found in the images, and the analytic
//! normal of each of its pixels.
//!
//! Circle coordinates are continuous image coordinates: pixel (row r, col c) covers
//! [c, c+1) × [r, r+1), so its centre is at (c + 0.5, r + 0.5). `cx` runs along columns
//! (right), `cy` along rows (down).
//!
//! Under orthographic projection the visible hemisphere of a sphere with centre
//! (cx, cy) and radius R has, at the pixel centre (u, v), the unit normal
//! n = ((u − cx)/R, −(v − cy)/R, √(1 − n_x² − n_y²)) — y flips because rows grow downward.
//!
//! # Detection ([`detect`])
//!
//! 1. The per-pixel **maximum over the K images**: every part of the sphere facing
//!    some light is bright in it, so attached shadows of single images do not cut
//!    into the silhouette.
//! 2. **Otsu's threshold** on it (inside `region` / `mask`), the **largest
//!    8-connected component**, holes filled.
//! 3. **Sub-pixel edge points**: along the image gradient at each boundary pixel,
//!    the crossing of the line halfway between straight lines fitted to the outer
//!    and inner parts of the profile (module `edges`).
//! 4. A **robust circle fit** ([`fit`]): RANSAC over point triples, the Kåsa algebraic
//!    fit on the inliers and a Gauss–Newton refinement of the orthogonal distances.
//! 5. **Sanity checks** against non-spheres: enough inliers, the filled component
//!    covers the fitted disk, the circle lies inside the image.
//!
//! 6. **Fallback from contrast edges** (module `contrast`): when no bright blob passes
//!    these checks — a dark mirror (chrome) sphere on a dark background, whose brightest
//!    pixels are its highlights — the circle is fitted to edge points of the
//!    log-stretched *mean* image wherever the rim contrasts with what lies behind it,
//!    by RANSAC scoring the fraction of the rim covered; accepted when at least
//!    [`DetectOptions::min_rim_coverage`] of the rim shows. When none does, it is tried
//!    once more with the background's level (2nd percentile of the window's mean) taken
//!    off before the stretch: a camera's black level lifts the background, and the
//!    stretch then leaves a dim rim (a rough metal's, a few grey levels above it in 8
//!    bits) without contrast.
//!
//!    6b. **The faint disk** (module `faint`): when the contrast edges fail too, the
//!    maximum image is thresholded halfway between its background level and each of
//!    the next few values present in it; the first largest component that is a disk
//!    gives the circle from its moments (centroid, √(area/π)). A rough metal under
//!    lights near the view axis, through an 8-bit camera with blur and a black level,
//!    shows its rim only one grey level above the background in the maximum image.
//!
//!    6c. **The faint disk under noise** (module `faint`): when that fails too, the mean
//!    image blurred by 2 px is thresholded 3, 4, 6, 9 standard deviations of its
//!    background above the background's mean; the first largest component that is a
//!    disk *with no light just outside it* (else a threshold cut the sphere's bright
//!    centre out of its dim rim), lit all round its edge, and whose step is below one
//!    sample's noise deviation (a brighter one would have shown in the maximum image: a
//!    mirror's blurred highlights merge into such a disk) is taken and re-thresholded
//!    at half the rim's step. The
//!    maximum over K noisy images lifts the background to a rough metal rim's level (2%
//!    noise, 20 images); the blurred mean divides the noise by about 7√K instead.
//!
//! 7. **The rim model** (module `rim`, [`DetectOptions::rim_model`], on by default):
//!    the circle of steps 3–6 is refined by fitting the image near the rim with a
//!    blurred profile (background | a₀ + a₁√s + a₂s inside, Gaussian blur σ fitted),
//!    sector by sector, on the maximum and on the mean image; the detection reports
//!    the circle's 1-σ uncertainty ([`Detection::uncertainty_px`]) and the blur.
//!    Mid-level crossings are biased by optical blur and by the √s shading next to the
//!    rim (0.1–0.35 px at σ 0.5–1 px, over 1 px on a dark rim); the model is not.
//!    When the pixels fit better as point samples (a render such as `synth`'s, with a
//!    staircase silhouette and no blur) the circle of step 3 is kept: mid-level
//!    crossings are unbiased there.
//!
//! **Cross-check from the lit arcs** ([`litarc::fit`]): each image's rim where that
//! image lights it, located by the blurred step's outer tail alone (nothing inside the
//! rim is modelled). Within 0.1 px on renders; on DiLiGenT's ball it agrees with the
//! rim model's centre within 0.03 px and lies 0.3 px inside its radius — both outside
//! the circle of the dataset's true normals (tests `sphere_truth`).
//!
//! **Cross-check from the shading** ([`photometric::fit`], needs the lights): the circle
//! whose normals let one isotropic reflectance, shared by all lights, fit the sphere's
//! inside best. Within 0.01 px on renders (blurred and 8-bit too); on DiLiGenT's ball
//! centre 0.10 px from the true normals' circle, radius +1.43 px.
//!
//! **A mask only says where to search.** With [`DetectOptions::mask`] (the sphere
//! folder's `mask.png` in `calibrate` and `run --sphere` alike, or `--mask`) steps 2–6
//! look only inside it widened by 3 px (a silhouette mask would otherwise hide the
//! background from the threshold and the edge profiles), but step 7 fits the rim on the
//! unmasked images, so the
//! circle is the images' whichever mask is given (a mask that covers the sphere gives
//! the same circle within 0.01 px as none).
//!
//! **Checking a circle** ([`check_circle`]): the rim model's residual on the mean image
//! with the rim held on a given circle, over its residual with the rim free sector by
//! sector. About 1 on the rim (1.04–1.30 for the true circle of renders), 1.9 for a
//! circle 1 px off a synth sphere of radius 30; `calibrate --circle` prints it and warns
//! above 1.5. On DiLiGenT's ball the circle of the dataset's true normals gives 3.0:
//! the photographed rim lies 0.5–0.75 px outside it.
//!
//! With [`DetectOptions::mask_outline`] steps 1–2 use a given silhouette mask instead
//! of the images (for spheres whose rim does not show at all); no rim model then.
//!
//! References: N. Otsu, "A threshold selection method from gray-level histograms",
//! IEEE SMC 1979; I. Kåsa, "A circle fitting procedure and its error analysis",
//! IEEE TIM 1976; N. Chernov, *Circular and Linear Regression*, CRC 2010.

pub mod checks;
mod contrast;
mod detect;
mod edges;
mod faint;
pub mod fit;
pub mod litarc;
mod overlay;
pub mod photometric;
mod rim;

pub use detect::detect;
pub use overlay::{encode_png, overlay};

use crate::error::{Error, Result, Setting};
use crate::image::{GrayImage, ImageStack, Mask};

/// A circle in continuous image coordinates (pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    /// Centre, along columns (pixels, right).
    pub cx: f64,
    /// Centre, along rows (pixels, down).
    pub cy: f64,
    /// Radius in pixels.
    pub radius: f64,
}

impl Circle {
    /// Analytic unit normal of the sphere at the centre of pixel (row, col), or `None`
    /// outside the circle shrunk by `rim` pixels (grazing normals and mixed pixels).
    pub fn normal_at(&self, row: usize, col: usize, rim: f64) -> Option<[f32; 3]> {
        let nx = (col as f64 + 0.5 - self.cx) / self.radius;
        let ny = -(row as f64 + 0.5 - self.cy) / self.radius;
        let rho2 = nx * nx + ny * ny;
        let inner = ((self.radius - rim) / self.radius).max(0.0);
        if rho2 >= inner * inner {
            return None;
        }
        Some([nx as f32, ny as f32, (1.0 - rho2).sqrt() as f32])
    }
}

impl Circle {
    /// Error unless the circle lies inside a `width` × `height` image (half a pixel
    /// of slack for rounding).
    pub fn check_inside(&self, width: usize, height: usize, what: &str) -> Result<()> {
        const SLACK: f64 = 0.5;
        let ok = self.radius.is_finite()
            && self.radius > 0.0
            && self.cx - self.radius >= -SLACK
            && self.cy - self.radius >= -SLACK
            && self.cx + self.radius <= width as f64 + SLACK
            && self.cy + self.radius <= height as f64 + SLACK;
        if ok {
            return Ok(());
        }
        Err(Error::setting(
            Setting::Circle,
            format!(
                "{what}: circle cx={:.2}, cy={:.2}, r={:.2} does not lie inside the {width}x{height} image",
                self.cx, self.cy, self.radius
            ),
            "the whole sphere must be visible: check the circle (pixels, x along columns, y along rows) or reframe the sphere",
        ))
    }
}

/// Settings of [`detect`].
#[derive(Clone, Debug)]
pub struct DetectOptions {
    /// Use this circle instead of detecting one (only checked to lie inside the image).
    pub circle: Option<Circle>,
    /// Search only inside this window `(x, y, w, h)`: column, row of its top-left
    /// pixel, width and height, in pixels. For a sphere sharing the images with the target.
    pub region: Option<(usize, usize, usize, usize)>,
    /// Search only inside this mask (same size as the images).
    pub mask: Option<Mask>,
    /// The mask *is* the sphere's silhouette (e.g. drawn by hand, as for a dark mirror
    /// sphere on a dark background, whose rim barely shows in the images): fit the
    /// circle to the mask's outline instead of the images. Needs `mask`.
    pub mask_outline: bool,
    /// RANSAC triples drawn by the circle fit (0 = no RANSAC).
    pub ransac_iterations: usize,
    /// Edge points farther than this from the circle are outliers (pixels).
    pub inlier_tol_px: f64,
    /// Fewer inliers than this fraction of the edge points → no sphere.
    pub min_inlier_fraction: f64,
    /// Largest accepted |component area / (π r²) − 1|: the bright blob must fill the disk.
    pub max_area_error: f64,
    /// When no bright blob is found: smallest fraction of the rim that must show as
    /// contrast edges for a circle found from them (module `contrast`) to be accepted.
    pub min_rim_coverage: f64,
    /// Refine the circle with the blurred-rim model (module `rim`, step 7 of the
    /// module docs). Off: the circle of the edge points.
    pub rim_model: bool,
}

impl Default for DetectOptions {
    fn default() -> Self {
        DetectOptions {
            circle: None,
            region: None,
            mask: None,
            mask_outline: false,
            ransac_iterations: 500,
            inlier_tol_px: 1.0,
            min_inlier_fraction: 0.5,
            max_area_error: 0.25,
            min_rim_coverage: 0.4,
            rim_model: true,
        }
    }
}

impl DetectOptions {
    /// The robust circle fit's settings taken from these options.
    pub(crate) fn circle_fit(&self) -> fit::FitOptions {
        fit::FitOptions {
            ransac_iterations: self.ransac_iterations,
            inlier_tol_px: self.inlier_tol_px,
            ..fit::FitOptions::default()
        }
    }

    /// The mask the sphere is searched in: [`DetectOptions::mask`] when given, else the
    /// sphere folder's mask (`folder_mask`, its `mask.png`) unless a search window
    /// ([`DetectOptions::region`]) is given. With a window the sphere shares its images
    /// with a target (the classic setup: one folder, the sphere in a corner of the
    /// images), and the folder's mask is the target's, not the sphere's: searching
    /// inside it would miss the sphere.
    pub fn search_mask(&self, folder_mask: Option<Mask>) -> Option<Mask> {
        match (&self.mask, self.region) {
            (Some(m), _) => Some(m.clone()),
            (None, Some(_)) => None,
            (None, None) => folder_mask,
        }
    }
}

/// Result of [`detect`], with the figures that say how much to trust it.
#[derive(Clone, Debug)]
pub struct Detection {
    /// The sphere's occluding circle (image coordinates, pixels).
    pub circle: Circle,
    /// RMS distance of the inlier edge points to the circle (pixels; 0 for an override).
    pub rms_residual_px: f64,
    /// Edge points used in the final fit.
    pub inliers: usize,
    /// Sub-pixel edge points found.
    pub edge_points: usize,
    /// 1-σ uncertainty of the circle (pixels): the larger of the standard deviations
    /// of its centre (√(var cx + var cy)) and of its radius, from the scatter of the
    /// rim's points about it (0 for an override). Above [`UNCERTAIN_PX`] the CLI warns.
    pub uncertainty_px: f64,
    /// Gaussian blur of the rim found by the rim model (pixels; `None` when the circle
    /// comes from edge points only).
    pub rim_blur_px: Option<f64>,
    /// The image the circle was fitted on: "maximum", "mean" (rim model), "edge points"
    /// (mid-level crossings, no rim model), "mask outline" or "given".
    pub fitted_on: &'static str,
    /// Per-pixel maximum over the K images (for [`overlay`]).
    pub max_image: GrayImage,
}

/// Circle uncertainty (pixels) above which the CLI warns that the circle is doubtful.
pub const UNCERTAIN_PX: f64 = 0.3;

impl Detection {
    /// One line for the CLI: the circle, its uncertainty and how it was fitted.
    pub fn describe(&self) -> String {
        let c = self.circle;
        if self.edge_points == 0 {
            // given (no fit, nothing to qualify)
            return format!("cx {:.3}, cy {:.3}, r {:.3} px", c.cx, c.cy, c.radius);
        }
        let blur = self
            .rim_blur_px
            .map(|b| format!(", rim blur {b:.2} px"))
            .unwrap_or_default();
        format!(
            "cx {:.3}, cy {:.3}, r {:.3} px ± {:.3} px (1σ; fitted on the {}{blur}); fit rms {:.3} px over {}/{} points",
            c.cx, c.cy, c.radius, self.uncertainty_px, self.fitted_on, self.rms_residual_px,
            self.inliers, self.edge_points
        )
    }

    /// A warning when the uncertainty exceeds [`UNCERTAIN_PX`].
    pub fn warning(&self) -> Option<String> {
        (self.uncertainty_px > UNCERTAIN_PX).then(|| {
            format!(
                "warning: the sphere's circle is uncertain by {:.2} px (> {UNCERTAIN_PX} px): grazing normals of the table will be off; check overlay.png, or give the circle by hand",
                self.uncertainty_px
            )
        })
    }
}

/// How well a circle lies on the images' rim (see [`check_circle`]).
#[derive(Clone, Copy, Debug)]
pub struct RimCheck {
    /// RMS residual of the rim model (step 7 of the module docs) on the mean image with
    /// the rim on the circle, at the blur that fits best (image units).
    pub rms_on_circle: f64,
    /// The same with the rim's position fitted sector by sector (about 6 px of arc
    /// each): the best the model does on these images (image units).
    pub rms_fitted: f64,
}

impl RimCheck {
    /// `rms_on_circle / rms_fitted`: about 1 when the circle lies on the rim; well above
    /// 1 (2.4 for DiLiGenT's ball and the circle of its true normals) when the images'
    /// rim lies elsewhere.
    pub fn ratio(&self) -> f64 {
        self.rms_on_circle / self.rms_fitted.max(f64::MIN_POSITIVE)
    }
}

/// Check a circle (given, or from another source) against the rim of the images: the
/// rim model's residual on the mean image with the rim held on `circle`, beside the
/// residual with the rim's position free. `None` when fewer than 8 sectors of the rim
/// lie in the image (or the circle is smaller than 6 px).
pub fn check_circle(stack: &ImageStack, circle: &Circle) -> Option<RimCheck> {
    if stack.k == 0 || circle.radius < 6.0 || !circle.radius.is_finite() {
        return None;
    }
    let mean: Vec<f32> = (0..stack.pixels())
        .map(|i| stack.pixel_flat(i).iter().sum::<f32>() / stack.k as f32)
        .collect();
    let view = edges::View {
        width: stack.width,
        height: stack.height,
        data: &mean,
    };
    let (rms_on_circle, rms_fitted) = rim::check(&view, circle)?;
    Some(RimCheck {
        rms_on_circle,
        rms_fitted,
    })
}

/// Circle uncertainty (pixels) of the rim model's fit above which [`rim_blur`] does not
/// report its blur.
const MAX_BLUR_UNCERTAINTY_PX: f64 = 0.05;

/// The Gaussian blur (pixels, on top of each pixel's area) of the sphere's rim at
/// `circle`: the rim model of step 7 (module docs) fitted on the maximum image around the
/// circle, starting from it. `Some(0.0)` for a point-sampled render (no blur); `None`
/// when the model does not fit (too little of the rim in the images, no contrast), or
/// fits only part of the rim (10% of its sectors or more off the circle) or holds the
/// circle to no better than 0.05 px (noise).
/// [`crate::lut::Table::build`] keeps it with the table ([`crate::lut::Table::rim_blur`]).
pub fn rim_blur(stack: &ImageStack, circle: &Circle) -> Option<f64> {
    let finite = circle.cx.is_finite() && circle.cy.is_finite() && circle.radius.is_finite();
    if stack.k == 0 || !finite {
        return None;
    }
    // the rim model reads up to its band outside the rim plus its largest offset
    let margin = 8.0;
    let lo = |c: f64| (c - circle.radius - margin).floor().max(0.0) as usize;
    let hi = |c: f64, n: usize| ((c + circle.radius + margin).ceil().max(0.0) as usize).min(n);
    let (x0, y0) = (lo(circle.cx), lo(circle.cy));
    let (x1, y1) = (hi(circle.cx, stack.width), hi(circle.cy, stack.height));
    if x1 <= x0 || y1 <= y0 {
        return None;
    }
    let (w, h) = (x1 - x0, y1 - y0);
    let mut maxv = Vec::with_capacity(w * h);
    for r in y0..y1 {
        for c in x0..x1 {
            maxv.push(stack.pixel(r, c).iter().fold(f32::MIN, |m, &v| m.max(v)));
        }
    }
    let view = edges::View {
        width: w,
        height: h,
        data: &maxv,
    };
    let init = Circle {
        cx: circle.cx - x0 as f64,
        cy: circle.cy - y0 as f64,
        radius: circle.radius,
    };
    let fit = rim::refine(&view, init, true)?;
    // under noise the model still fits, but with a third of the rim's sectors off the
    // circle and a poorly held blur (the 1%-noise aluminium of `tests/camera_mitsuba.rs`:
    // 1.06 px, 63 of 105 sectors, ±0.066 px; clean or blurred rims: all sectors,
    // ±0.001–0.015 px)
    let whole_rim = fit.sectors_used * 10 >= fit.sectors * 9;
    let held = fit.uncertainty_px() < MAX_BLUR_UNCERTAINTY_PX;
    (whole_rim && held).then_some(if fit.point_sampled { 0.0 } else { fit.sigma_px })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_points_out_of_the_sphere_in_camera_frame() {
        let c = Circle {
            cx: 50.0,
            cy: 50.0,
            radius: 40.0,
        };
        // centre pixel faces the camera
        let n = c.normal_at(49, 49, 0.0).unwrap();
        assert!(n[2] > 0.999);
        // a pixel above the centre (smaller row) faces up (+y)
        let n = c.normal_at(20, 49, 0.0).unwrap();
        assert!(n[1] > 0.7 && n[0].abs() < 0.02);
        // a pixel right of the centre faces right (+x)
        let n = c.normal_at(49, 80, 0.0).unwrap();
        assert!(n[0] > 0.7);
        // outside, and inside the skipped rim
        assert!(c.normal_at(49, 95, 0.0).is_none());
        assert!(c.normal_at(49, 88, 2.0).is_none());
    }
}
