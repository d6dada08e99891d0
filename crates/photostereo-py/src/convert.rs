//! numpy arrays ↔ the library's image types.
//!
//! Outputs cross without a copy: the library's `Vec` becomes the numpy array's buffer.
//! Inputs are copied once into the library's pixel-major layout (a `(K, H, W)` image
//! array is read in whatever strides it has; the transposed view that
//! `Dataset.images` returns is read straight through).

use ndarray::{Array2, Array3};
use numpy::{PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3};
use photostereo::image::{GrayImage, Image, ImageStack, Lights, Mask, NormalMap};
use pyo3::prelude::*;

/// `(K, H, W)` float32 images → a pixel-major stack named `names` (may be empty).
pub fn stack_from(images: &PyReadonlyArray3<'_, f32>, names: Vec<String>) -> PyResult<ImageStack> {
    let a = images.as_array();
    let (k, h, w) = a.dim();
    if k == 0 || h == 0 || w == 0 {
        return Err(value_error(format!(
            "images of shape ({k}, {h}, {w}): give a (K, H, W) array with K, H, W > 0"
        )));
    }
    // without names, a lookup table's names are not compared
    let names = if names.is_empty() || names.len() == k {
        names
    } else {
        return Err(value_error(format!(
            "{} names for {k} images: give one name per image",
            names.len()
        )));
    };
    let hwk = a.permuted_axes([1, 2, 0]);
    let data: Vec<f32> = match hwk.as_slice() {
        Some(s) => s.to_vec(),
        None => hwk.iter().copied().collect(),
    };
    Ok(ImageStack {
        width: w,
        height: h,
        k,
        data,
        names,
    })
}

/// `(H, W)` bool → a mask.
pub fn mask_from(mask: &PyReadonlyArray2<'_, bool>) -> Mask {
    let a = mask.as_array();
    let (h, w) = a.dim();
    Image {
        width: w,
        height: h,
        data: a.iter().copied().collect(),
    }
}

/// `(H, W)` float32 → a gray image.
pub fn gray_from(img: &PyReadonlyArray2<'_, f32>) -> GrayImage {
    let a = img.as_array();
    let (h, w) = a.dim();
    Image {
        width: w,
        height: h,
        data: a.iter().copied().collect(),
    }
}

/// `(H, W, 3)` float32 → a normal map.
pub fn normals_from(n: &PyReadonlyArray3<'_, f32>) -> PyResult<NormalMap> {
    let a = n.as_array();
    let (h, w, c) = a.dim();
    if c != 3 {
        return Err(value_error(format!(
            "normals of shape ({h}, {w}, {c}): give an (H, W, 3) array"
        )));
    }
    let flat: Vec<f32> = a.iter().copied().collect();
    Ok(Image {
        width: w,
        height: h,
        data: flat.chunks_exact(3).map(|v| [v[0], v[1], v[2]]).collect(),
    })
}

/// `(K, 3)` float32 directions → unit lights of intensity 1.
pub fn lights_from(l: &PyReadonlyArray2<'_, f32>) -> PyResult<Lights> {
    let a = l.as_array();
    let (k, c) = a.dim();
    if c != 3 {
        return Err(value_error(format!(
            "lights of shape ({k}, {c}): give a (K, 3) array of directions (x right, y up, z toward the camera)"
        )));
    }
    let dirs = a.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    Ok(Lights::from_directions(dirs))
}

/// A gray image → `(H, W)` float32, no copy.
pub fn gray_to_py(py: Python<'_>, img: GrayImage) -> Bound<'_, PyArray2<f32>> {
    let a = Array2::from_shape_vec((img.height, img.width), img.data)
        .expect("an image's data holds width × height values");
    PyArray2::from_owned_array(py, a)
}

/// A mask → `(H, W)` bool, no copy.
pub fn mask_to_py(py: Python<'_>, m: Mask) -> Bound<'_, PyArray2<bool>> {
    let a = Array2::from_shape_vec((m.height, m.width), m.data)
        .expect("a mask's data holds width × height values");
    PyArray2::from_owned_array(py, a)
}

/// A normal map → `(H, W, 3)` float32, no copy.
pub fn normals_to_py(py: Python<'_>, n: NormalMap) -> Bound<'_, PyArray3<f32>> {
    let flat: Vec<f32> = bytemuck::allocation::try_cast_vec(n.data)
        .unwrap_or_else(|(_, v)| v.into_iter().flatten().collect());
    let a = Array3::from_shape_vec((n.height, n.width, 3), flat)
        .expect("a normal map holds width × height normals");
    PyArray3::from_owned_array(py, a)
}

/// A stack → `(H, W, K)` float32 (its own layout), no copy.
pub fn stack_to_py(py: Python<'_>, s: ImageStack) -> Bound<'_, PyArray3<f32>> {
    let a = Array3::from_shape_vec((s.height, s.width, s.k), s.data)
        .expect("a stack holds width × height × k samples");
    PyArray3::from_owned_array(py, a)
}

/// Lights → `(K, 3)` float32 directions.
pub fn lights_to_py<'py>(py: Python<'py>, l: &Lights) -> Bound<'py, PyArray2<f32>> {
    let flat: Vec<f32> = l.directions.iter().flatten().copied().collect();
    let a = Array2::from_shape_vec((l.len(), 3), flat).expect("three values per light");
    PyArray2::from_owned_array(py, a)
}

/// A `ValueError` for bad arguments caught here (the library's own go through [`crate::to_py`]).
pub fn value_error(msg: String) -> PyErr {
    pyo3::exceptions::PyValueError::new_err(msg)
}

/// A JSON value as the Python object `json.loads` would give: dict, list, str, int,
/// float, bool or None.
pub fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use pyo3::types::{PyDict, PyList};
    use serde_json::Value;
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(a) => {
            let items = a
                .iter()
                .map(|x| json_to_py(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        Value::Object(m) => {
            let d = PyDict::new(py);
            for (k, x) in m {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}
