//! NumPy `.npy` arrays through `ndarray-npy`: normal maps (H, W, 3), gray images and
//! depth maps (H, W), masks (H, W).
//!
//! Written arrays are float32 (bool for masks), C order. Reading accepts float32 or
//! float64 (masks: bool, uint8, int64, float32, float64; non-zero and not NaN = inside),
//! in C or Fortran order.

use super::{read_file, write_atomic};
use crate::error::{Error, Result};
use crate::image::{GrayImage, Image, Mask, NormalMap};
use ndarray::{Array2, Array3, ArrayD};
use ndarray_npy::{ReadNpyExt, ReadableElement, WriteNpyExt};
use std::path::Path;

const FIX: &str = "give the path of an existing .npy file";

/// Read an n-dimensional array of `f32`, accepting float32 or float64 files.
fn read_f32_array(path: &Path) -> Result<ArrayD<f32>> {
    let bytes = read_file(path, FIX)?;
    if let Ok(a) = ArrayD::<f32>::read_npy(&bytes[..]) {
        return Ok(a);
    }
    match ArrayD::<f64>::read_npy(&bytes[..]) {
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
    let a = read_f32_array(path)?;
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
    let a = read_f32_array(path)?;
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
    let bytes = read_file(path, FIX)?;
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
    let flat: Vec<f32> = normals.data.iter().flatten().copied().collect();
    let a = Array3::from_shape_vec((normals.height, normals.width, 3), flat)
        .map_err(|e| super::encode_error(path, e))?;
    write_array(path, &a)
}

/// Write a gray image or depth map as float32 (H, W) `.npy` (atomic); NaN stays NaN.
pub fn write_gray_npy(path: &Path, img: &GrayImage) -> Result<()> {
    let a = Array2::from_shape_vec((img.height, img.width), img.data.clone())
        .map_err(|e| super::encode_error(path, e))?;
    write_array(path, &a)
}

/// Write a mask as bool (H, W) `.npy` (atomic).
pub fn write_mask_npy(path: &Path, mask: &Mask) -> Result<()> {
    let a = Array2::from_shape_vec((mask.height, mask.width), mask.data.clone())
        .map_err(|e| super::encode_error(path, e))?;
    write_array(path, &a)
}
