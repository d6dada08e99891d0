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
//! **Under noise** ([`find_in_noise`], step 6c) the background has no levels to step
//! through and the maximum over K noisy images lifts it to the metal rim's level (at 2%
//! Gaussian noise, the maximum of 20 samples of the background is about 4% of full
//! scale; a rough aluminium sphere's rim is 1.6% in the maximum image). The mean image
//! keeps the rim (0.5% there) while dividing the noise by √K, and a Gaussian blur of
//! [`NOISE_SMOOTHING_PX`] divides it by about 2√π·σ more. That image is thresholded
//! at [`NOISE_Z`] standard deviations of its background above the background's mean,
//! both read from its lower percentiles ([`background_noise`]), lowest first. The first
//! largest component that is a disk, and has no light just outside it (the unblurred
//! ring beyond it no brighter than a fifth of the ring as far inside: a threshold above
//! a dim rim cuts a disk out of the sphere's brighter centre), lit all round its edge
//! (else it is a mirror's merged highlights, [`Ring`]), and no more than [`HIDDEN_RIM`]
//! sample noise deviations above the background (a brighter disk shows in the maximum
//! image, where the other steps look, so it is not a rim they missed), is
//! re-thresholded at half the rim's step ([`at_half_step`]: a threshold low on a
//! blurred step crosses it outside the rim, by up to 2 blur deviations) and gives the
//! circle as above; the rim model (step 7) refines it on the unblurred images where it
//! fits. On rough aluminium (`tests/camera_mitsuba.rs`) it finds the circle at 2%
//! noise within 0.3 px and refuses at 3%, where the rim's step is below the noise.
//!
//! The circle is the component's moments: centre = centroid, radius = √(area / π). A
//! binary disk's centroid averages every pixel, so it is far steadier than a fit to its
//! staircase outline; the area places the rim where the blurred maximum image crosses
//! the threshold, which is inside the true rim by the distance over which the rim's
//! signal falls to half a level (step 7, the rim model, refines it where it can).

use super::contrast::gaussian_blur;
use super::fit::fit_robust;
use super::{edges, Circle, DetectOptions};
use crate::stats::percentile;

/// Percentile of a window's values taken as the background's level (the corners of a
/// window around the sphere are about a fifth of it).
const BACKGROUND_PERCENTILE: f64 = 0.02;

/// Number of thresholds tried above the background level.
const LEVELS: usize = 6;

/// Smallest component (pixels) taken for a sphere.
const MIN_AREA: usize = 50;

/// Standard deviation (pixels) of the blur of the mean image before [`find_in_noise`]
/// thresholds it.
const NOISE_SMOOTHING_PX: f64 = 2.0;

/// Thresholds of [`find_in_noise`], in standard deviations of the blurred background
/// above its mean, lowest first (the lowest threshold puts the disk's edge nearest the
/// rim): 3σ is exceeded by one background pixel in about 700, and blurred noise comes
/// in blobs of a few pixels that the robust circle fit of the boundary drops.
const NOISE_Z: [f32; 4] = [3.0, 4.0, 6.0, 9.0];

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

/// The faint disk of a noisy capture in the window's mean image `mean` (`keep`: searched
/// pixels): see the module docs, "Under noise". The reason as text when no threshold
/// gives a disk.
pub(crate) fn find_in_noise(
    mean: &[f32],
    keep: &[bool],
    (width, height): (usize, usize),
    k: usize,
    opts: &DetectOptions,
) -> Result<FaintDisk, String> {
    if mean.is_empty() {
        return Err("the window is empty".into());
    }
    // the noise of one sample: the mean image's background noise times √K
    let sample_sd = background_noise(mean, keep).map_or(0.0, |(_, sd)| sd * (k as f32).sqrt());
    let smooth = gaussian_blur(mean, width, height, NOISE_SMOOTHING_PX);
    let (level, sd) = background_noise(&smooth, keep)
        .ok_or_else(|| String::from("the blurred mean image has no background"))?;
    let disk_at = |t: f32| {
        let fg: Vec<bool> = smooth.iter().zip(keep).map(|(v, k)| *k && *v > t).collect();
        let comp = edges::largest_component(&fg, width, height);
        disk_of(&comp, (width, height), opts).map(|d| FaintDisk { threshold: t, ..d })
    };
    let mut last = String::new();
    for z in NOISE_Z {
        let disk = match disk_at(level + z * sd) {
            Ok(disk) => disk,
            Err(why) => {
                last = why;
                continue;
            }
        };
        let (a, b) = RING_PX;
        let outside = Ring::around(mean, keep, width, &disk.circle, (a, b));
        let inside = Ring::around(mean, keep, width, &disk.circle, (-b, -a));
        last = match (outside.excess(level), inside.excess(level)) {
            (Some(_), Some(i)) if i >= HIDDEN_RIM * sample_sd as f64 => format!(
                "the disk of r {:.1} px stands {:.1} noise deviations above the background: \
                 not a rim hidden by noise",
                disk.circle.radius,
                i / sample_sd as f64
            ),
            (Some(o), Some(i)) if o <= OUTSIDE_SHARE * i.max(0.0) && inside.all_round(level) => {
                return Ok(at_half_step(disk, i, level, &disk_at, |d: &FaintDisk| {
                    Ring::around(mean, keep, width, &d.circle, (-b, -a)).excess(level)
                }));
            }
            (Some(o), Some(i)) if o > OUTSIDE_SHARE * i.max(0.0) => format!(
                "the disk of r {:.1} px has light outside it: an inner part of the sphere",
                disk.circle.radius
            ),
            _ => format!(
                "the disk of r {:.1} px is not lit all round its edge (highlights, not a rim)",
                disk.circle.radius
            ),
        };
    }
    Err(format!(
        "no threshold above the noise of the blurred mean image gives a disk ({last})"
    ))
}

/// A low threshold crosses the blurred rim outside it: `disk` re-thresholded at half the
/// rim's step (`step`, the inner ring's excess over `level`), where that lies above the
/// threshold that found it, and again about each new disk (the inner ring of a disk
/// too wide straddles the rim and reads too small a step) up to [`HALF_STEP_ROUNDS`]
/// times or until the radius moves by less than 0.05 px.
fn at_half_step(
    mut disk: FaintDisk,
    mut step: f64,
    level: f32,
    disk_at: &impl Fn(f32) -> Result<FaintDisk, String>,
    inner_step: impl Fn(&FaintDisk) -> Option<f64>,
) -> FaintDisk {
    for _ in 0..HALF_STEP_ROUNDS {
        let mid = level + 0.5 * step as f32;
        if mid <= disk.threshold {
            break;
        }
        let Ok(next) = disk_at(mid) else { break };
        let moved = (next.circle.radius - disk.circle.radius).abs();
        disk = next;
        match inner_step(&disk) {
            Some(s) if moved >= 0.05 => step = s,
            _ => break,
        }
    }
    disk
}

/// Most re-thresholdings of [`at_half_step`].
const HALF_STEP_ROUNDS: usize = 4;

/// Largest step of a rim (in the mean image) that [`find_in_noise`] takes, in standard
/// deviations of one sample's noise. A rim brighter than the noise shows in the
/// maximum image, where the steps before look: when they found no circle there, a disk
/// standing out of the noise is something else (a mirror's blurred highlights merge
/// into one; on aluminium at 2% noise the rim's step is 0.2 deviations).
const HIDDEN_RIM: f64 = 1.0;

/// Sums of `values` (searched where `keep`) in [`RING_SECTORS`] equal angular sectors of
/// the ring of pixels whose centre lies between `from` and `to` pixels outside a circle
/// (negative: inside).
///
/// [`find_in_noise`] compares the ring [`RING_PX`] outside its disk with the ring as far
/// inside: under strong noise a threshold may cut the sphere's brighter centre out of
/// its dim rim (a disk, but with the rim's light outside it), so the outer ring's
/// excess over the background must be at most [`OUTSIDE_SHARE`] of the inner ring's.
/// The inner ring must be lit all round ([`Ring::all_round`]): the blurred highlights of
/// a mirror sphere whose rim does not show merge into a disk too, but its edge is lit
/// only where the highlights are. The inner ring's excess is also the rim's step,
/// halved for the final threshold.
struct Ring {
    sums: [f64; RING_SECTORS],
    counts: [usize; RING_SECTORS],
}

impl Ring {
    fn around(
        values: &[f32],
        keep: &[bool],
        width: usize,
        c: &Circle,
        (from, to): (f64, f64),
    ) -> Ring {
        let mut ring = Ring {
            sums: [0.0; RING_SECTORS],
            counts: [0; RING_SECTORS],
        };
        for (i, (&v, &k)) in values.iter().zip(keep).enumerate() {
            let (x, y) = (
                (i % width) as f64 + 0.5 - c.cx,
                (i / width) as f64 + 0.5 - c.cy,
            );
            let d = x.hypot(y) - c.radius;
            if k && v.is_finite() && d >= from && d < to {
                let turn = 0.5 + y.atan2(x) / std::f64::consts::TAU;
                let sector = ((turn * RING_SECTORS as f64) as usize).min(RING_SECTORS - 1);
                ring.sums[sector] += v as f64;
                ring.counts[sector] += 1;
            }
        }
        ring
    }

    /// Mean excess over `level` of the whole ring; `None` when it holds no pixel.
    fn excess(&self, level: f32) -> Option<f64> {
        let n: usize = self.counts.iter().sum();
        (n > 0).then(|| self.sums.iter().sum::<f64>() / n as f64 - level as f64)
    }

    /// Whether all but [`UNLIT_SECTORS`] of the searched sectors have an excess over
    /// `level` of at least [`OUTSIDE_SHARE`] of the ring's mean excess (a positive one).
    fn all_round(&self, level: f32) -> bool {
        let Some(mean) = self.excess(level).filter(|&e| e > 0.0) else {
            return false;
        };
        let dim = (self.sums.iter().zip(&self.counts))
            .filter(|(_, &n)| n > 0)
            .filter(|(&s, &n)| s / n as f64 - (level as f64) < OUTSIDE_SHARE * mean)
            .count();
        dim <= UNLIT_SECTORS
    }
}

/// Angular sectors of a [`Ring`].
const RING_SECTORS: usize = 16;

/// Sectors of the inner ring allowed to be dim ([`Ring::all_round`]): a stand, a
/// touching object or a cast shadow may hide part of a rim.
const UNLIT_SECTORS: usize = 2;

/// Distances (pixels) from the threshold's circle of the rings compared by
/// [`Ring`]: beyond [`NOISE_SMOOTHING_PX`]'s spread of the rim, and beyond the
/// threshold's inward bias (about a pixel).
const RING_PX: (f64, f64) = (3.0, 8.0);

/// Largest share of the inner ring's excess over the background allowed in the outer
/// ring ([`Ring`]).
const OUTSIDE_SHARE: f64 = 0.2;

/// Mean and standard deviation of the background of `values` (searched where `keep`),
/// from its 2nd and 10th percentiles read as those of a normal distribution (2.05σ and
/// 1.28σ below its mean): a window around a whole disk is at least a fifth background. `None` when nothing is searched or the spread is 0 (no
/// noise: a clean image is the other steps' case).
fn background_noise(values: &[f32], keep: &[bool]) -> Option<(f32, f32)> {
    let mut v: Vec<f32> = searched(values, keep).collect();
    let p2 = percentile(&mut v, 0.02)?;
    let p10 = percentile(&mut v, 0.10)?;
    let sd = (p10 - p2) / (2.054 - 1.2816);
    (sd > 0.0).then_some((p10 + 1.2816 * sd, sd))
}

/// The [`BACKGROUND_PERCENTILE`] of the searched (`keep`) finite `values`; `None` when
/// none is searched. Also the contrast fallback's background level (module `detect`).
pub(super) fn background_percentile(values: &[f32], keep: &[bool]) -> Option<f32> {
    let mut v: Vec<f32> = searched(values, keep).collect();
    percentile(&mut v, BACKGROUND_PERCENTILE)
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

    /// A normal deviate per index (Box–Muller on a hash): deterministic noise.
    fn gauss(i: usize) -> f32 {
        let u = |j: u64| {
            let h = (j.wrapping_add(1)).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11;
            (h as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(2 * i as u64), u(2 * i as u64 + 1));
        ((-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()) as f32
    }

    /// A sphere of radius `r` about `c` whose rim (beyond 0.8 r) is `rim` above the
    /// background and whose centre is 0.05 above it, in Gaussian noise of `sd`.
    fn noisy_sphere(size: usize, c: (f64, f64), r: f64, rim: f32, sd: f32) -> Vec<f32> {
        (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f64 + 0.5, (i / size) as f64 + 0.5);
                let d = (x - c.0).hypot(y - c.1);
                let v = if d < 0.8 * r {
                    0.05
                } else if d < r {
                    rim
                } else {
                    0.0
                };
                0.01 + v + sd * gauss(i)
            })
            .collect()
    }

    #[test]
    fn finds_a_dim_rim_in_noise_and_refuses_a_disk_above_it() {
        // the mean of 20 images: its noise is that of one sample ÷ √20; the rim's step is
        // 0.4 deviations of one sample's noise (1.6 of the mean's): no pixel shows it,
        // the disk does
        let (size, c, r) = (160, (81.4, 77.9), 55.0);
        let opts = DetectOptions::default();
        let img = noisy_sphere(size, c, r, 0.0015, 0.004 / 20f32.sqrt());
        let keep = vec![true; img.len()];
        let d = find_in_noise(&img, &keep, (size, size), 20, &opts).unwrap();
        let off = (d.circle.cx - c.0).hypot(d.circle.cy - c.1);
        assert!(off < 0.3, "{:?}", d.circle);
        assert!((d.circle.radius - r).abs() < 0.5, "{:?}", d.circle);
        // a disk that stands out of the noise would have shown in the maximum image
        let bright = noisy_sphere(size, c, r, 0.05, 0.004 / 20f32.sqrt());
        let err = find_in_noise(&bright, &keep, (size, size), 20, &opts).unwrap_err();
        assert!(err.contains("not a rim hidden by noise"), "{err}");
    }

    #[test]
    fn noise_alone_and_a_noiseless_image_give_no_disk() {
        let size = 96;
        let noise: Vec<f32> = (0..size * size).map(|i| 0.01 + 0.004 * gauss(i)).collect();
        let keep = vec![true; noise.len()];
        let opts = DetectOptions::default();
        assert!(find_in_noise(&noise, &keep, (size, size), 20, &opts).is_err());
        assert!(find_in_noise(&[], &[], (0, 0), 20, &opts).is_err());
        let flat = vec![3.0f32; size * size];
        assert!(find_in_noise(&flat, &keep, (size, size), 20, &opts).is_err());
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
