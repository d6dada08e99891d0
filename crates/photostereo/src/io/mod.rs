//! Reading and writing datasets, images, `.npy` arrays and text — the only module
//! that touches the file system.
//!
//! # Dataset layout (DiLiGenT style)
//!
//! A dataset is one directory:
//!
//! | file | required | content |
//! |---|---|---|
//! | light images | yes | 8/16-bit grayscale or RGB PNG/TIFF, or JPEG, one per light |
//! | `filenames.txt` | no | the image file names in light order, one per line |
//! | `light_directions.txt` | no | one `x y z` line per light (surface → light, camera frame; normalised on load) |
//! | `light_intensities.txt` | no | one line per light: one value, or an `R G B` triple |
//! | `*.lp` or `lights.json` | no | instead of `light_directions.txt`: an RTIBuilder / Relight `.lp` file (it also lists the images: without `filenames.txt` they are its images, matched by file name) or an AliceVision `lights.json` (lights in image order; its intensities stand in for `light_intensities.txt`), see [`lights_file`] |
//! | `mask.png` | no | object mask, non-zero = inside |
//! | `exposure_times.txt` | no | several exposures per light: each `filenames.txt` line names one file per exposure, this file the relative exposure of each column; merged into one linear image per light, see [`hdr`] |
//!
//! Without `filenames.txt` the light images are every `*.png`, `*.tif`, `*.tiff`,
//! `*.jpg`, `*.jpeg` file of the directory in natural name order (`2.png` before `10.png`), except
//! files that are not light images by name ([`dataset::is_light_image_name`]):
//! a stem (name without extension, lower case) that contains `mask` (`mask.png`,
//! `lit_mask.png`), ends in `_gt` (`normal_gt.png`), or starts with `normal`,
//! `depth`, `albedo`, `error`, `overlay` or `preview` (outputs of this tool).
//!
//! # Pixel values
//!
//! Integer samples are divided by their full scale (255 or 65535), so values lie in
//! [0, 1]. RGB images are converted to luminance after each channel has been divided
//! by its light intensity: Y = 0.2126 R/I_R + 0.7152 G/I_G + 0.0722 B/I_B (Rec. 709
//! weights on linear values).
//!
//! Before that, each stored value is linearised by the response curve of
//! [`LoadOptions::response`] ([`Response`]): by default sRGB for JPEG files (camera
//! JPEGs are sRGB-encoded) and linear for PNG and TIFF (8-bit PNGs included, unless
//! told otherwise). Lambertian photometric stereo and light calibration need linear
//! values. The lookup of a sphere of the same material, same camera, does not: a
//! monotonic response shared by sphere and target leaves an exact match a match; it
//! does once the albedo is free (the table's scale normalisation assumes linear values).
//! A grayscale image with an RGB intensity triple is divided by the triple's
//! luminance. An alpha channel is ignored. Float TIFFs are taken as they are.
//!
//! # Limits
//!
//! Every reader checks what a header claims (an `.npy` shape, an image size, a table's
//! window) against the file's real size and the limits of [`limits`] before allocating,
//! and refuses the file with a message naming it and the claim. Text files are at most
//! [`limits::MAX_TEXT_BYTES`]; float images must hold finite values.
//!
//! # Writing
//!
//! Every writer goes through [`write_atomic`]: the bytes go to a temporary file in the
//! destination directory, which is renamed over the destination only when all of it
//! was written, so a failed or interrupted run never leaves a half-written file.

pub mod bands;
pub mod dataset;
pub mod export;
pub mod hdr;
pub mod lights_file;
pub mod limits;
pub mod memtrace;
pub mod npy;
pub mod raster;
pub mod response;
pub mod run;
pub mod text_files;

pub use bands::{probe_images, BandReader, StackHeader};
pub use dataset::{
    load_dataset, open_dataset_bands, readable_by_bands, write_dataset, Dataset, DatasetBands,
    LoadOptions,
};
pub use export::{write_depth_tiff, write_normal_map_png, write_normals_tiff, NormalMapStyle};
pub use lights_file::{read_light_file, read_lights_for, write_lp, LightFile, LightFormat};
pub use npy::{
    read_gray_npy, read_mask_npy, read_normals_npy, write_gray_npy, write_mask_npy, write_normals,
};
pub use raster::{
    read_gray_image, read_mask, read_mask_any, read_normals_any, read_normals_png,
    write_colormap_png, write_depth_png, write_gray_png, write_gray_png_range, write_mask_png,
    write_normals_png,
};
pub use response::Response;
pub use run::{
    dataset_name, has_ground_truth, previous_run_files, read_ground_truth, read_meta_scale,
    read_table, remove_files, write_table, RUN_FILES,
};
pub use text_files::{read_intensities, read_lights, write_intensities, write_light_directions};

use crate::error::{Error, Result};
use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Write a file atomically: `fill` writes the content into a temporary file next to
/// `path`, which then replaces `path` in one rename. On any error (from `fill`, from
/// the disk) the temporary file is removed and `path` is left untouched. Missing
/// parent directories are created.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let Some(name) = path.file_name() else {
        return Err(Error::invalid(
            format!("{}: not a file name", path.display()),
            "give the path of a file to write",
        ));
    };
    if path.is_dir() {
        return Err(Error::invalid(
            format!("{}: is a directory", path.display()),
            "give the path of a file to write (a new name, or a file to replace)",
        ));
    }
    create_dir_all(&dir)?;
    remove_stale_temps(&dir, &name.to_string_lossy());
    let tmp = temp_path(&dir, &name.to_string_lossy());
    let result = write_temp(&tmp, fill)
        .and_then(|()| fs::rename(&tmp, path).map_err(|e| Error::io(path, e)));
    if result.is_err() {
        // Best effort: the temporary file may not exist if creating it failed.
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// The error of creating the directory `dir`: when a part of it is an existing file,
/// say so, naming that file.
fn dir_error(dir: &Path, e: std::io::Error) -> Error {
    match dir.ancestors().find(|a| a.is_file()) {
        Some(file) => Error::invalid(
            format!("{}: is a file, not a directory", file.display()),
            "give an output path that is a directory or does not exist yet",
        ),
        None => Error::io(dir, e),
    }
}

/// A fresh, unused temporary name in `dir` for a file that will become `name`.
fn temp_path(dir: &Path, name: &str) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    dir.join(format!(".{name}.tmp-{}-{n}", std::process::id()))
}

/// Remove the temporaries of `name` in `dir` left by a process that no longer runs (one
/// killed by SIGKILL or a power cut while writing, which cannot clean up after itself).
/// A temporary whose process still runs (a concurrent writer) is left alone. Best
/// effort: an error here only leaves the stale file, it never fails the write. Linux
/// only (it asks `/proc` whether the writer lives); elsewhere nothing is removed.
fn remove_stale_temps(dir: &Path, name: &str) {
    if !cfg!(target_os = "linux") || !Path::new("/proc/self").exists() {
        return;
    }
    let prefix = format!(".{name}.tmp-");
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        let Some(Ok(pid)) = rest.split_once('-').map(|(pid, _)| pid.parse::<u32>()) else {
            continue;
        };
        if !Path::new("/proc").join(pid.to_string()).exists() {
            let _ = fs::remove_file(entry.path());
        }
    }
}

fn write_temp(tmp: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(tmp)
        .map_err(|e| Error::io(tmp, e))?;
    let mut writer = BufWriter::new(file);
    fill(&mut writer)?;
    let file: File = writer
        .into_inner()
        .map_err(|e| Error::io(tmp, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(tmp, e))
}

/// The machine's memory in bytes (`MemTotal` of `/proc/meminfo`); `None` where that is
/// not known (not Linux).
pub fn system_memory() -> Option<u64> {
    let text = fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Write a text file atomically.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_bytes(path, text.as_bytes())
}

/// Write raw bytes atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| w.write_all(bytes).map_err(|e| Error::io(path, e)))
}

/// Read a UTF-8 text file of at most [`limits::MAX_TEXT_BYTES`] (light directions,
/// intensities, file lists, JSON side files), with [`Error::NotFound`] naming it when
/// it does not exist.
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = limits::read_bounded(path, limits::MAX_TEXT_BYTES, "check the path")?;
    String::from_utf8(bytes).map_err(|_| Error::Decode {
        path: path.to_path_buf(),
        message: "not a UTF-8 text file".into(),
    })
}

/// Read a whole file of at most [`limits::MAX_FILE_BYTES`], with [`Error::NotFound`]
/// naming it when it does not exist.
pub(crate) fn read_file(path: &Path, fix: &str) -> Result<Vec<u8>> {
    limits::read_bounded(path, limits::MAX_FILE_BYTES, fix)
}

/// Create a directory and its parents; when a part of the path is an existing file, the
/// error says so, naming that file.
pub fn create_dir_all(dir: &Path) -> Result<()> {
    fs::create_dir_all(dir).map_err(|e| dir_error(dir, e))
}

/// Map an I/O error to [`Error::NotFound`] (with `fix`) or [`Error::Io`].
pub(crate) fn not_found_or_io(path: &Path, e: std::io::Error, fix: &str) -> Error {
    if e.kind() == std::io::ErrorKind::NotFound {
        Error::NotFound {
            path: path.to_path_buf(),
            fix: fix.to_string(),
        }
    } else {
        Error::io(path, e)
    }
}

/// An encoder error while writing `path`.
pub(crate) fn encode_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::io(path, std::io::Error::other(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_killed_writers_temporary_is_removed_a_live_ones_kept() {
        let dir = std::env::temp_dir().join(format!("ps-io-stale-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        // Linux pids are at most 2^22, so this writer cannot be running.
        let dead = dir.join(".depth.npy.tmp-999999999-0");
        let live = dir.join(format!(".depth.npy.tmp-{}-999", std::process::id()));
        let other = dir.join(".normals.npy.tmp-999999999-0");
        for f in [&dead, &live, &other] {
            fs::write(f, b"partial").unwrap();
        }
        write_bytes(&dir.join("depth.npy"), b"whole").unwrap();
        assert_eq!(fs::read(dir.join("depth.npy")).unwrap(), b"whole");
        if cfg!(target_os = "linux") {
            assert!(!dead.exists(), "a dead writer's temporary is removed");
        }
        assert!(live.exists(), "a running writer's temporary is kept");
        assert!(
            other.exists(),
            "only the temporaries of the file written are touched"
        );
        let _ = fs::remove_dir_all(&dir);
    }
}
