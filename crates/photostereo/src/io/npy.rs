//! NumPy `.npy` arrays through `ndarray-npy`: normal maps (H, W, 3), gray images and
//! depth maps (H, W), masks (H, W).
//!
//! Written arrays are float32 (bool for masks), C order. Reading accepts float32 or
//! float64 (masks: bool, uint8, int64, float32, float64; non-zero and not NaN = inside),
//! in C or Fortran order.

use super::limits;
use super::{read_file, write_atomic};
use crate::error::{Error, Result};
use crate::image::{GrayImage, Image, Mask, NormalMap};
use ndarray::{Array2, ArrayD, ArrayView2, ArrayView3};
use ndarray_npy::{ReadNpyExt, ReadableElement, WriteNpyExt};
use std::path::Path;

const FIX: &str = "give the path of an existing .npy file";

/// Read an `.npy` file whole, after checking that its header is sound and that the
/// file holds exactly the data the header claims (see [`limits`]): `ndarray-npy`
/// allocates what the shape claims before reading, so a lying header must not reach it.
fn read_checked(path: &Path) -> Result<Checked> {
    let bytes = read_file(path, FIX)?;
    let (claim, start) = check_npy(&bytes).map_err(|message| Error::Decode {
        path: path.to_path_buf(),
        message,
    })?;
    Ok(Checked {
        bytes,
        claim,
        start,
    })
}

/// A whole `.npy` file whose header was checked: its bytes, what the header claims and
/// where the data starts.
struct Checked {
    bytes: Vec<u8>,
    claim: Claim,
    start: usize,
}

/// What an `.npy` header claims: the element size (bytes) and the shape.
#[derive(Debug, PartialEq)]
struct Claim {
    item: u64,
    shape: Vec<u64>,
    /// Little-endian float32 in C order (`'<f4'`, `fortran_order: False`): the layout
    /// this program writes, read without ndarray's copy ([`read_plain`]).
    plain_f32: bool,
}

/// Check the header of an `.npy` file against its length and the limits; returns the
/// claim and where the data starts.
fn check_npy(bytes: &[u8]) -> std::result::Result<(Claim, usize), String> {
    let (claim, data_start) = parse_header(bytes)?;
    let mut count: u64 = 1;
    for &d in &claim.shape {
        count = count
            .checked_mul(d)
            .ok_or_else(|| format!("the header claims shape {:?}: too large", claim.shape))?;
    }
    let claimed = count
        .checked_mul(claim.item)
        .ok_or_else(|| format!("the header claims shape {:?}: too large", claim.shape))?;
    let held = (bytes.len() - data_start) as u64;
    if claimed != held {
        return Err(format!(
            "the header claims shape {:?} of {}-byte elements ({claimed} bytes of data), \
             the file holds {held} bytes (truncated or damaged file)",
            claim.shape, claim.item
        ));
    }
    if let [h, w, ..] = claim.shape[..] {
        if h > limits::MAX_SIDE || w > limits::MAX_SIDE || h.saturating_mul(w) > limits::MAX_PIXELS
        {
            return Err(format!(
                "shape {:?}: over the limit of {} per side and {} pixels",
                claim.shape,
                limits::MAX_SIDE,
                limits::MAX_PIXELS
            ));
        }
    }
    Ok((claim, data_start))
}

/// Parse the magic, version, header length and the `descr` and `shape` entries of the
/// header dictionary; returns the claim and where the data starts.
fn parse_header(bytes: &[u8]) -> std::result::Result<(Claim, usize), String> {
    const MAGIC: &[u8] = b"\x93NUMPY";
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        return Err("not a .npy file (no \\x93NUMPY signature)".into());
    }
    let (len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as u64, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as u64,
            12,
        ),
        v => {
            return Err(format!(
                ".npy format version {v} (this program reads 1 to 3)"
            ))
        }
    };
    if len > limits::MAX_NPY_HEADER || start as u64 + len > bytes.len() as u64 {
        return Err(format!(
            "the header claims {len} bytes, the file holds {} (truncated or damaged file)",
            bytes.len() - start
        ));
    }
    let end = start + len as usize;
    let text = std::str::from_utf8(&bytes[start..end])
        .map_err(|_| "the header is not text (damaged file)".to_string())?;
    let claim = Claim {
        item: item_size(text)?,
        shape: shape(text)?,
        plain_f32: is_plain_f32(text),
    };
    Ok((claim, end))
}

/// The text after `'key':` in a header dictionary.
fn entry<'a>(text: &'a str, key: &str) -> std::result::Result<&'a str, String> {
    let quoted = [format!("'{key}'"), format!("\"{key}\"")];
    let at = quoted
        .iter()
        .find_map(|q| text.find(q.as_str()).map(|i| i + q.len()))
        .ok_or_else(|| format!("the header has no '{key}' entry"))?;
    let rest = text[at..].trim_start();
    rest.strip_prefix(':')
        .map(str::trim_start)
        .ok_or_else(|| format!("the header's '{key}' entry is malformed"))
}

/// Element size from `descr` (`'<f4'`, `'|b1'`, ...); structured types are refused.
fn item_size(text: &str) -> std::result::Result<u64, String> {
    let d = entry(text, "descr")?;
    let q = d.chars().next().filter(|c| *c == '\'' || *c == '"');
    let bad = || {
        format!(
            "unsupported element type {}",
            d.split(',').next().unwrap_or(d)
        )
    };
    let q = q.ok_or_else(bad)?;
    let inner = d[1..].split(q).next().ok_or_else(bad)?;
    let digits = inner.trim_start_matches(['<', '>', '|', '=']);
    let size = digits.get(1..).and_then(|n| n.parse::<u64>().ok());
    match size {
        Some(s) if (1..=16).contains(&s) => Ok(s),
        _ => Err(bad()),
    }
}

/// The `shape` tuple.
fn shape(text: &str) -> std::result::Result<Vec<u64>, String> {
    let s = entry(text, "shape")?;
    let body = s
        .strip_prefix('(')
        .and_then(|r| r.split(')').next())
        .ok_or_else(|| "the header's shape is not a tuple".to_string())?;
    body.split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.trim_end_matches('L')
                .parse::<u64>()
                .map_err(|_| format!("the header's shape ({body}) is not a tuple of sizes"))
        })
        .collect()
}

/// Whether the header says little-endian float32 in C order.
fn is_plain_f32(text: &str) -> bool {
    let starts =
        |key, with: &[&str]| entry(text, key).is_ok_and(|v| with.iter().any(|w| v.starts_with(w)));
    starts("descr", &["'<f4'", "\"<f4\""]) && starts("fortran_order", &["False"])
}

/// The shape and the elements (`T`: f32 or [f32; 3], plain old data) of a checked
/// little-endian float32 C-order file, copied once from the file's bytes; `None` for
/// any other layout, or when the last axis does not fit `T`, or on a big-endian machine.
fn read_plain<T: bytemuck::Pod>(file: &Checked) -> Option<(Vec<usize>, Vec<T>)> {
    if cfg!(target_endian = "big") {
        return None;
    }
    let claim = &file.claim;
    let data = &file.bytes[file.start..];
    let size = std::mem::size_of::<T>();
    if !claim.plain_f32 || size == 0 || data.len() % size != 0 {
        return None;
    }
    let mut out = vec![T::zeroed(); data.len() / size];
    bytemuck::cast_slice_mut::<T, u8>(&mut out).copy_from_slice(data);
    let shape = claim.shape.iter().map(|&d| d as usize).collect();
    Some((shape, out))
}

/// An n-dimensional array of `f32` from the checked bytes of `path`, accepting float32
/// or float64 files in any layout.
fn read_f32_bytes(path: &Path, bytes: &[u8]) -> Result<ArrayD<f32>> {
    if let Ok(a) = ArrayD::<f32>::read_npy(bytes) {
        return Ok(a);
    }
    match ArrayD::<f64>::read_npy(bytes) {
        Ok(a) => Ok(a.mapv(|v| v as f32)),
        Err(e) => Err(decode_error(path, e, "a float32 or float64 array")),
    }
}

fn decode_error(path: &Path, e: impl std::fmt::Display, expected: &str) -> Error {
    Error::Decode {
        path: path.to_path_buf(),
        message: format!("{e} (expected {expected})"),
    }
}

fn shape_error(path: &Path, shape: &[usize], expected: &str) -> Error {
    Error::Decode {
        path: path.to_path_buf(),
        message: format!("array of shape {shape:?}, expected {expected}"),
    }
}

/// Read a normal map stored as an (H, W, 3) float array.
pub fn read_normals_npy(path: &Path) -> Result<NormalMap> {
    let file = read_checked(path)?;
    if let Some((shape, data)) = read_plain::<[f32; 3]>(&file) {
        if let [h, w, 3] = shape[..] {
            return Image::from_vec(w, h, data);
        }
    }
    let a = read_f32_bytes(path, &file.bytes)?;
    let shape = a.shape().to_vec();
    if shape.len() != 3 || shape[2] != 3 {
        return Err(shape_error(path, &shape, "(H, W, 3)"));
    }
    let data: Vec<[f32; 3]> = a
        .as_standard_layout()
        .as_slice()
        .unwrap_or_default()
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    Image::from_vec(shape[1], shape[0], data)
}

/// Read a gray image or depth map stored as an (H, W) float array (an (H, W, 1) array
/// is accepted too).
pub fn read_gray_npy(path: &Path) -> Result<GrayImage> {
    let file = read_checked(path)?;
    if let Some((shape, data)) = read_plain::<f32>(&file) {
        if let [h, w] | [h, w, 1] = shape[..] {
            return Image::from_vec(w, h, data);
        }
    }
    let a = read_f32_bytes(path, &file.bytes)?;
    let shape = a.shape().to_vec();
    let ok = shape.len() == 2 || (shape.len() == 3 && shape[2] == 1);
    if !ok {
        return Err(shape_error(path, &shape, "(H, W)"));
    }
    let data = a.as_standard_layout().iter().copied().collect();
    Image::from_vec(shape[1], shape[0], data)
}

/// Read a mask stored as an (H, W) array of bool, uint8, int64, float32 or float64;
/// non-zero (and not NaN) = inside.
pub fn read_mask_npy(path: &Path) -> Result<Mask> {
    let bytes = read_checked(path)?.bytes;
    fn try_read<T: ReadableElement + Clone>(
        bytes: &[u8],
        inside: impl Fn(&T) -> bool,
    ) -> Option<Mask> {
        let a = Array2::<T>::read_npy(bytes).ok()?;
        let (h, w) = a.dim();
        let data = a.as_standard_layout().iter().map(inside).collect();
        Image::from_vec(w, h, data).ok()
    }
    try_read::<bool>(&bytes, |&v| v)
        .or_else(|| try_read::<u8>(&bytes, |&v| v != 0))
        .or_else(|| try_read::<i64>(&bytes, |&v| v != 0))
        .or_else(|| try_read::<f32>(&bytes, |&v| v != 0.0 && !v.is_nan()))
        .or_else(|| try_read::<f64>(&bytes, |&v| v != 0.0 && !v.is_nan()))
        .ok_or_else(|| Error::Decode {
            path: path.to_path_buf(),
            message: "not a 2-D bool/uint8/int64/float32/float64 .npy array".into(),
        })
}

fn write_array<A: WriteNpyExt + ?Sized>(path: &Path, array: &A) -> Result<()> {
    write_atomic(path, |w| {
        array.write_npy(w).map_err(|e| super::encode_error(path, e))
    })
}

/// Write a normal map as float32 (H, W, 3) `.npy` (atomic).
pub fn write_normals(path: &Path, normals: &NormalMap) -> Result<()> {
    let flat: &[f32] = bytemuck::cast_slice(&normals.data);
    let a = ArrayView3::from_shape((normals.height, normals.width, 3), flat)
        .map_err(|e| super::encode_error(path, e))?;
    write_array(path, &a)
}

/// Write a gray image or depth map as float32 (H, W) `.npy` (atomic); NaN stays NaN.
pub fn write_gray_npy(path: &Path, img: &GrayImage) -> Result<()> {
    let a = ArrayView2::from_shape((img.height, img.width), &img.data[..])
        .map_err(|e| super::encode_error(path, e))?;
    write_array(path, &a)
}

/// Write a mask as bool (H, W) `.npy` (atomic).
pub fn write_mask_npy(path: &Path, mask: &Mask) -> Result<()> {
    let a = Array2::from_shape_vec((mask.height, mask.width), mask.data.clone())
        .map_err(|e| super::encode_error(path, e))?;
    write_array(path, &a)
}
