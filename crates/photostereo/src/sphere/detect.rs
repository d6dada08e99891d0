//! Finding the sphere's circle in the images ([`detect`]): the bright blob in the
//! maximum image (or the contrast fallback), refined on the rim, with the checks of
//! its size, inliers and region.

use super::fit::{self, fit_robust};
use super::{contrast, edges, faint, rim, Circle, DetectOptions, Detection};
use crate::error::{Error, Result, Setting};
use crate::image::{GrayImage, ImageStack, Mask};
use rayon::prelude::*;

/// Find the calibration sphere's circle in a stack of K images (see the module docs).
///
/// Errors: [`Error::SphereNotFound`] when neither a disk-shaped bright blob nor a
/// circle of contrast edges is found;
/// [`Error::InvalidInput`] for an empty stack, a region or circle outside the image;
/// [`Error::SizeMismatch`] for a mask of another size.
pub fn detect(stack: &ImageStack, opts: &DetectOptions) -> Result<Detection> {
    if stack.k == 0 || stack.pixels() == 0 {
        return Err(Error::invalid(
            "calibration images",
            "the sphere stack is empty: give at least one image",
        ));
    }
    let (w, h) = (stack.width, stack.height);
    let max_image = stack.max_image();
    if let Some(c) = opts.circle {
        c.check_inside(w, h, "the given circle")?;
        return Ok(Detection {
            circle: c,
            rms_residual_px: 0.0,
            inliers: 0,
            edge_points: 0,
            uncertainty_px: 0.0,
            rim_blur_px: None,
            fitted_on: "given",
            max_image,
        });
    }
    let (x0, y0, rw, rh) = check_region(opts.region, w, h)?;
    if let Some(m) = &opts.mask {
        m.check_size(w, h, "sphere mask")?;
    }
    let win = (x0, y0, rw, rh);
    // a tight silhouette mask would hide the background from the threshold and the
    // edge profiles: search inside it widened by a margin
    let search = opts.mask.as_ref().map(|m| dilate(m, SEARCH_MARGIN_PX));
    let blob = match (&opts.mask, opts.mask_outline) {
        (Some(m), true) => {
            let outline = m.map(|&b| if b { 1.0 } else { 0.0 });
            let mut det = detect_blob(&outline, None, win, opts, max_image)?;
            det.fitted_on = "mask outline";
            return Ok(det);
        }
        (None, true) => {
            return Err(Error::setting(
                Setting::SphereSearch,
                "sphere detection from the mask outline",
                "no mask was given: give the sphere's mask",
            ))
        }
        (_, false) => detect_blob(&max_image, search.as_ref(), win, opts, max_image.clone()),
    };
    let det = match blob {
        Err(Error::SphereNotFound { what, reason, fix }) => {
            contrast_fallback(stack, search.as_ref(), opts, win)
                .or_else(|why| {
                    faint_fallback(&max_image, search.as_ref(), opts, win)
                        .map_err(|faint| format!("{why}; as a faint disk: {faint}"))
                })
                .or_else(|why| {
                    noisy_fallback(stack, search.as_ref(), opts, win, &max_image)
                        .map_err(|noisy| format!("{why}; under noise: {noisy}"))
                })
                .map_err(|why| Error::SphereNotFound {
                    what,
                    reason: format!("{reason}; from contrast edges: {why}"),
                    fix,
                })
        }
        other => other,
    }?;
    Ok(if opts.rim_model {
        refine_on_rim(stack, win, det)
    } else {
        det
    })
}

/// Step 7 of the module docs: the rim model on the maximum and on the mean image of
/// the search window (never masked: a mask only says where to search), with and
/// without the linear shading term. The full model's fit of smaller statistical
/// uncertainty is the circle; half the largest disagreement between the four fits is
/// added (in quadrature) to its uncertainty. The detection is unchanged when the full
/// model fits on neither image.
fn refine_on_rim(
    stack: &ImageStack,
    win: (usize, usize, usize, usize),
    det: Detection,
) -> Detection {
    let (x0, y0, w, h) = win;
    let (mut maxv, mut meanv) = (Vec::with_capacity(w * h), Vec::with_capacity(w * h));
    for r in y0..y0 + h {
        for c in x0..x0 + w {
            let px = stack.pixel(r, c);
            maxv.push(*det.max_image.get(r, c));
            meanv.push(px.iter().sum::<f32>() / stack.k as f32);
        }
    }
    let init = Circle {
        cx: det.circle.cx - x0 as f64,
        cy: det.circle.cy - y0 as f64,
        radius: det.circle.radius,
    };
    let fit_on = |data: &[f32], name: &'static str, linear: bool| {
        let view = edges::View {
            width: w,
            height: h,
            data,
        };
        rim::refine(&view, init, linear).map(|f| (f, name, linear))
    };
    let variants = [
        (&maxv, "maximum", true),
        (&meanv, "mean", true),
        (&maxv, "maximum", false),
        (&meanv, "mean", false),
    ];
    let fits: Vec<_> = variants
        .par_iter()
        .filter_map(|(data, name, linear)| fit_on(data, name, *linear))
        .collect();
    let best = fits
        .iter()
        .filter(|f| f.2)
        .min_by(|a, b| a.0.uncertainty_px().total_cmp(&b.0.uncertainty_px()));
    let Some((fit, name, _)) = best else {
        return det;
    };
    if fit.point_sampled {
        // a point-sampled render: its staircase edge has no blur, and the mid-level
        // crossings of step 3 are unbiased there (and less noisy than the model)
        return det;
    }
    let spread = fits
        .iter()
        .flat_map(|a| fits.iter().map(|b| rim::distance(&a.0.circle, &b.0.circle)))
        .fold(0.0, f64::max);
    Detection {
        circle: Circle {
            cx: fit.circle.cx + x0 as f64,
            cy: fit.circle.cy + y0 as f64,
            radius: fit.circle.radius,
        },
        rms_residual_px: fit.rms_px,
        inliers: fit.sectors_used,
        edge_points: fit.sectors,
        uncertainty_px: fit.uncertainty_px().hypot(0.5 * spread),
        rim_blur_px: Some(fit.sigma_px),
        fitted_on: name,
        max_image: det.max_image,
    }
}

/// Margin (pixels) by which a search mask is widened (Chebyshev distance).
const SEARCH_MARGIN_PX: usize = 3;

/// `mask` dilated by `r` pixels (a (2r+1)² square), separably.
fn dilate(mask: &Mask, r: usize) -> Mask {
    let (w, h) = (mask.width, mask.height);
    let rows = Mask::from_fn(w, h, |row, col| {
        (col.saturating_sub(r)..(col + r + 1).min(w)).any(|c| *mask.get(row, c))
    });
    Mask::from_fn(w, h, |row, col| {
        (row.saturating_sub(r)..(row + r + 1).min(h)).any(|rr| *rows.get(rr, col))
    })
}

/// Step 6 of the module docs, as a [`Detection`].
fn contrast_fallback(
    stack: &ImageStack,
    mask: Option<&Mask>,
    opts: &DetectOptions,
    win: (usize, usize, usize, usize),
) -> std::result::Result<Detection, String> {
    let (mean, keep) = window_mean(stack, mask, win);
    let fit = match detect_contrast(&mean, mask.map(|_| &keep[..]), win, 0.0, opts) {
        Ok(fit) => fit,
        Err(why) => {
            // a camera's black level lifts the background, and the log stretch then
            // hides a dim rim (a rough metal's): try again with the background's level
            // taken off (its low percentile; 0 without a black level)
            let floor = background_level(&mean, &keep);
            if floor <= 0.0 {
                return Err(why);
            }
            detect_contrast(&mean, mask.map(|_| &keep[..]), win, floor, opts).map_err(|again| {
                format!("{why}; with the background level {floor:.4} taken off: {again}")
            })?
        }
    };
    Ok(Detection {
        circle: fit.circle,
        rms_residual_px: fit.rms_residual_px,
        inliers: fit.inliers,
        edge_points: fit.edge_points,
        uncertainty_px: fit.uncertainty_px,
        rim_blur_px: None,
        fitted_on: "edge points",
        max_image: stack.max_image(),
    })
}

/// Step 6b of the module docs (module `faint`), as a [`Detection`].
fn faint_fallback(
    max_image: &GrayImage,
    mask: Option<&Mask>,
    opts: &DetectOptions,
    win: (usize, usize, usize, usize),
) -> std::result::Result<Detection, String> {
    let (values, keep) = window_values(max_image, mask, win);
    let disk = faint::find(&values, &keep, (win.2, win.3), opts)?;
    Ok(disk_detection(&disk, win, "faint disk", max_image))
}

/// Step 6c of the module docs (module `faint`, "Under noise"), as a [`Detection`].
fn noisy_fallback(
    stack: &ImageStack,
    mask: Option<&Mask>,
    opts: &DetectOptions,
    win: (usize, usize, usize, usize),
    max_image: &GrayImage,
) -> std::result::Result<Detection, String> {
    let (mean, keep) = window_mean(stack, mask, win);
    let disk = faint::find_in_noise(&mean, &keep, (win.2, win.3), stack.k, opts)?;
    Ok(disk_detection(
        &disk,
        win,
        "faint disk under noise",
        max_image,
    ))
}

/// A faint disk found in the window `win` as a [`Detection`] in image coordinates.
fn disk_detection(
    disk: &faint::FaintDisk,
    win: (usize, usize, usize, usize),
    fitted_on: &'static str,
    max_image: &GrayImage,
) -> Detection {
    Detection {
        circle: Circle {
            cx: disk.circle.cx + win.0 as f64,
            cy: disk.circle.cy + win.1 as f64,
            radius: disk.circle.radius,
        },
        rms_residual_px: disk.rms_residual_px,
        inliers: disk.inliers,
        edge_points: disk.boundary,
        uncertainty_px: faint::uncertainty(disk),
        rim_blur_px: None,
        fitted_on,
        max_image: max_image.clone(),
    }
}

/// The mean over the K images in the window `win` (row-major; non-finite samples count
/// as 0) and whether each pixel is searched (inside `mask`).
fn window_mean(
    stack: &ImageStack,
    mask: Option<&Mask>,
    (x0, y0, w, h): (usize, usize, usize, usize),
) -> (Vec<f32>, Vec<bool>) {
    let mut mean = Vec::with_capacity(w * h);
    let mut keep = Vec::with_capacity(w * h);
    for r in y0..y0 + h {
        for c in x0..x0 + w {
            let px = stack.pixel(r, c);
            let m = px.iter().filter(|v| v.is_finite()).sum::<f32>() / stack.k as f32;
            mean.push(m);
            keep.push(mask.is_none_or(|m| *m.get(r, c)));
        }
    }
    (mean, keep)
}

/// The background's level in the mean image: [`faint::background_percentile`] of its
/// searched values (0 when none is positive).
fn background_level(mean: &[f32], keep: &[bool]) -> f32 {
    faint::background_percentile(mean, keep).map_or(0.0, |p| p.max(0.0))
}

/// Steps 2–5 of the module docs on `image` (the maximum image or a mask outline).
fn detect_blob(
    image: &GrayImage,
    mask: Option<&Mask>,
    win: (usize, usize, usize, usize),
    opts: &DetectOptions,
    max_image: GrayImage,
) -> Result<Detection> {
    let (x0, y0) = (win.0, win.1);
    let crop = Crop::new(image, mask, win)?;
    let points = crop.edge_points()?;
    let fit_opts = opts.circle_fit();
    let fit = fit_robust(&points, &fit_opts)?;
    let inliers = fit.inlier_count();
    let mut circle = fit.circle;
    circle.cx += x0 as f64;
    circle.cy += y0 as f64;
    check_inliers(&fit, points.len(), opts)?;
    circle.check_inside(max_image.width, max_image.height, "detected sphere")?;
    check_area(&fit, crop.area, opts)?;
    let used: Vec<[f64; 2]> = points
        .iter()
        .zip(&fit.inliers)
        .filter(|(_, &k)| k)
        .map(|(p, _)| *p)
        .collect();
    let uncertainty_px = fit::uncertainty(&used, &fit.circle).unwrap_or(f64::INFINITY);
    Ok(Detection {
        circle,
        rms_residual_px: fit.rms_residual_px,
        inliers,
        edge_points: points.len(),
        uncertainty_px,
        rim_blur_px: None,
        fitted_on: "edge points",
        max_image,
    })
}

/// The contrast-edge detection ([`contrast`]) on the window's `mean` image (`keep`: the
/// searched pixels, with a mask), stretched after `floor` (the background's level, or
/// 0) is taken off; the reason as text when no circle covers enough of its rim.
fn detect_contrast(
    mean: &[f32],
    keep: Option<&[bool]>,
    win: (usize, usize, usize, usize),
    floor: f32,
    opts: &DetectOptions,
) -> std::result::Result<contrast::ContrastFit, String> {
    let (x0, y0, w, h) = win;
    let lifted;
    let stretched = if floor > 0.0 {
        lifted = mean.iter().map(|&m| m - floor).collect::<Vec<f32>>();
        &lifted[..]
    } else {
        mean
    };
    let log = contrast::log_mean(stretched, w, h);
    let view = edges::View {
        width: w,
        height: h,
        data: &log,
    };
    let points = contrast::edge_points(&view, keep);
    let iterations = 20 * opts.ransac_iterations;
    let Some(fit) = contrast::fit_contrast(&points, w, h, iterations, opts.inlier_tol_px) else {
        return Err(format!("no circle through {} edge points", points.len()));
    };
    let linear = edges::View {
        width: w,
        height: h,
        data: mean,
    };
    let Some(mut fit) = contrast::relocate(&points, &fit, &linear, opts.inlier_tol_px) else {
        return Err("the rim's edge points could not be located".to_string());
    };
    if fit.coverage < opts.min_rim_coverage {
        return Err(format!(
            "the best circle has edges on only {:.0}% of its rim",
            100.0 * fit.coverage
        ));
    }
    // Refinement may move the RANSAC circle: check it again.
    if !contrast::plausible(&fit.circle, w, h) {
        let c = fit.circle;
        return Err(format!(
            "the refined circle (cx {:.1}, cy {:.1}, r {:.1} in the search window) is under 8 px or leaves it",
            c.cx, c.cy, c.radius
        ));
    }
    fit.circle.cx += x0 as f64;
    fit.circle.cy += y0 as f64;
    Ok(fit)
}

fn not_found(reason: String) -> Error {
    Error::SphereNotFound {
        what: "the maximum of the calibration images".into(),
        reason,
        fix: "check that the images show one bright sphere on a darker background, restrict the search to a region or a mask around the sphere, or give the circle by hand (centre x, y and radius in pixels)".into(),
    }
}

fn check_region(
    region: Option<(usize, usize, usize, usize)>,
    w: usize,
    h: usize,
) -> Result<(usize, usize, usize, usize)> {
    let Some((x, y, rw, rh)) = region else {
        return Ok((0, 0, w, h));
    };
    if rw < 8 || rh < 8 || x + rw > w || y + rh > h {
        return Err(Error::invalid(
            format!("sphere region x={x}, y={y}, w={rw}, h={rh}"),
            format!("the region must be at least 8x8 pixels and lie inside the {w}x{h} image"),
        ));
    }
    Ok((x, y, rw, rh))
}

fn check_inliers(fit: &fit::CircleFit, points: usize, opts: &DetectOptions) -> Result<()> {
    let inliers = fit.inlier_count();
    let frac = inliers as f64 / points.max(1) as f64;
    if frac < opts.min_inlier_fraction {
        return Err(not_found(format!(
            "only {inliers} of {points} edge points ({:.0}%) lie on one circle",
            100.0 * frac
        )));
    }
    Ok(())
}

fn check_area(fit: &fit::CircleFit, area: usize, opts: &DetectOptions) -> Result<()> {
    let disk = std::f64::consts::PI * fit.circle.radius.powi(2);
    let area_error = area as f64 / disk - 1.0;
    if area_error.abs() > opts.max_area_error {
        return Err(not_found(format!(
            "the bright blob ({area} pixels) does not fill the fitted circle (r = {:.1} px, {:.0} pixels)",
            fit.circle.radius, disk
        )));
    }
    Ok(())
}

/// The search window of the maximum image, thresholded.
struct Crop {
    width: usize,
    height: usize,
    values: Vec<f32>,
    component: Vec<bool>,
    area: usize,
    /// Smallest inner − outer plateau difference accepted as an edge.
    min_step: f64,
}

impl Crop {
    fn new(
        max_image: &GrayImage,
        mask: Option<&Mask>,
        win: (usize, usize, usize, usize),
    ) -> Result<Self> {
        let (_, _, width, height) = win;
        let (mut values, keep) = window_values(max_image, mask, win);
        let (lo, hi) = searched_range(&values, &keep)?;
        // the mask only says where to search: edge profiles are sampled on the raw
        // values (non-finite ones replaced)
        let raw: Vec<f32> = values
            .iter()
            .map(|&v| if v.is_finite() { v } else { lo })
            .collect();
        for (v, k) in values.iter_mut().zip(&keep) {
            if !*k {
                *v = lo;
            }
        }
        let t = edges::otsu(&values, &keep, lo, hi);
        let fg: Vec<bool> = values
            .iter()
            .zip(&keep)
            .map(|(v, k)| *k && *v > t)
            .collect();
        let component = edges::largest_component(&fg, width, height);
        let area = component.iter().filter(|&&b| b).count();
        let mean = |inside: bool| {
            let (s, n) = values
                .iter()
                .zip(&component)
                .filter(|(_, &b)| b == inside)
                .fold((0.0f64, 0usize), |(s, n), (v, _)| (s + *v as f64, n + 1));
            s / n.max(1) as f64
        };
        let min_step = 0.2 * (mean(true) - mean(false));
        Ok(Crop {
            width,
            height,
            values: raw,
            component,
            area,
            min_step,
        })
    }

    /// Sub-pixel edge points of the component (crop coordinates).
    fn edge_points(&self) -> Result<Vec<[f64; 2]>> {
        const MIN_AREA: usize = 30;
        if self.area < MIN_AREA {
            return Err(not_found(format!(
                "the largest bright blob has only {} pixels",
                self.area
            )));
        }
        let (mut sx, mut sy) = (0.0, 0.0);
        for (i, _) in self.component.iter().enumerate().filter(|(_, &b)| b) {
            sx += (i % self.width) as f64 + 0.5;
            sy += (i / self.width) as f64 + 0.5;
        }
        let centroid = (sx / self.area as f64, sy / self.area as f64);
        let view = edges::View {
            width: self.width,
            height: self.height,
            data: &self.values,
        };
        let points: Vec<[f64; 2]> =
            edges::boundary_pixels(&self.component, self.width, self.height)
                .into_iter()
                .filter_map(|(r, c)| edges::subpixel_edge(&view, r, c, centroid, self.min_step))
                .collect();
        if points.len() < 12 {
            return Err(not_found(format!(
                "only {} sub-pixel edge points on the largest bright blob",
                points.len()
            )));
        }
        Ok(points)
    }
}

/// The maximum image's values in the window `win` (x0, y0, width, height), row by row,
/// and whether each is searched (finite and inside `mask`).
pub(super) fn window_values(
    max_image: &GrayImage,
    mask: Option<&Mask>,
    (x0, y0, width, height): (usize, usize, usize, usize),
) -> (Vec<f32>, Vec<bool>) {
    let mut values = Vec::with_capacity(width * height);
    let mut keep = Vec::with_capacity(width * height);
    for r in y0..y0 + height {
        for c in x0..x0 + width {
            let v = *max_image.get(r, c);
            keep.push(v.is_finite() && mask.is_none_or(|m| *m.get(r, c)));
            values.push(v);
        }
    }
    (values, keep)
}

/// The lowest and highest searched value; an error when nothing is searched or the
/// searched values are uniform.
fn searched_range(values: &[f32], keep: &[bool]) -> Result<(f32, f32)> {
    let kept = || values.iter().zip(keep).filter(|(_, &k)| k).map(|(v, _)| *v);
    if kept().next().is_none() {
        // the search window and the search mask do not overlap (e.g. a target's mask
        // taken for the sphere's): nothing to search
        return Err(not_found(
            "no pixel is left to search: the search window and the search mask do not overlap"
                .to_string(),
        ));
    }
    let lo = kept().fold(f32::INFINITY, f32::min);
    let hi = kept().fold(f32::NEG_INFINITY, f32::max);
    if hi.is_nan() || lo.is_nan() || hi - lo <= 1e-6 * hi.abs().max(1e-3) {
        return Err(not_found(format!(
            "the maximum image is uniform (values {lo} to {hi})"
        )));
    }
    Ok((lo, hi))
}
