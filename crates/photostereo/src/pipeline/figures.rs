//! The figures of a run: the rows of the report and of `run.json`.

use serde_json::{json, Value};

use super::{Accuracy, Estimate, Interreflections, Job, Output};
use crate::image::{DepthMap, GrayImage, Mask};
use crate::{integrate, mesh, sphere};

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
) -> Vec<(String, String)> {
    let s = &job.target;
    let mut f = vec![
        (
            "images".to_string(),
            format!("{} of {}×{}", s.k, s.width, s.height),
        ),
        ("pixels in the mask".into(), job.mask.count().to_string()),
        ("integrator".into(), method.name().to_string()),
        (
            "depth range (px)".into(),
            format!("{:.2}", depth_range(depth, &job.mask)),
        ),
        (
            "mesh".into(),
            format!(
                "{} vertices, {} triangles",
                mesh.vertices.len(),
                mesh.faces.len()
            ),
        ),
    ];
    if let Some(c) = &est.confidence {
        let mean = masked_mean(c, &job.mask);
        f.push(("mean confidence".into(), format!("{mean:.3}")));
    }
    if let Some(a) = &est.albedo {
        let mean = masked_mean(a, &job.mask);
        f.push(("mean albedo".into(), format!("{mean:.3}")));
    }
    f.extend(accuracy_rows(acc));
    if let Some(ir) = ir {
        f.push(("interreflections".into(), ir.summary.clone()));
        f.push((
            "concavity depth before → after (px)".into(),
            format!("{:.2} → {:.2}", ir.depth_before, ir.depth_after),
        ));
        f.push((
            "mean albedo before → after".into(),
            format!("{:.3} → {:.3}", ir.albedo_before, ir.albedo_after),
        ));
    }
    f
}

fn accuracy_rows(acc: &Accuracy) -> Vec<(String, String)> {
    let mut f = Vec::new();
    if let Some((st, _)) = &acc.angular {
        f.push(("mean angular error (°)".into(), format!("{:.3}", st.mean)));
        f.push((
            "median angular error (°)".into(),
            format!("{:.3}", st.median),
        ));
    }
    if let Some((st, _)) = &acc.depth {
        f.push((
            "depth RMSE after offset (px)".into(),
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

/// `run.json`: the dataset's title, the integrator, per-stage seconds (`stages`, in
/// order, those before the pipeline's own included), the figures, and the accuracy and
/// interreflection numbers when there are some.
pub fn run_json(title: &str, p: &Output, stages: &[(String, f64)]) -> Value {
    let stage_list: Vec<Value> = stages
        .iter()
        .map(|(n, s)| json!({"stage": n, "seconds": s}))
        .collect();
    let figures: serde_json::Map<String, Value> = p
        .figures
        .iter()
        .map(|(k, v)| (k.clone(), Value::String(v.clone())))
        .collect();
    let mut v = json!({
        "dataset": title,
        "integrator": p.method.name(),
        "stages": stage_list,
        "total_seconds": stages.iter().map(|s| s.1).sum::<f64>(),
        "figures": figures,
    });
    if let Some((st, _)) = &p.accuracy.angular {
        v["angular_error_deg"] = json!({"mean": st.mean, "median": st.median, "count": st.count});
    }
    if let Some((st, _)) = &p.accuracy.depth {
        v["depth_error_px"] = json!({"rmse": st.rmse, "range": st.range, "offset": st.offset});
    }
    if let Some(ir) = &p.interreflections {
        v["interreflections"] = json!({
            "depth_before_px": ir.depth_before,
            "depth_after_px": ir.depth_after,
            "mean_albedo_before": ir.albedo_before,
            "mean_albedo_after": ir.albedo_after,
            "iterations": ir.iterations,
            "summary": ir.summary,
        });
    }
    v
}
