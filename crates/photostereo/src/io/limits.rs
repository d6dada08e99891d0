//! The readers' checks of a file's size and of the sizes its header claims, against
//! the limits of [`crate::limits`] (re-exported here).

pub use crate::limits::*;

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// Read a whole file of at most `max` bytes. The size is checked before reading, and
/// the read itself stops past `max` (a file that grows, or a device with no size, is
/// refused too). A missing file is [`Error::NotFound`] with `fix`.
pub fn read_bounded(path: &Path, max: u64, fix: &str) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|e| super::not_found_or_io(path, e, fix))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return Err(Error::invalid(
            format!("{}: is a directory", path.display()),
            fix.to_string(),
        ));
    }
    if meta.len() > max {
        return Err(too_large(path, meta.len(), max));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(max + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > max {
        return Err(too_large(path, bytes.len() as u64, max));
    }
    Ok(bytes)
}

fn too_large(path: &Path, size: u64, max: u64) -> Error {
    Error::invalid(
        format!(
            "{}: file of {size} bytes, over the limit of {max} bytes",
            path.display()
        ),
        "check that this is the right file (see the README, \"Limits\")",
    )
}

/// Check an image or array size claimed by the header of `path` against [`MAX_SIDE`]
/// and [`MAX_PIXELS`].
pub fn check_dimensions(path: &Path, width: u64, height: u64) -> Result<()> {
    let pixels = width.checked_mul(height);
    if width > MAX_SIDE || height > MAX_SIDE || pixels.is_none_or(|p| p > MAX_PIXELS) {
        return Err(Error::Decode {
            path: path.to_path_buf(),
            message: format!(
                "the header claims {width}x{height} pixels, over the limit of \
                 {MAX_SIDE} per side and {MAX_PIXELS} in all (damaged file?)"
            ),
        });
    }
    Ok(())
}

/// The `image` crate's decoder limits from the constants above.
pub(crate) fn image_limits() -> image::Limits {
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_SIDE as u32);
    limits.max_image_height = Some(MAX_SIDE as u32);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    limits
}
