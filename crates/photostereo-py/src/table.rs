//! `Table` (a lookup table with the sphere detection it came from) and `calibrate`.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use numpy::{PyReadonlyArray2, PyReadonlyArray3};
use photostereo::image::{GrayImage, Mask};
use photostereo::pipeline::Calibration;
use photostereo::sphere::{Circle, DetectOptions, Detection};
use photostereo::{io, lut, pipeline};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::convert;
use crate::dataset::Dataset;
use crate::funcs::LookupResult;

/// A lookup table: intensity tuple → normal, from a calibration sphere.
#[pyclass(module = "photostereo._native", frozen)]
#[derive(Clone)]
pub struct Table {
    pub cal: Calibration,
    /// The lookup prepared from the table (search index, isolation radii, rim model),
    /// without and with `normalize`: built at its first use, then reused by every
    /// lookup with this table (not pickled: rebuilt after unpickling).
    prepared: [OnceLock<Arc<lut::Lookup<'static>>>; 2],
}

/// The lookup's options for `normalize`, as `photostereo normals [--normalize]`: with
/// it, brightness-normalised matching, or on a specular table the diffuse + specular
/// fit ([`lut::options_for`]).
pub fn lookup_options(normalize: bool) -> lut::Options {
    lut::Options {
        normalize,
        split_if_specular: normalize,
        ..lut::Options::default()
    }
}

impl Table {
    pub fn new(cal: Calibration) -> Self {
        Table {
            cal,
            prepared: Default::default(),
        }
    }

    /// The prepared lookup for `normalize` (built now if it was not yet; call it with
    /// the GIL released).
    pub fn prepared(&self, normalize: bool) -> photostereo::Result<Arc<lut::Lookup<'static>>> {
        let slot = &self.prepared[usize::from(normalize)];
        if let Some(l) = slot.get() {
            return Ok(l.clone());
        }
        let tables = vec![self.cal.table.clone()];
        let built = Arc::new(lut::Lookup::new(tables, &lookup_options(normalize))?);
        // two threads may both build it: the first one stored is kept
        Ok(slot.get_or_init(|| built).clone())
    }
}

#[pymethods]
impl Table {
    /// The sphere's circle (cx, cy, r) in pixels: cx along columns, cy along rows,
    /// pixel (r, c) centred at (c + 0.5, r + 0.5).
    #[getter]
    fn circle(&self) -> (f64, f64, f64) {
        let c = self.cal.table.circle;
        (c.cx, c.cy, c.radius)
    }

    /// Number of lights K.
    #[getter]
    fn k(&self) -> usize {
        self.cal.table.k
    }

    /// Image names the table was built from, in light order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.cal.table.names.clone()
    }

    /// Free-text material name.
    #[getter]
    fn material(&self) -> String {
        self.cal.table.material.clone()
    }

    /// Number of table entries (sphere pixels used).
    fn __len__(&self) -> usize {
        self.cal.table.entries.len()
    }

    /// The optical blur of the sphere's images (px, Gaussian σ) measured on its rim when
    /// the table was built; None where it could not be measured. Above 0.35 px the
    /// spatial stage weights the target's outline down.
    #[getter]
    fn rim_blur(&self) -> Option<f64> {
        self.cal.table.rim_blur
    }

    /// RMS distance of the edge points to the fitted circle (px); None for a loaded table.
    #[getter]
    fn fit_rms(&self) -> Option<f64> {
        self.cal.detection.as_ref().map(|d| d.rms_residual_px)
    }

    /// lookup(target, *, mask=None, normalize=False, spatial=True) -> Result: normals of
    /// `target` (a Dataset, a dataset directory or a (K, H, W) array under the same
    /// lights) by this table, as `photostereo normals --lut` (spatial=False:
    /// `--no-spatial`); see `photostereo.lookup`. The table's search index is built at
    /// the first lookup and reused.
    #[pyo3(signature = (target, *, mask=None, normalize=false, spatial=true))]
    fn lookup(
        &self,
        py: Python<'_>,
        target: Bound<'_, PyAny>,
        mask: Option<Bound<'_, PyAny>>,
        normalize: bool,
        spatial: bool,
    ) -> PyResult<LookupResult> {
        // the Python layer's argument handling (a Dataset, a path or an array; a mask array)
        let api = py.import("photostereo")?;
        let ds = api.getattr("_dataset")?.call1((target,))?;
        let ds = ds.cast::<Dataset>()?.get();
        let mask = match mask {
            None => ds.mask_value(py),
            Some(m) => {
                let m = api.getattr("_mask")?.call1((m,))?;
                let m: PyReadonlyArray2<'_, bool> = m.extract()?;
                Some(convert::mask_from(&m))
            }
        };
        let stack = ds.stack(py)?;
        let mask = mask.unwrap_or_else(|| Mask::full(stack.width, stack.height));
        crate::funcs::lookup_stack(py, stack, mask, &[self], normalize, Some(spatial))
    }

    /// Write the table file (the `.lut` format of `photostereo calibrate`), atomically.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let t = &self.cal.table;
        crate::compute(py, || io::write_table(&path, t))
    }

    /// Read a table file written by `save` or `photostereo calibrate`.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Table> {
        let table = crate::compute(py, move || io::read_table(&path))?;
        Ok(Table::new(Calibration {
            table,
            detection: None,
        }))
    }

    fn __repr__(&self) -> String {
        let t = &self.cal.table;
        format!(
            "Table(K={}, {} entries, circle=({:.2}, {:.2}, {:.2}), material={:?})",
            t.k,
            t.entries.len(),
            t.circle.cx,
            t.circle.cy,
            t.circle.radius,
            t.material
        )
    }

    /// Pickling (for Dask): the table bytes and the detection.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let me = slf.get();
        let bytes = PyBytes::new(py, &me.cal.table.to_bytes());
        let det = me.cal.detection.as_ref().map(|d| {
            (
                (d.circle.cx, d.circle.cy, d.circle.radius),
                (d.rms_residual_px, d.uncertainty_px, d.rim_blur_px),
                (d.inliers, d.edge_points, d.fitted_on),
                (d.max_image.width, d.max_image.height),
                d.max_image.data.clone(),
            )
        });
        let ctor = py
            .import("photostereo._native")?
            .getattr("Table")?
            .getattr("_from_state")?;
        let args = (bytes, det).into_pyobject(py)?.into_any();
        Ok((ctor, args))
    }

    /// Rebuild a table pickled by `__reduce__`.
    #[staticmethod]
    fn _from_state(py: Python<'_>, bytes: Vec<u8>, det: Option<DetState>) -> PyResult<Table> {
        let table = crate::compute(py, move || lut::Table::from_bytes(&bytes))?;
        let detection = det.map(
            |((cx, cy, r), (rms, unc, blur), (inliers, edges, on), (w, h), data)| Detection {
                circle: Circle { cx, cy, radius: r },
                rms_residual_px: rms,
                uncertainty_px: unc,
                rim_blur_px: blur,
                inliers,
                edge_points: edges,
                fitted_on: fitted_on(&on),
                max_image: GrayImage {
                    width: w,
                    height: h,
                    data,
                },
            },
        );
        Ok(Table::new(Calibration { table, detection }))
    }
}

/// A pickled detection: circle, (rms, uncertainty, rim blur), (inliers, edge points,
/// fitted on), max image size and pixels.
type DetState = (
    (f64, f64, f64),
    (f64, f64, Option<f64>),
    (usize, usize, String),
    (usize, usize),
    Vec<f32>,
);

/// The library's name of the image a circle was fitted on ([`Detection::fitted_on`]).
fn fitted_on(name: &str) -> &'static str {
    ["maximum", "mean", "edge points", "mask outline", "given"]
        .into_iter()
        .find(|n| *n == name)
        .unwrap_or("given")
}

/// calibrate(images, names, mask, circle, sphere_region, rim, material, smooth, denoise) -> Table
#[pyfunction]
#[pyo3(signature = (images, names, mask=None, circle=None, sphere_region=None, rim=2.0, material=String::new(), smooth=None, denoise=None))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate(
    py: Python<'_>,
    images: PyReadonlyArray3<'_, f32>,
    names: Vec<String>,
    mask: Option<PyReadonlyArray2<'_, bool>>,
    circle: Option<(f64, f64, f64)>,
    sphere_region: Option<(usize, usize, usize, usize)>,
    rim: f64,
    material: String,
    smooth: Option<f64>,
    denoise: Option<String>,
) -> PyResult<Table> {
    let denoise = match denoise.as_deref() {
        None => lut::Denoise::Auto,
        Some(how) => how.parse().map_err(|e: photostereo::Error| {
            pyo3::exceptions::PyValueError::new_err(format!("denoise={how:?}: {e}"))
        })?,
    };
    let stack = convert::stack_from(&images, names)?;
    let mask = mask.map(|m| convert::mask_from(&m));
    let opts = pipeline::Options {
        detect: DetectOptions {
            circle: circle.map(|(cx, cy, radius)| Circle { cx, cy, radius }),
            region: sphere_region,
            ..DetectOptions::default()
        },
        build: lut::BuildOptions {
            rim,
            material,
            smooth,
            denoise,
        },
        ..Default::default()
    };
    let cal = crate::compute(py, move || pipeline::calibrate(&stack, mask, &opts))?;
    Ok(Table::new(cal))
}
