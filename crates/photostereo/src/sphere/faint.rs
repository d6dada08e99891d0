//! Step 6b of the module docs: the **faint disk**. A shiny sphere under lights near the
//! view axis is black almost everywhere in every image but its highlight; in the maximum
//! image its rim may stand only one grey level above the background (an 8-bit camera, a
//! rough metal whose microfacet tail, raised by the masking term towards grazing view,
//! is a fraction of a level). Otsu's threshold then separates the highlight from the
//! rest (step 2 finds the lit cap, no circle), and the contrast edges of a one-level
//! step are too weak for step 6. Yet the step is there all round the rim.
//!
//! The maximum image is thresholded halfway between its background level (its
//! [`BACKGROUND_PERCENTILE`] value in the window) and each of the next few values
//! present in it, lowest first; the first threshold whose largest component (holes
//! filled) is a disk is taken: its boundary pixels lie on one circle
//! ([`fit::fit_robust`], the usual inlier checks) and it fills that circle. On a
//! quantised image these thresholds are the quantisation levels; on a noisy or
//! continuous background the component is not a disk and nothing is found.
//!
//! The circle is the component's moments: centre = centroid, radius = √(area / π). A
//! binary disk's centroid averages every pixel, so it is far steadier than a fit to its
//! staircase outline; the area places the rim where the blurred maximum image crosses
//! the threshold, which is inside the true rim by the distance over which the rim's
//! signal falls to half a level (step 7, the rim model, refines it where it can).

use super::fit::fit_robust;
use super::{edges, Circle, DetectOptions};

/// Percentile of a window's values taken as the background's level (the corners of a
/// window around the sphere are about a fifth of it).
const BACKGROUND_PERCENTILE: f64 = 0.02;

/// Number of thresholds tried above the background level.
const LEVELS: usize = 6;

/// Smallest component (pixels) taken for a sphere.
const MIN_AREA: usize = 50;

/// A disk found in the maximum image (window coordinates).
#[derive(Clone, Debug)]
pub(crate) struct FaintDisk {
    /// Centroid and √(area/π) of the component.
    pub circle: Circle,
    /// Root-mean-square distance of the boundary pixels' inliers to their fitted circle.
    pub rms_residual_px: f64,
    /// Boundary pixels on that circle, and all of them.
    pub inliers: usize,
    pub boundary: usize,
    /// The threshold used (image units).
    pub threshold: f32,
    /// Distance between the centroid and the boundary fit's centre (pixels): where the
    /// rim's brightness varies round the circle, the threshold crossing does too, and
    /// the two estimates part.
    pub centre_gap_px: f64,
}

/// The faint disk in the window's maximum image `values` (`keep`: searched pixels); the
/// reason as text when no threshold gives one.
pub(crate) fn find(
    values: &[f32],
    keep: &[bool],
    (width, height): (usize, usize),
    opts: &DetectOptions,
) -> Result<FaintDisk, String> {
    let levels = levels_above_background(values, keep);
    if levels.len() < 2 {
        return Err("the maximum image has no level above its background".into());
    }
    let mut last = String::new();
    for pair in levels.windows(2).take(LEVELS) {
        let t = 0.5 * (pair[0] + pair[1]);
        let fg: Vec<bool> = values.iter().zip(keep).map(|(v, k)| *k && *v > t).collect();
        let comp = edges::largest_component(&fg, width, height);
        match disk_of(&comp, (width, height), opts) {
            Ok(mut disk) => {
                disk.threshold = t;
                return Ok(disk);
            }
            Err(why) => last = why,
        }
    }
    Err(format!(
        "no threshold just above the background gives a disk ({last})"
    ))
}

/// The [`BACKGROUND_PERCENTILE`] of the searched (`keep`) finite `values`; `None` when
/// none is searched. Also the contrast fallback's background level (module `detect`).
pub(super) fn background_percentile(values: &[f32], keep: &[bool]) -> Option<f32> {
    let mut v: Vec<f32> = searched(values, keep).collect();
    if v.is_empty() {
        return None;
    }
    let i = ((v.len() - 1) as f64 * BACKGROUND_PERCENTILE) as usize;
    Some(*v.select_nth_unstable_by(i, f32::total_cmp).1)
}

/// The searched finite values.
fn searched<'v>(values: &'v [f32], keep: &'v [bool]) -> impl Iterator<Item = f32> + 'v {
    values
        .iter()
        .zip(keep)
        .filter(|(x, &k)| k && x.is_finite())
        .map(|(x, _)| *x)
}

/// The background's level and the next [`LEVELS`] distinct values above it, ascending.
fn levels_above_background(values: &[f32], keep: &[bool]) -> Vec<f32> {
    let Some(floor) = background_percentile(values, keep) else {
        return Vec::new();
    };
    let mut above: Vec<f32> = searched(values, keep).filter(|&x| x > floor).collect();
    above.sort_unstable_by(f32::total_cmp);
    above.dedup();
    above.truncate(LEVELS);
    std::iter::once(floor).chain(above).collect()
}

/// The component `comp` as a disk, or why it is not one.
fn disk_of(
    comp: &[bool],
    (width, height): (usize, usize),
    opts: &DetectOptions,
) -> Result<FaintDisk, String> {
    let area = comp.iter().filter(|&&b| b).count();
    if area < MIN_AREA {
        return Err(format!("largest component {area} px"));
    }
    let boundary: Vec<[f64; 2]> = edges::boundary_pixels(comp, width, height)
        .into_iter()
        .map(|(r, c)| [c as f64 + 0.5, r as f64 + 0.5])
        .collect();
    let fit_opts = opts.circle_fit();
    let fit = fit_robust(&boundary, &fit_opts).map_err(|e| e.to_string())?;
    let inliers = fit.inlier_count();
    if (inliers as f64) < opts.min_inlier_fraction * boundary.len() as f64 {
        return Err(format!(
            "{inliers} of {} boundary pixels on one circle",
            boundary.len()
        ));
    }
    let circle = moments(comp, width, area);
    let disk = std::f64::consts::PI * fit.circle.radius.powi(2);
    let fill = area as f64 / disk - 1.0;
    let centre_gap = (circle.cx - fit.circle.cx).hypot(circle.cy - fit.circle.cy);
    if fill.abs() > opts.max_area_error || centre_gap > 1.0 || !plausible(&circle, width, height) {
        return Err(format!(
            "a component of {area} px that does not fill its circle (r {:.1} px)",
            fit.circle.radius
        ));
    }
    Ok(FaintDisk {
        circle,
        rms_residual_px: fit.rms_residual_px,
        inliers,
        boundary: boundary.len(),
        threshold: 0.0,
        centre_gap_px: centre_gap,
    })
}

/// Centroid and equal-area radius of the component.
fn moments(comp: &[bool], width: usize, area: usize) -> Circle {
    let (mut sx, mut sy) = (0.0f64, 0.0f64);
    for (i, _) in comp.iter().enumerate().filter(|(_, &b)| b) {
        sx += (i % width) as f64 + 0.5;
        sy += (i / width) as f64 + 0.5;
    }
    Circle {
        cx: sx / area as f64,
        cy: sy / area as f64,
        radius: (area as f64 / std::f64::consts::PI).sqrt(),
    }
}

/// The whole disk inside the window (a disk cut by the window's border is not a sphere
/// whose rim shows).
fn plausible(c: &Circle, width: usize, height: usize) -> bool {
    c.cx - c.radius >= 0.0
        && c.cy - c.radius >= 0.0
        && c.cx + c.radius <= width as f64
        && c.cy + c.radius <= height as f64
}

/// Uncertainty of the centre and radius (pixels): the boundary's scatter averaged over
/// its pixels, and the gap between the two centre estimates (the threshold's crossing
/// moves round an unevenly lit rim; the scatter alone would not show that bias).
pub(crate) fn uncertainty(disk: &FaintDisk) -> f64 {
    let scatter = disk.rms_residual_px.max(0.3) / (disk.inliers.max(1) as f64).sqrt();
    scatter.hypot(disk.centre_gap_px)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A background of `bg` with a disk one level above it and a bright cap.
    fn faint_sphere(size: usize, c: (f64, f64), r: f64, bg: f32) -> Vec<f32> {
        (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f64 + 0.5, (i / size) as f64 + 0.5);
                let d = (x - c.0).hypot(y - c.1);
                if d < 0.3 * r {
                    bg + 200.0
                } else if d < r {
                    bg + 1.0
                } else {
                    bg
                }
            })
            .collect()
    }

    #[test]
    fn finds_a_disk_one_level_above_the_background() {
        let (size, c, r) = (120, (60.3, 57.8), 40.0);
        let img = faint_sphere(size, c, r, 8.0);
        let keep = vec![true; img.len()];
        let d = find(&img, &keep, (size, size), &DetectOptions::default()).unwrap();
        assert!((d.circle.cx - c.0).abs() < 0.05, "{:?}", d.circle);
        assert!((d.circle.cy - c.1).abs() < 0.05, "{:?}", d.circle);
        assert!((d.circle.radius - r).abs() < 0.1, "{:?}", d.circle);
        assert_eq!(d.threshold, 8.5);
    }

    #[test]
    fn a_square_is_not_a_disk() {
        let size = 100;
        let img: Vec<f32> = (0..size * size)
            .map(|i| {
                let (x, y) = (i % size, i / size);
                if (20..80).contains(&x) && (20..80).contains(&y) {
                    9.0
                } else {
                    8.0
                }
            })
            .collect();
        let keep = vec![true; img.len()];
        assert!(find(&img, &keep, (size, size), &DetectOptions::default()).is_err());
    }

    #[test]
    fn empty_and_uniform_images_find_nothing() {
        let opts = DetectOptions::default();
        assert!(find(&[], &[], (0, 0), &opts).is_err());
        let flat = vec![3.0f32; 64 * 64];
        assert!(find(&flat, &vec![true; flat.len()], (64, 64), &opts).is_err());
    }
}
