//! The limits of every reader, in one place.
//!
//! A file's header states how much data follows (an `.npy` shape, a PNG/TIFF size, a
//! table's window). Readers check that claim against the file's real size and against
//! the limits below *before* allocating anything of that size, and refuse a file that
//! breaks either with a message naming the file and what it claims. So a damaged or
//! hostile file can make a reader fail, never abort on an impossible allocation.
//!
//! | what | limit | why |
//! |---|---|---|
//! | any file read whole (`.npy`, `.lut`) | [`MAX_FILE_BYTES`] = 4 GiB | 30× a 1024² × 96-light float stack |
//! | text files (lights, intensities, file list, JSON) | [`MAX_TEXT_BYTES`] = 16 MiB | 400 000 light lines |
//! | image side (PNG/TIFF, `.npy` H and W) | [`MAX_SIDE`] = 65 536 px | |
//! | pixels per image or array plane | [`MAX_PIXELS`] = 2^28 (16 384²) | |
//! | decoder allocation per image | [`MAX_DECODE_BYTES`] = 2 GiB | a 16 384² RGBA 16-bit image |
//! | `.npy` header | [`MAX_NPY_HEADER`] = 64 KiB | NumPy writes < 1 KiB |
//!
//! Compressed images (PNG deflate, TIFF LZW) cannot be checked against the file size
//! (deflate reaches 1032:1), so for them the pixel and allocation limits are what
//! bound memory; an `.npy` array and a table must hold exactly the bytes their header
//! claims.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// Largest file read whole into memory (`.npy` arrays, lookup tables), bytes.
pub const MAX_FILE_BYTES: u64 = 4 << 30;
/// Largest text file (light directions, intensities, file list, JSON side files), bytes.
pub const MAX_TEXT_BYTES: u64 = 16 << 20;
/// Largest width or height of an image or array, pixels.
pub const MAX_SIDE: u64 = 1 << 16;
/// Largest number of pixels of one image or array plane (16 384²).
pub const MAX_PIXELS: u64 = 1 << 28;
/// Largest buffer an image decoder may allocate for one image, bytes.
pub const MAX_DECODE_BYTES: u64 = 2 << 30;
/// Largest `.npy` header (the text dictionary after the magic), bytes.
pub const MAX_NPY_HEADER: u64 = 64 << 10;

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
