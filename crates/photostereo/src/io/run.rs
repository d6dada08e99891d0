//! The files of a `run` beyond the dataset itself: ground truth beside the images,
//! the image scale of a render's `meta.json`, lookup-table files and the dataset's name.

use std::path::Path;

use super::{npy, read_file, write_bytes};
use crate::error::{Error, Result};
use crate::image::{DepthMap, NormalMap};
use crate::lut::Table;

/// `normal_gt.npy` and `depth_gt.npy` of a dataset directory, each when present.
pub fn read_ground_truth(dir: &Path) -> Result<(Option<NormalMap>, Option<DepthMap>)> {
    let n = dir.join("normal_gt.npy");
    let d = dir.join("depth_gt.npy");
    let normals = n.is_file().then(|| npy::read_normals_npy(&n)).transpose()?;
    let depth = d.is_file().then(|| npy::read_gray_npy(&d)).transpose()?;
    Ok((normals, depth))
}

/// Whether `dir` holds a ground truth that [`read_ground_truth`] would read (a run by
/// bands reads it only once the normals are made, to keep it out of their peak memory).
pub fn has_ground_truth(dir: &Path) -> bool {
    dir.join("normal_gt.npy").is_file() || dir.join("depth_gt.npy").is_file()
}

/// `65535 / scale` from the dataset's `meta.json` when it has a positive `scale` field
/// (renders that store radiance × scale in 16-bit PNGs); `None` without the file or field.
pub fn read_meta_scale(dir: &Path) -> Result<Option<f32>> {
    let path = dir.join("meta.json");
    if !path.exists() {
        return Ok(None);
    }
    let text = super::read_text(&path)?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| Error::Decode {
        path: path.clone(),
        message: format!("not valid JSON ({e})"),
    })?;
    Ok(v.get("scale")
        .and_then(|s| s.as_f64())
        .filter(|s| *s > 0.0)
        .map(|s| (65535.0 / s) as f32))
}

/// Read a lookup-table file (`.lut`, as `photostereo calibrate` writes it).
pub fn read_table(path: &Path) -> Result<Table> {
    let bytes = read_file(
        path,
        "give the path of a table written by `photostereo calibrate`",
    )?;
    Table::from_bytes(&bytes).map_err(|e| Error::Decode {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Write a lookup table atomically (the format of [`crate::lut::format`]).
pub fn write_table(path: &Path, table: &Table) -> Result<()> {
    write_bytes(path, &table.to_bytes())
}

/// The name of a dataset directory (its last component after resolving `.` and `..`),
/// for titles; the path as given when it has no name.
pub fn dataset_name(dir: &Path) -> String {
    dir.canonicalize()
        .ok()
        .as_deref()
        .unwrap_or(dir)
        .file_name()
        .map_or_else(
            || dir.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
}

/// Every file name a `run` can write into its output directory. Only these are ever
/// removed as stale ([`previous_run_files`], [`remove_files`]): an output directory may
/// hold the user's own files too.
pub const RUN_FILES: &[&str] = &[
    "normals.npy",
    "normals.png",
    "albedo.npy",
    "albedo.png",
    "confidence.npy",
    "confidence.png",
    "normals_sigma.npy",
    "normals_sigma.png",
    "own_share.npy",
    "depth.npy",
    "depth.png",
    "mesh.ply",
    "curvature.npy",
    "curvature.png",
    "gaussian_curvature.npy",
    "normal_map.png",
    "normals.tif",
    "depth.tif",
    "lights.txt",
    "chrome_overlay.png",
    "sphere_overlay.png",
    "convergence.csv",
    "profiles.png",
    "convergence.png",
    "report.html",
    "run.json",
];

/// The files an earlier run wrote into `out`, as its `run.json` lists them (`files`);
/// for a `run.json` from before that list, every name of [`RUN_FILES`]. Empty when `out`
/// has no readable `run.json` (not a run's directory). Only names of [`RUN_FILES`] count.
pub fn previous_run_files(out: &Path) -> Vec<String> {
    let Ok(text) = super::read_text(&out.join("run.json")) else {
        return Vec::new();
    };
    let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) else {
        return Vec::new();
    };
    let listed: Option<Vec<&str>> = v
        .get("files")
        .and_then(|f| f.as_array())
        .map(|a| a.iter().filter_map(|s| s.as_str()).collect());
    RUN_FILES
        .iter()
        .filter(|n| listed.as_ref().is_none_or(|l| l.contains(n)))
        .map(|n| n.to_string())
        .collect()
}

/// Remove the files `names` (of [`RUN_FILES`] only) from `out`; returns those that were
/// there and are gone. A name that is not a file there is skipped.
pub fn remove_files(out: &Path, names: &[String]) -> Result<Vec<String>> {
    let mut removed = Vec::new();
    for name in names.iter().filter(|n| RUN_FILES.contains(&n.as_str())) {
        let path = out.join(name);
        if path.is_file() {
            std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
            removed.push(name.clone());
        }
    }
    Ok(removed)
}
