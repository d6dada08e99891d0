//! The figures of a run: the rows of the report and of `run.json`.

use super::summary::Figure;
use super::{Accuracy, Estimate, Interreflections, Job};
use crate::image::{DepthMap, GrayImage, Mask};
use crate::warning::{Warning, WarningCode};
use crate::{integrate, mesh, sphere};

/// The title (the dataset's name) and subtitle (how it was solved) of a report.
#[derive(Clone, Debug, Default)]
pub struct Titles {
    /// Title of the report and `dataset` of `run.json`.
    pub title: String,
    /// One line under the title.
    pub subtitle: String,
}

/// Depth range (max − min) over the mask, pixels.
pub fn depth_range(depth: &DepthMap, mask: &Mask) -> f32 {
    let (lo, hi) = depth
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(d, &m)| m && d.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), (d, _)| {
            (lo.min(*d), hi.max(*d))
        });
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}

/// Mean over the mask of the finite values.
pub fn masked_mean(img: &GrayImage, mask: &Mask) -> f32 {
    let (sum, n) = img
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(v, &m)| m && v.is_finite())
        .fold((0.0f64, 0usize), |(s, n), (v, _)| {
            (s + f64::from(*v), n + 1)
        });
    if n == 0 {
        f32::NAN
    } else {
        (sum / n as f64) as f32
    }
}

/// What the pictures `albedo.png` and `depth.png` (and the report's) show: the albedo's
/// white level and the depth's colour range ([`crate::picture::albedo_picture`],
/// [`crate::picture::depth_picture`]).
pub(super) fn picture_rows(job: &Job, albedo: Option<&GrayImage>, depth: &DepthMap) -> Vec<Figure> {
    use crate::picture as raster;
    let mask = Some(&job.mask);
    let mut f = Vec::new();
    if let Some(a) = albedo {
        let white = raster::albedo_white(a, mask);
        f.push(Figure::new(
            "albedo.png white level",
            format!("{white:.3} (99th percentile; black = 0)"),
        ));
    }
    let (_, (lo, hi)) = raster::depth_picture(depth, mask);
    f.push(Figure::new(
        "depth.png colour range (px)",
        format!("{lo:.2} far, dark → {hi:.2} near, yellow (viridis, 1st → 99th percentile)"),
    ));
    f
}

/// The curvature row: its scale and the picture's colour range.
pub(super) fn curvature_row(c: &crate::curvature::Curvature) -> Figure {
    let (med, lim) = (c.median_abs_mean, c.display_limit);
    let radius = if med > 0.0 {
        format!(" (a sphere of radius {:.0} px)", 1.0 / med)
    } else {
        String::new()
    };
    Figure::new(
        "mean curvature (1/px)",
        format!(
            "median |H| {med:.2e}{radius}; curvature.png: blue −{lim:.2e} → red +{lim:.2e} \
             (99th percentile of |H|)"
        ),
    )
}

/// Confidence below which a lookup is not to be trusted ([`crate::lut`]: 1 = perfect match).
pub const LOW_CONFIDENCE: f32 = 0.5;

/// The warnings of a job: a lookup whose confidence is below [`LOW_CONFIDENCE`] over most
/// of the mask (the sphere's intensities do not cover the target's), and interreflection
/// removal on images whose radiance scale nobody gave.
///
/// `confidence` is the estimate's (after the spatial stage, the lookup's times
/// `own_share`); the warning is about the lookup's own matches, so the share is divided
/// out again where it is given. The spatial stage deciding many pixels is a warning of
/// its own (`checks::warnings`): on 8-bit rough metal it decides half the mask, and the
/// product said "not to be trusted" of normals 0.36° off (2026-12-07).
pub fn warnings(
    job: &Job,
    confidence: Option<&GrayImage>,
    own_share: Option<&GrayImage>,
    opts: &super::Options,
) -> Vec<Warning> {
    let mut w = Vec::new();
    if let Some(c) = confidence {
        let share = |i: usize| own_share.map_or(1.0, |s| s.data[i]);
        let inside: Vec<f32> = (c.data.iter().enumerate())
            .zip(&job.mask.data)
            .filter(|(_, &m)| m)
            .map(|((i, &v), _)| {
                let s = share(i);
                let own = if s > 0.0 { v / s } else { v };
                if own.is_finite() {
                    own.min(1.0)
                } else {
                    0.0
                }
            })
            .collect();
        let low = inside.iter().filter(|&&v| v < LOW_CONFIDENCE).count();
        if !inside.is_empty() && 2 * low > inside.len() {
            let code = WarningCode::LowConfidence;
            w.push(Warning::new(
                code,
                format!(
                "low confidence: {:.0}% of the mask has a lookup confidence below {LOW_CONFIDENCE} \
                 (mean {:.3}). The sphere's intensities do not cover the target's: the sphere is \
                 probably not of the target's material, or not under the same lights, or the \
                 exposures differ. These normals and this depth are not to be trusted; use a \
                 sphere of the same material under the same lights (or Lambertian photometric \
                 stereo for a matte object).",
                100.0 * low as f64 / inside.len() as f64,
                inside.iter().map(|&v| f64::from(v)).sum::<f64>() / inside.len() as f64
            ),
            ));
        }
    }
    if opts.interreflections && !opts.nik.scale_known {
        w.push(Warning::new(
            WarningCode::ImageScaleUnknown,
            "image scale unknown: interreflection removal needs images in radiance units (the \
             bounced light is proportional to the absolute albedo, which photometric stereo \
             knows only up to the camera's gain). Nothing said so here (no image scale given, no \
             meta.json scale): with 8-bit photographs the depth of a concavity may be off by \
             several percent. Give the image scale (the factor to radiance units) or \
             calibrated light_intensities.txt.",
        ));
    }
    w
}

/// The circle figure: "cx, cy, r ± uncertainty (…; fit rms … px)".
pub(super) fn circle(det: &sphere::Detection) -> String {
    let c = det.circle;
    format!(
        "{:.2}, {:.2}, {:.2} ± {:.2} (1σ, fitted on the {}; fit rms {:.2} px)",
        c.cx, c.cy, c.radius, det.uncertainty_px, det.fitted_on, det.rms_residual_px
    )
}

/// The figure rows after the circle: sizes, integrator, depth, mesh, means, accuracy,
/// interreflections.
pub(super) fn summary(
    job: &Job,
    est: &Estimate,
    depth: &DepthMap,
    mesh: &mesh::Mesh,
    method: integrate::Method,
    acc: &Accuracy,
    ir: &Option<Interreflections>,
) -> Vec<Figure> {
    let s = &job.target;
    let mut f = vec![
        Figure::new("images", format!("{} of {}×{}", s.k, s.width, s.height)),
        Figure::new("pixels in the mask", job.mask.count().to_string()),
        Figure::new("integrator", method.name().to_string()),
        Figure::new(
            "depth range (px)",
            format!("{:.2}", depth_range(depth, &job.mask)),
        ),
        Figure::new(
            "mesh",
            format!(
                "{} vertices, {} triangles{}",
                mesh.vertices.len(),
                mesh.faces.len(),
                if mesh.stride > 1 {
                    format!(
                        " (one vertex every {} rows and columns: the mesh is capped; \
                         depth.npy has every pixel)",
                        mesh.stride
                    )
                } else {
                    String::new()
                }
            ),
        ),
    ];
    if let Some(c) = &est.confidence {
        let mean = masked_mean(c, &job.mask);
        f.push(Figure::new("mean confidence", format!("{mean:.3}")));
    }
    if let Some(a) = &est.albedo {
        let mean = masked_mean(a, &job.mask);
        f.push(Figure::new("mean albedo", format!("{mean:.3}")));
    }
    f.extend(accuracy_rows(acc));
    if let Some(ir) = ir {
        f.push(Figure::new("interreflections", ir.summary.clone()));
        f.push(Figure::new(
            "depth range before → after interreflection removal (px)",
            format!("{:.2} → {:.2}", ir.depth_before, ir.depth_after),
        ));
        f.push(Figure::new(
            "mean albedo before → after",
            format!("{:.3} → {:.3}", ir.albedo_before, ir.albedo_after),
        ));
    }
    f
}

fn accuracy_rows(acc: &Accuracy) -> Vec<Figure> {
    let mut f = Vec::new();
    if let Some((st, _)) = &acc.angular {
        f.push(Figure::new(
            "mean angular error (°)",
            format!("{:.3}", st.mean),
        ));
        f.push(Figure::new(
            "median angular error (°)",
            format!("{:.3}", st.median),
        ));
    }
    if let Some((st, _)) = &acc.depth {
        f.push(Figure::new(
            "depth RMSE after offset (px)",
            format!(
                "{:.3} ({:.2}% of the range {:.1})",
                st.rmse,
                100.0 * st.rmse / st.range.max(1e-9),
                st.range
            ),
        ));
    }
    f
}
