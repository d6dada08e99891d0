//! `Dataset` and `load_dataset`.

use std::path::PathBuf;

use numpy::{PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3};
use photostereo::image::{ImageStack, Lights, Mask};
use photostereo::io;
use pyo3::prelude::*;

use crate::convert;

/// A photometric-stereo dataset: K images under K lights.
///
/// `images` (K, H, W) float32: linear luminance, light intensities divided out;
/// `lights` (K, 3) float32 unit directions (surface → light; x right, y up, z toward
/// the camera) or None; `mask` (H, W) bool or None; `names` the image file names.
#[pyclass(module = "photostereo._native", frozen)]
pub struct Dataset {
    /// The images in the library's layout (H, W, K); `images` is its (K, H, W) view.
    hwk: Py<PyArray3<f32>>,
    lights: Option<Py<PyArray2<f32>>>,
    mask: Option<Py<PyArray2<bool>>>,
    names: Vec<String>,
    path: Option<PathBuf>,
}

#[pymethods]
impl Dataset {
    /// Dataset(images, lights=None, mask=None, names=None): a dataset from arrays;
    /// images (K, H, W) float32, lights (K, 3), mask (H, W) bool.
    #[new]
    #[pyo3(signature = (images, lights=None, mask=None, names=None))]
    fn new(
        py: Python<'_>,
        images: PyReadonlyArray3<'_, f32>,
        lights: Option<PyReadonlyArray2<'_, f32>>,
        mask: Option<PyReadonlyArray2<'_, bool>>,
        names: Option<Vec<String>>,
    ) -> PyResult<Self> {
        let stack = convert::stack_from(&images, names.unwrap_or_default())?;
        let lights = lights.map(|l| convert::lights_from(&l)).transpose()?;
        let mask = mask.map(|m| convert::mask_from(&m));
        Ok(Self::from_parts(py, stack, lights, mask, None))
    }

    /// (K, H, W) float32 images (a view of the dataset's buffer: no copy).
    #[getter]
    fn images<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let a = self.hwk.bind(py);
        a.call_method1("transpose", ((2, 0, 1),))
    }

    /// (K, 3) float32 unit light directions, or None (no light_directions.txt).
    #[getter]
    fn lights(&self, py: Python<'_>) -> Option<Py<PyArray2<f32>>> {
        self.lights.as_ref().map(|l| l.clone_ref(py))
    }

    /// (H, W) bool mask, or None (no mask.png).
    #[getter]
    fn mask(&self, py: Python<'_>) -> Option<Py<PyArray2<bool>>> {
        self.mask.as_ref().map(|m| m.clone_ref(py))
    }

    /// Image file names in light order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.names.clone()
    }

    /// The dataset directory (None for a dataset made from arrays).
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.path.clone()
    }

    /// Number of images K.
    fn __len__(&self, py: Python<'_>) -> usize {
        self.hwk.bind(py).dims()[2]
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let dims = self.hwk.bind(py).dims();
        format!(
            "Dataset({} images of {}×{}, lights: {}, mask: {}{})",
            dims[2],
            dims[1],
            dims[0],
            if self.lights.is_some() { "yes" } else { "no" },
            if self.mask.is_some() { "yes" } else { "no" },
            self.path
                .as_ref()
                .map(|p| format!(", from {}", p.display()))
                .unwrap_or_default()
        )
    }
}

impl Dataset {
    pub fn from_parts(
        py: Python<'_>,
        stack: ImageStack,
        lights: Option<Lights>,
        mask: Option<Mask>,
        path: Option<PathBuf>,
    ) -> Self {
        let names = stack.names.clone();
        Dataset {
            lights: lights.map(|l| convert::lights_to_py(py, &l).unbind()),
            mask: mask.map(|m| convert::mask_to_py(py, m).unbind()),
            hwk: convert::stack_to_py(py, stack).unbind(),
            names,
            path,
        }
    }

    /// The images as a library stack (a copy of the current array contents).
    pub fn stack(&self, py: Python<'_>) -> PyResult<ImageStack> {
        let a = self.hwk.bind(py).readonly();
        let view = a.as_array();
        let (h, w, k) = view.dim();
        let data = match view.as_slice() {
            Some(s) => s.to_vec(),
            None => view.iter().copied().collect(),
        };
        Ok(ImageStack {
            width: w,
            height: h,
            k,
            data,
            names: self.names.clone(),
        })
    }

    /// The mask as a library mask.
    pub fn mask_value(&self, py: Python<'_>) -> Option<Mask> {
        self.mask
            .as_ref()
            .map(|m| convert::mask_from(&m.bind(py).readonly()))
    }

    /// The lights as library lights.
    pub fn lights_value(&self, py: Python<'_>) -> PyResult<Option<Lights>> {
        self.lights
            .as_ref()
            .map(|l| convert::lights_from(&l.bind(py).readonly()))
            .transpose()
    }
}

/// load_dataset(path, response=None) -> Dataset: read a dataset directory (DiLiGenT
/// layout; PNG/TIFF/JPEG images, light_directions.txt or an RTI .lp / AliceVision
/// lights.json). response: "linear", "srgb", "gamma=G" or None (sRGB for JPEG files,
/// linear otherwise): how the stored values are linearised.
#[pyfunction]
#[pyo3(signature = (path, response=None))]
pub fn load_dataset(py: Python<'_>, path: PathBuf, response: Option<&str>) -> PyResult<Dataset> {
    let p = path.clone();
    let response: io::Response = match response {
        Some(r) => r.parse().map_err(crate::to_py)?,
        None => io::Response::Auto,
    };
    let d = crate::compute(py, move || {
        let opts = io::LoadOptions {
            response,
            ..Default::default()
        };
        io::load_dataset(&p, &opts)
    })?;
    Ok(Dataset::from_parts(
        py,
        d.stack,
        d.lights,
        d.mask,
        Some(path),
    ))
}
