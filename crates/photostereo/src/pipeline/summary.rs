//! The typed summary of a run ([`RunSummary`]): `run.json` is its serialisation, and the
//! report, the `run` subcommand's terminal table and Python's dict are made from it.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::Output;
use crate::warning::{Warning, WarningCode};

/// One row of a run's figures: what it is and its value, as the report shows it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Figure {
    /// What is measured (the report's label, a key of `run.json`'s `figures`).
    pub name: String,
    /// Its value, with its units and how it was measured.
    pub value: String,
}

impl Figure {
    /// The row `name`: `value`.
    pub fn new(name: impl Into<String>, value: impl Into<String>) -> Self {
        Figure {
            name: name.into(),
            value: value.into(),
        }
    }
}

/// A picture a stage made (e.g. the interreflection iteration's plots).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Plot {
    /// The file it is written to in the output folder (`profiles.png`, …).
    pub file: String,
    /// The PNG bytes.
    pub png: Vec<u8>,
}

/// The seconds one stage took.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StageTime {
    /// The stage's name.
    pub stage: String,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Angular error of the normals against the truth (degrees).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AngularError {
    /// Mean over the counted pixels.
    pub mean: f64,
    /// Median over the counted pixels.
    pub median: f64,
    /// Pixels counted.
    pub count: usize,
}

/// Depth error against the truth after the best offset (pixels).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DepthError {
    /// Root mean square error.
    pub rmse: f64,
    /// Depth range of the truth.
    pub range: f64,
    /// Offset added to the estimate.
    pub offset: f64,
}

/// What interreflection removal changed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InterreflectionFigures {
    /// Depth range over the mask of the raw reconstruction (px).
    pub depth_before_px: f32,
    /// The same for the kept iterate.
    pub depth_after_px: f32,
    /// Mean albedo of the raw reconstruction.
    pub mean_albedo_before: f32,
    /// The same for the kept iterate.
    pub mean_albedo_after: f32,
    /// Compensation steps done.
    pub iterations: usize,
    /// One-line summary of the iteration.
    pub summary: String,
}

/// Everything `run.json` holds, typed. Serialised (see [`RunSummary::to_json`]) its keys
/// are those `run.json` has always had — `figures` an object of name → value,
/// `warnings` a list of messages — and `warning_codes`, each warning's code in the same
/// order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(into = "Wire", from = "Wire")]
pub struct RunSummary {
    /// The dataset's title.
    pub dataset: String,
    /// The integrator used (its name).
    pub integrator: String,
    /// Seconds per stage, in order (loading included).
    pub stages: Vec<StageTime>,
    /// Their sum.
    pub total_seconds: f64,
    /// The figures, in the order of the report (`run.json` sorts them by name).
    pub figures: Vec<Figure>,
    /// How far not to trust the result, and why.
    pub warnings: Vec<Warning>,
    /// Against the truth, when the job had some.
    pub angular_error_deg: Option<AngularError>,
    /// Against the truth, when the job had some.
    pub depth_error_px: Option<DepthError>,
    /// With interreflection removal.
    pub interreflections: Option<InterreflectionFigures>,
    /// The files written.
    pub files: Vec<String>,
    /// The files of an earlier run in the folder that this run removed.
    pub stale_removed: Vec<String>,
}

impl RunSummary {
    /// The summary of `p` for the dataset `title`, with every stage's seconds (`stages`,
    /// those before the pipeline's own included); no files yet.
    pub fn of(title: &str, p: &Output, stages: &[(String, f64)]) -> Self {
        let ir = p.interreflections.as_ref();
        RunSummary {
            dataset: title.to_string(),
            integrator: p.method.name().to_string(),
            stages: stages
                .iter()
                .map(|(stage, seconds)| StageTime {
                    stage: stage.clone(),
                    seconds: *seconds,
                })
                .collect(),
            total_seconds: stages.iter().map(|s| s.1).sum::<f64>(),
            figures: p.figures.clone(),
            warnings: p.warnings.clone(),
            angular_error_deg: p.accuracy.angular.as_ref().map(|(s, _)| AngularError {
                mean: s.mean,
                median: s.median,
                count: s.count,
            }),
            depth_error_px: p.accuracy.depth.as_ref().map(|(s, _)| DepthError {
                rmse: s.rmse,
                range: s.range,
                offset: s.offset,
            }),
            interreflections: ir.map(|ir| InterreflectionFigures {
                depth_before_px: ir.depth_before,
                depth_after_px: ir.depth_after,
                mean_albedo_before: ir.albedo_before,
                mean_albedo_after: ir.albedo_after,
                iterations: ir.iterations,
                summary: ir.summary.clone(),
            }),
            files: Vec::new(),
            stale_removed: Vec::new(),
        }
    }

    /// As a JSON value (its objects' keys sorted, as `run.json` writes them).
    pub fn to_json(&self) -> serde_json::Value {
        // the wire struct holds strings, numbers, lists and maps only: nothing can fail
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }

    /// Read a summary back from `run.json`'s text.
    ///
    /// Errors: text that is not a run summary (the serde message).
    pub fn from_json(text: &str) -> serde_json::Result<Self> {
        serde_json::from_str(text)
    }
}

/// `run.json`'s layout.
#[derive(Serialize, Deserialize)]
struct Wire {
    dataset: String,
    integrator: String,
    stages: Vec<StageTime>,
    total_seconds: f64,
    figures: BTreeMap<String, String>,
    warnings: Vec<String>,
    #[serde(default)]
    warning_codes: Vec<WarningCode>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    angular_error_deg: Option<AngularError>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    depth_error_px: Option<DepthError>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    interreflections: Option<InterreflectionFigures>,
    #[serde(default)]
    files: Vec<String>,
    #[serde(default)]
    stale_removed: Vec<String>,
}

impl From<RunSummary> for Wire {
    fn from(s: RunSummary) -> Self {
        Wire {
            dataset: s.dataset,
            integrator: s.integrator,
            stages: s.stages,
            total_seconds: s.total_seconds,
            figures: s.figures.into_iter().map(|f| (f.name, f.value)).collect(),
            warning_codes: s.warnings.iter().map(|w| w.code).collect(),
            warnings: s.warnings.into_iter().map(|w| w.message).collect(),
            angular_error_deg: s.angular_error_deg,
            depth_error_px: s.depth_error_px,
            interreflections: s.interreflections,
            files: s.files,
            stale_removed: s.stale_removed,
        }
    }
}

impl From<Wire> for RunSummary {
    fn from(w: Wire) -> Self {
        // a run.json from before the codes: every warning is `Other`
        let codes = w
            .warning_codes
            .into_iter()
            .chain(std::iter::repeat(WarningCode::Other));
        RunSummary {
            dataset: w.dataset,
            integrator: w.integrator,
            stages: w.stages,
            total_seconds: w.total_seconds,
            figures: w
                .figures
                .into_iter()
                .map(|(n, v)| Figure::new(n, v))
                .collect(),
            warnings: w
                .warnings
                .into_iter()
                .zip(codes)
                .map(|(m, c)| Warning::new(c, m))
                .collect(),
            angular_error_deg: w.angular_error_deg,
            depth_error_px: w.depth_error_px,
            interreflections: w.interreflections,
            files: w.files,
            stale_removed: w.stale_removed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> RunSummary {
        RunSummary {
            dataset: "vase".into(),
            integrator: "lsq".into(),
            stages: vec![StageTime {
                stage: "lookup".into(),
                seconds: 0.25,
            }],
            total_seconds: 0.25,
            figures: vec![
                Figure::new("mesh", "3 vertices"),
                Figure::new("images", "12"),
            ],
            warnings: vec![Warning::new(
                WarningCode::LowConfidence,
                "low confidence: …",
            )],
            angular_error_deg: Some(AngularError {
                mean: 0.5,
                median: 0.4,
                count: 100,
            }),
            depth_error_px: None,
            interreflections: None,
            files: vec!["normals.npy".into()],
            stale_removed: Vec::new(),
        }
    }

    #[test]
    fn run_json_keeps_its_keys_and_adds_the_codes() {
        let v = sample().to_json();
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(|k| k.as_str()).collect();
        let want = [
            "angular_error_deg",
            "dataset",
            "figures",
            "files",
            "integrator",
            "stages",
            "stale_removed",
            "total_seconds",
            "warning_codes",
            "warnings",
        ];
        assert_eq!(keys, want);
        assert_eq!(v["figures"]["mesh"], "3 vertices");
        assert_eq!(v["warnings"][0], "low confidence: …");
        assert_eq!(v["warning_codes"][0], "low_confidence");
        assert_eq!(v["stages"][0]["stage"], "lookup");
        assert_eq!(v["angular_error_deg"]["count"], 100);
    }

    #[test]
    fn a_summary_reads_back_from_its_json() {
        let s = sample();
        let back = RunSummary::from_json(&s.to_json().to_string()).unwrap();
        // run.json sorts the figures by name
        let mut sorted = s.clone();
        sorted.figures.sort_by(|a, b| a.name.cmp(&b.name));
        assert_eq!(back, sorted);
        // a run.json from before the codes: its warnings read as `Other`
        let mut old = s.to_json();
        old.as_object_mut().unwrap().remove("warning_codes");
        let back = RunSummary::from_json(&old.to_string()).unwrap();
        assert_eq!(back.warnings[0].code, WarningCode::Other);
        assert_eq!(back.warnings[0].message, s.warnings[0].message);
    }
}
