//! Accuracy against ground truth: angular error of normal maps and depth RMSE.
//!
//! # Normals
//!
//! The angular error at a pixel is the angle between the estimate e and the ground
//! truth g, θ = atan2(‖e × g‖, e · g) in degrees (neither needs to be unit length; the
//! `atan2` form stays accurate near 0°, where `acos` loses digits). The statistics are
//! the ones of the DiLiGenT benchmark (Shi et al., "A Benchmark Dataset and Evaluation
//! for Non-Lambertian and Uncalibrated Photometric Stereo", CVPR 2016): mean and
//! median error and the share of pixels under 5°, 10° and 20°.
//!
//! Which pixels count: pixels inside the mask where the **ground truth** is a valid
//! normal (finite, non-zero). Ground-truth holes are skipped and reported in
//! [`NormalStats::skipped_gt`]. An **estimate** that is NaN, infinite or zero at a
//! counted pixel (the method gave up there) counts as the worst error, 180°, and is
//! reported in [`NormalStats::invalid_est`]: a method cannot improve its score by
//! leaving pixels out.
//!
//! # Depth
//!
//! Depth from normals is known up to an additive constant, so the estimate is first
//! shifted by the best offset (least squares: the mean of gt − est over the counted
//! pixels), then RMSE = sqrt(mean((est + offset − gt)²)). Counted pixels: inside the
//! mask with both depths finite.

use crate::error::{Error, Result};
use crate::image::{DepthMap, GrayImage, Image, Mask, NormalMap};
use serde::Serialize;

/// Angular error statistics of a normal map, in degrees and percent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NormalStats {
    /// Mean angular error (degrees).
    pub mean: f64,
    /// Median angular error (degrees; mean of the two middle values for an even count).
    pub median: f64,
    /// Root mean square angular error (degrees).
    pub rms: f64,
    /// Largest angular error (degrees).
    pub max: f64,
    /// Percentage of counted pixels with error below 5°.
    pub under_5: f64,
    /// Percentage of counted pixels with error below 10°.
    pub under_10: f64,
    /// Percentage of counted pixels with error below 20°.
    pub under_20: f64,
    /// Number of counted pixels (inside the mask with a valid ground truth).
    pub count: usize,
    /// Counted pixels whose estimate is NaN/zero (scored as 180°).
    pub invalid_est: usize,
    /// Pixels inside the mask skipped because the ground truth is NaN/zero there.
    pub skipped_gt: usize,
}

/// Depth error after removing the best constant offset, in pixel units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DepthStats {
    /// RMSE of est + offset − gt (pixels).
    pub rmse: f64,
    /// Mean absolute error of est + offset − gt (pixels).
    pub mae: f64,
    /// The offset added to the estimate (pixels).
    pub offset: f64,
    /// Range max − min of the ground truth over the counted pixels (pixels), a scale
    /// for the RMSE.
    pub range: f64,
    /// Number of counted pixels.
    pub count: usize,
}

fn valid(n: &[f32; 3]) -> bool {
    n.iter().all(|v| v.is_finite()) && *n != [0.0; 3]
}

/// Angle between two non-zero vectors, degrees, as atan2(‖a × b‖, a · b): accurate near
/// 0° and 180°, where acos of the dot product loses half the digits.
pub fn angle_deg(a: &[f32; 3], b: &[f32; 3]) -> f64 {
    let a = a.map(f64::from);
    let b = b.map(f64::from);
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
    let cos = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    sin.atan2(cos).to_degrees()
}

fn check_sizes<A: Clone, B>(est: &Image<A>, gt: &Image<B>, mask: &Mask, what: &str) -> Result<()> {
    if !est.same_size(gt) {
        return Err(Error::SizeMismatch {
            what: format!("estimated {what}"),
            expected_w: gt.width,
            expected_h: gt.height,
            found_w: est.width,
            found_h: est.height,
            fix: format!("compare {what} of the same size as the ground truth"),
        });
    }
    mask.check_size(gt.width, gt.height, &format!("mask for the {what}"))
}

/// Per-pixel angular error (degrees): NaN outside the mask and where the ground truth
/// is invalid; 180 where the estimate is invalid.
pub fn angular_error_map(est: &NormalMap, gt: &NormalMap, mask: &Mask) -> Result<GrayImage> {
    check_sizes(est, gt, mask, "normal map")?;
    let data = (0..gt.len())
        .map(|i| {
            let (e, g) = (&est.data[i], &gt.data[i]);
            if !mask.data[i] || !valid(g) {
                f32::NAN
            } else if !valid(e) {
                180.0
            } else {
                angle_deg(e, g) as f32
            }
        })
        .collect();
    Image::from_vec(gt.width, gt.height, data)
}

/// Angular error statistics of `est` against `gt` over `mask` (see the module docs for
/// which pixels count). Errors: different sizes, or no pixel to count.
pub fn angular_errors(est: &NormalMap, gt: &NormalMap, mask: &Mask) -> Result<NormalStats> {
    check_sizes(est, gt, mask, "normal map")?;
    let mut errors = Vec::with_capacity(mask.count());
    let (mut invalid_est, mut skipped_gt) = (0, 0);
    for i in 0..gt.len() {
        if !mask.data[i] {
            continue;
        }
        let (e, g) = (&est.data[i], &gt.data[i]);
        if !valid(g) {
            skipped_gt += 1;
        } else if !valid(e) {
            invalid_est += 1;
            errors.push(180.0);
        } else {
            errors.push(angle_deg(e, g));
        }
    }
    if errors.is_empty() {
        return Err(Error::EmptyMask {
            what: format!(
                "normal evaluation ({skipped_gt} masked pixels without a valid ground truth)"
            ),
            fix: "use a mask that covers pixels where the ground truth is defined".into(),
        });
    }
    let n = errors.len() as f64;
    let share = |t: f64| 100.0 * errors.iter().filter(|&&e| e < t).count() as f64 / n;
    let (under_5, under_10, under_20) = (share(5.0), share(10.0), share(20.0));
    let mean = errors.iter().sum::<f64>() / n;
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    errors.sort_by(f64::total_cmp);
    let m = errors.len();
    let median = if m % 2 == 1 {
        errors[m / 2]
    } else {
        0.5 * (errors[m / 2 - 1] + errors[m / 2])
    };
    Ok(NormalStats {
        mean,
        median,
        rms,
        max: errors[m - 1],
        under_5,
        under_10,
        under_20,
        count: m,
        invalid_est,
        skipped_gt,
    })
}

/// Depth RMSE of `est` against `gt` over `mask` after removing the best offset (see
/// the module docs). Errors: different sizes, or no pixel with both depths finite.
pub fn depth_rmse(est: &DepthMap, gt: &DepthMap, mask: &Mask) -> Result<DepthStats> {
    check_sizes(est, gt, mask, "depth map")?;
    let pairs: Vec<(f64, f64)> = (0..gt.len())
        .filter(|&i| mask.data[i] && est.data[i].is_finite() && gt.data[i].is_finite())
        .map(|i| (est.data[i] as f64, gt.data[i] as f64))
        .collect();
    if pairs.is_empty() {
        return Err(Error::EmptyMask {
            what: "depth evaluation (no masked pixel where both depths are finite)".into(),
            fix: "check the mask and that the depth maps are not NaN over the object".into(),
        });
    }
    let n = pairs.len() as f64;
    let offset = pairs.iter().map(|(e, g)| g - e).sum::<f64>() / n;
    let residual = |(e, g): &(f64, f64)| e + offset - g;
    let rmse = (pairs.iter().map(|p| residual(p).powi(2)).sum::<f64>() / n).sqrt();
    let mae = pairs.iter().map(|p| residual(p).abs()).sum::<f64>() / n;
    let (lo, hi) = pairs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (_, g)| {
            (lo.min(*g), hi.max(*g))
        });
    Ok(DepthStats {
        rmse,
        mae,
        offset,
        range: hi - lo,
        count: pairs.len(),
    })
}
