//! The computations: lookup, Lambertian, lights from a sphere, integration,
//! interreflections and the whole `run`.

use std::path::PathBuf;

use numpy::{PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3};
use photostereo::image::{GrayImage, ImageStack, Mask};
use photostereo::progress::NoProgress;
use photostereo::{integrate as integ, interreflect as ir, lambertian as lamb, lightcal};
use photostereo::{lut, normals, pipeline, sphere};
use pyo3::prelude::*;
use pyo3::types::PyBool;

use crate::convert::{self, value_error};
use crate::table::Table;

/// Normals and the maps that come with them.
#[pyclass(module = "photostereo._native", name = "Result", frozen)]
pub struct LookupResult {
    /// (H, W, 3) float32 unit normals, [0, 0, 0] outside the mask.
    #[pyo3(get)]
    normals: Py<PyArray3<f32>>,
    /// (H, W) float32 albedo (Lambertian; lookup with normalize=True), else None.
    #[pyo3(get)]
    albedo: Option<Py<PyArray2<f32>>>,
    /// (H, W) float32 confidence in [0, 1] (lookup), else None.
    #[pyo3(get)]
    confidence: Option<Py<PyArray2<f32>>>,
    /// (H, W) float32 RMS residual per light used.
    #[pyo3(get)]
    residual: Py<PyArray2<f32>>,
    /// Mixture weights [(H, W), (H, W)] for two tables, else None.
    #[pyo3(get)]
    weights: Option<Vec<Py<PyArray2<f32>>>>,
    /// (H, W) float32 angular standard error (degrees) of each normal from its own data
    /// (None with two tables).
    #[pyo3(get)]
    normals_sigma: Option<Py<PyArray2<f32>>>,
    /// (H, W) float32 share in [0, 1] of each pixel's own data in its normal (spatial
    /// stage; 0 = its neighbours decided it), else None.
    #[pyo3(get)]
    own_share: Option<Py<PyArray2<f32>>>,
    /// [(code, message)]: what limits the result (e.g. "spatial_stage_skipped" with two
    /// tables), the codes of `photostereo::WarningCode` in snake case.
    #[pyo3(get)]
    warnings: Vec<(String, String)>,
}

#[pymethods]
impl LookupResult {
    fn __repr__(&self, py: Python<'_>) -> String {
        use numpy::PyUntypedArrayMethods;
        let d = self.normals.bind(py).shape().to_vec();
        format!(
            "Result(normals {}×{}, albedo: {}, confidence: {}, weights: {})",
            d[1],
            d[0],
            self.albedo.is_some(),
            self.confidence.is_some(),
            self.weights.is_some()
        )
    }
}

fn gray(py: Python<'_>, g: GrayImage) -> Py<PyArray2<f32>> {
    convert::gray_to_py(py, g).unbind()
}

fn mask_or_full(mask: Option<PyReadonlyArray2<'_, bool>>, s: &ImageStack) -> Mask {
    mask.map(|m| convert::mask_from(&m))
        .unwrap_or_else(|| Mask::full(s.width, s.height))
}

/// lookup(images, names, tables, mask=None, normalize=False, spatial=None) -> Result
///
/// [`photostereo::normals::solve`], as `photostereo normals`: the lookup, then (one
/// table; `spatial=None` or `True`) the spatial stage: the noise measured on the
/// target, the spatial solve, the confidence times each pixel's own share.
/// `spatial=False` keeps every pixel's own match (`--no-spatial`).
#[pyfunction]
#[pyo3(signature = (images, names, tables, mask=None, normalize=false, spatial=None))]
pub fn lookup(
    py: Python<'_>,
    images: PyReadonlyArray3<'_, f32>,
    names: Vec<String>,
    tables: Vec<PyRef<'_, Table>>,
    mask: Option<PyReadonlyArray2<'_, bool>>,
    normalize: bool,
    spatial: Option<bool>,
) -> PyResult<LookupResult> {
    let stack = convert::stack_from(&images, names)?;
    let mask = mask_or_full(mask, &stack);
    let tables: Vec<&Table> = tables.iter().map(|t| &**t).collect();
    lookup_stack(py, stack, mask, &tables, normalize, spatial)
}

/// [`lookup`] on a library stack and mask: one table through its prepared
/// [`lut::Lookup`] (built at its first use, then reused), two (a mixture) prepared for
/// this call.
pub(crate) fn lookup_stack(
    py: Python<'_>,
    stack: ImageStack,
    mask: Mask,
    tables: &[&Table],
    normalize: bool,
    spatial: Option<bool>,
) -> PyResult<LookupResult> {
    if spatial == Some(true) && tables.len() != 1 {
        return Err(value_error(format!(
            "spatial=True with {} tables: the spatial stage models one table (mixtures are \
             not modelled); give one table or spatial=False",
            tables.len()
        )));
    }
    let opts = normals::Options {
        spatial: spatial.unwrap_or(true).then(Default::default),
    };
    let out = match tables {
        [one] => crate::compute(py, || {
            let prepared = one.prepared(normalize)?;
            let input = normals::Input::Lookup(&prepared);
            normals::solve(&stack, &mask, &input, &opts, &NoProgress)
        })?,
        _ => {
            let tables: Vec<lut::Table> = tables.iter().map(|t| t.cal.table.clone()).collect();
            let asked = crate::table::lookup_options(normalize);
            crate::compute(py, || {
                let input = normals::Input::Tables(&tables, &asked);
                normals::solve(&stack, &mask, &input, &opts, &NoProgress)
            })?
        }
    };
    Ok(result(py, out))
}

/// The Python result of [`normals::solve`].
fn result(py: Python<'_>, out: normals::Output) -> LookupResult {
    LookupResult {
        normals: convert::normals_to_py(py, out.normals).unbind(),
        albedo: out.albedo.map(|a| gray(py, a)),
        confidence: out.confidence.map(|c| gray(py, c)),
        residual: gray(py, out.residual),
        weights: out
            .weights
            .map(|w| w.into_iter().map(|g| gray(py, g)).collect()),
        normals_sigma: out.normals_sigma.map(|g| gray(py, g)),
        own_share: out.own_share.map(|g| gray(py, g)),
        warnings: out.warnings.into_iter().map(warning).collect(),
    }
}

/// A warning as (code, message), the code as `run.json`'s `warning_codes` write it.
fn warning(w: photostereo::Warning) -> (String, String) {
    let code = serde_json::to_value(w.code)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| "other".to_string());
    (code, w.message)
}

/// lambertian(images, lights, mask=None, robust=True, spatial=True, black_level="auto")
/// -> Result
///
/// [`photostereo::normals::solve`] with Lambertian least squares, as `photostereo
/// normals --lambertian` (`spatial=False`: `--no-spatial`; `black_level`: as
/// `--black-level`, [`BlackLevelArg`]).
#[pyfunction]
#[pyo3(signature = (images, lights, mask=None, robust=true, spatial=true, black_level=BlackLevelArg(lamb::BlackLevelChoice::Auto)))]
pub fn lambertian(
    py: Python<'_>,
    images: PyReadonlyArray3<'_, f32>,
    lights: PyReadonlyArray2<'_, f32>,
    mask: Option<PyReadonlyArray2<'_, bool>>,
    robust: bool,
    spatial: bool,
    black_level: BlackLevelArg,
) -> PyResult<LookupResult> {
    let stack = convert::stack_from(&images, Vec::new())?;
    let lights = convert::lights_from(&lights)?;
    let mask = mask_or_full(mask, &stack);
    let mut lo = if robust {
        lamb::Options::default()
    } else {
        lamb::Options::plain()
    };
    let opts = normals::Options {
        spatial: spatial.then(Default::default),
    };
    let out = crate::compute(py, move || {
        // the images as given are the full scale's unit (levels are fractions of it)
        let data = (&stack, &mask, &lights);
        let (out, decision) = lamb::solve_with_black_level(black_level.0, data, &lo, 1.0)?;
        lo.black_level = decision.level;
        let input = normals::Input::Lambertian(&lights, &lo);
        normals::spatial_stage(&stack, &mask, &input, &opts, normals::from_lambertian(out))
    })?;
    Ok(result(py, out))
}

/// The `black_level=` argument: "auto" (measured and taken off when clearly above 0),
/// None or "none" (nothing taken off), or a level in [0, 0.25) as a fraction of full
/// scale; anything else is a ValueError that says what is taken.
pub struct BlackLevelArg(lamb::BlackLevelChoice);

impl<'a, 'py> FromPyObject<'a, 'py> for BlackLevelArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        use lamb::BlackLevelChoice as C;
        let choice = if obj.is_none() {
            Some(C::None)
        } else if let Ok(text) = obj.extract::<String>() {
            match text.as_str() {
                "auto" => Some(C::Auto),
                "none" => Some(C::None),
                _ => None,
            }
        } else {
            // a bool is an int in Python: not a level
            let number = obj
                .extract::<f64>()
                .ok()
                .filter(|_| !obj.is_instance_of::<PyBool>());
            number
                .map(|v| C::Given(v as f32))
                .filter(|c| c.check().is_ok())
        };
        choice.map(BlackLevelArg).ok_or_else(|| {
            let repr = obj
                .repr()
                .map_or_else(|_| "?".to_string(), |r| r.to_string());
            value_error(format!(
                "black_level={repr}: give \"auto\", None, or a level in [0, {}) as a fraction \
                 of full scale (e.g. 0.03)",
                lamb::MAX_BLACK_LEVEL
            ))
        })
    }
}

/// lights_from_sphere(images, mask=None, kind="chrome", circle=None) -> (K, 3) lights
#[pyfunction]
#[pyo3(signature = (images, mask=None, kind="chrome", circle=None))]
pub fn lights_from_sphere<'py>(
    py: Python<'py>,
    images: PyReadonlyArray3<'_, f32>,
    mask: Option<PyReadonlyArray2<'_, bool>>,
    kind: &str,
    circle: Option<(f64, f64, f64)>,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let chrome = match kind {
        "chrome" => true,
        "matte" => false,
        other => {
            return Err(value_error(format!(
                "kind={other:?}: use \"chrome\" (mirror sphere, lights from its highlights) or \"matte\""
            )))
        }
    };
    let stack = convert::stack_from(&images, Vec::new())?;
    let mask = mask.map(|m| convert::mask_from(&m));
    let lights = crate::compute(py, move || {
        let det = sphere::detect(
            &stack,
            &sphere::DetectOptions {
                circle: circle.map(|(cx, cy, radius)| sphere::Circle { cx, cy, radius }),
                // a mirror sphere's rim barely shows: its silhouette mask is the better outline
                mask_outline: chrome && mask.is_some(),
                mask,
                ..Default::default()
            },
        )?;
        if chrome {
            Ok(lightcal::from_chrome_sphere(&stack, &det.circle, &Default::default())?.0)
        } else {
            lightcal::from_matte_sphere(&stack, &det.circle, &Default::default())
        }
    })?;
    Ok(convert::lights_to_py(py, &lights))
}

/// The integrator of a method name; "auto" (or None) chooses from the mask.
fn method(name: Option<&str>, mask: &Mask) -> PyResult<integ::Method> {
    match name {
        None | Some("auto") => Ok(integ::choose_method(mask)),
        Some(n) => integ::Method::from_name(n).map_err(crate::to_py),
    }
}

/// integrate(normals, mask=None, method="auto", weights=None, camera=None, focal=None,
/// min_nz=0.05, bini_k=2.0, parts="contour") -> (H, W) depth
///
/// `camera` is `(text, name)`: a 3×3 intrinsics matrix as text (the `--camera K.txt`
/// format; `name` names it in errors); `focal` a focal length in pixels with the
/// principal point at the image centre (`--focal`). With either, the integration is
/// perspective and "auto" means lsq.
#[pyfunction]
#[pyo3(signature = (normals, mask=None, method=None, weights=None, camera=None, focal=None, min_nz=0.05, bini_k=2.0, parts=None))]
#[allow(clippy::too_many_arguments)]
pub fn integrate<'py>(
    py: Python<'py>,
    normals: PyReadonlyArray3<'_, f32>,
    mask: Option<PyReadonlyArray2<'_, bool>>,
    method: Option<&str>,
    weights: Option<PyReadonlyArray2<'_, f32>>,
    camera: Option<(String, String)>,
    focal: Option<f64>,
    min_nz: f32,
    bini_k: f32,
    parts: Option<&str>,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let n = convert::normals_from(&normals)?;
    let parts = match parts {
        None => integ::Parts::default(),
        Some(name) => integ::Parts::from_name(name)
            .map_err(|e| value_error(format!("parts={name:?}: {e}")))?,
    };
    let mask = mask
        .map(|m| convert::mask_from(&m))
        .unwrap_or_else(|| Mask::full(n.width, n.height));
    if !(min_nz.is_finite() && (0.0..1.0).contains(&min_nz)) {
        return Err(value_error(format!(
            "min_nz={min_nz}: give a number in [0, 1)"
        )));
    }
    let camera = match (camera, focal) {
        (Some(_), Some(_)) => {
            return Err(value_error(
                "give camera= (the intrinsics) or focal= (a focal length), not both".into(),
            ))
        }
        (Some((text, name)), None) => {
            Some(integ::Camera::from_text(&text, &name).map_err(crate::to_py)?)
        }
        (None, Some(f)) => Some(integ::Camera::centred(f, n.width, n.height).map_err(|_| {
            value_error(format!(
                "focal={f}: give the focal length in pixels (a positive number)"
            ))
        })?),
        (None, None) => None,
    };
    let mut method = match (method, camera) {
        // perspective integration is lsq or bini; lsq is the default
        (None | Some("auto"), Some(_)) => integ::Method::Lsq,
        _ => self::method(method, &mask)?,
    };
    if let integ::Method::Bilateral { k, .. } = &mut method {
        if !(bini_k.is_finite() && bini_k > 0.0) {
            return Err(value_error(format!(
                "bini_k={bini_k}: give a positive number"
            )));
        }
        *k = bini_k;
    }
    let opts = integ::Options {
        method,
        weights: weights.map(|w| convert::gray_from(&w)),
        min_nz,
        camera,
        parts,
    };
    let out = crate::compute(py, move || integ::solve(&n, &mask, &opts))?;
    Ok(convert::gray_to_py(py, out.depth))
}

type IterRow = (usize, f32, f32, f32);
type InterreflectOut<'py> = (
    Bound<'py, PyArray3<f32>>,
    Bound<'py, PyArray2<f32>>,
    Bound<'py, PyArray2<f32>>,
    String,
    String,
    Vec<IterRow>,
    usize,
);

/// interreflect(images, lights, mask, max_iter, tol, method, block, black_level=0.0,
/// full_scale=1.0) -> (normals, albedo, depth, summary, csv, [(t, depth_range,
/// mean_albedo, change)], best); black_level: the camera's, a fraction of full_scale (the
/// images' full scale in their units), taken off before the iteration
#[pyfunction]
#[pyo3(signature = (images, lights, mask=None, max_iter=10, tol=0.01, method=None, block=None, black_level=0.0, full_scale=1.0))]
#[allow(clippy::too_many_arguments)]
pub fn interreflect<'py>(
    py: Python<'py>,
    images: PyReadonlyArray3<'_, f32>,
    lights: PyReadonlyArray2<'_, f32>,
    mask: Option<PyReadonlyArray2<'_, bool>>,
    max_iter: usize,
    tol: f32,
    method: Option<&str>,
    block: Option<usize>,
    black_level: f32,
    full_scale: f32,
) -> PyResult<InterreflectOut<'py>> {
    // not measured here (bounced light reads as an offset): a level, or 0 for none
    if lamb::BlackLevelChoice::Given(black_level).check().is_err() {
        return Err(value_error(format!(
            "black_level={black_level}: give the camera's black level in [0, {}) as a \
             fraction of full scale (e.g. 0.03), or 0 for none",
            lamb::MAX_BLACK_LEVEL
        )));
    }
    let stack = convert::stack_from(&images, Vec::new())?;
    let lights = convert::lights_from(&lights)?;
    let mask = mask_or_full(mask, &stack);
    let mut opts = ir::NikOptions {
        max_iter,
        tol,
        ..Default::default()
    };
    opts.integrate.method = self::method(method, &mask)?;
    opts.radiosity.block = block.unwrap_or(0);
    opts.lambertian.black_level = black_level * full_scale;
    let out = crate::compute(py, move || {
        ir::solve(&stack, &mask, &lights, &opts, &NoProgress)
    })?;
    let rows: Vec<IterRow> = out
        .iterations
        .iter()
        .enumerate()
        .map(|(t, it)| (t, it.depth_range, it.mean_albedo, it.relative_change))
        .collect();
    let (summary, csv, best) = (out.summary(), out.convergence_csv(), out.best);
    let shape = out.iterations.into_iter().nth(best).map(|it| it.shape);
    let shape = shape.ok_or_else(|| value_error("no iterate".into()))?;
    Ok((
        convert::normals_to_py(py, shape.normals),
        convert::gray_to_py(py, shape.albedo),
        convert::gray_to_py(py, shape.depth),
        summary,
        csv,
        rows,
        best,
    ))
}

/// run(target, out, sphere=None, table=None, lambertian=False, lights=None, chrome=None,
/// mask=None, image_scale=None, interreflections=False, method=None, spatial=True,
/// block=None, response=None, memory=None, black_level="auto") -> dict: what run.json
/// holds (response: "linear", "srgb", "gamma=G"; None = sRGB for JPEG files, linear
/// otherwise; memory: the run's budget, e.g. "2G" or a number of bytes; None = half of the
/// machine's memory; black_level: as `lambertian`'s, `run --black-level`)
#[pyfunction]
#[pyo3(signature = (target, out, sphere=None, table=None, lambertian=false, lights=None, chrome=None, mask=None, image_scale=None, interreflections=false, method=None, spatial=true, block=None, response=None, memory=None, black_level=BlackLevelArg(lamb::BlackLevelChoice::Auto)))]
#[allow(clippy::too_many_arguments)]
pub fn run<'py>(
    py: Python<'py>,
    target: PathBuf,
    out: PathBuf,
    sphere: Option<PathBuf>,
    table: Option<PyRef<'_, Table>>,
    lambertian: bool,
    lights: Option<PathBuf>,
    chrome: Option<PathBuf>,
    mask: Option<PathBuf>,
    image_scale: Option<f32>,
    interreflections: bool,
    method: Option<&str>,
    spatial: bool,
    block: Option<usize>,
    response: Option<&str>,
    memory: Option<&str>,
    black_level: BlackLevelArg,
) -> PyResult<Bound<'py, PyAny>> {
    let inputs = pipeline::Inputs {
        target,
        sphere,
        calibration: table.map(|t| t.cal.clone()),
        lambertian,
        lights,
        chrome,
        mask,
        image_scale,
        response: match response {
            Some(r) => r.parse().map_err(crate::to_py)?,
            None => Default::default(),
        },
    };
    let opts = pipeline::Options {
        method: match method {
            None | Some("auto") => None,
            Some(n) => Some(integ::Method::from_name(n).map_err(crate::to_py)?),
        },
        interreflections,
        black_level: black_level.0,
        ..Default::default()
    };
    let mut opts = pipeline::Options {
        spatial: opts.spatial.filter(|_| spatial),
        ..opts
    };
    opts.nik.radiosity.block = block.unwrap_or(0);
    opts.memory = memory
        .map(photostereo::plan::parse_size)
        .transpose()
        .map_err(crate::to_py)?;
    let done = crate::compute(py, move || pipeline::run(&inputs, &out, &opts, &NoProgress))?;
    // the dict is made from the typed summary, as run.json is (no text parsed back)
    convert::json_to_py(py, &done.summary.to_json())
}
