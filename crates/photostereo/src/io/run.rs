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
