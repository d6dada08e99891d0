//! The whole job: normals → depth → mesh → figures → files, as `photostereo run`,
//! `photostereo demo` and the Python package run it.
//!
//! # Stages
//!
//! 1. **Normals**, by one of ([`Normals`]; [`crate::normals::solve`] does this stage,
//!    spatial stage included, for the whole-stack path):
//!    * a lookup table (calibration-based photometric stereo, see [`crate::lut`]): the
//!      calibration sphere is found ([`crate::sphere::detect`]), its table built
//!      ([`crate::lut::Table::build`]) and the target looked up ([`crate::lut::solve`]);
//!      or a table built beforehand ([`Calibration`]), e.g. once for a batch of targets;
//!    * Lambertian least squares with known lights ([`crate::lambertian`]), and with
//!      [`Options::interreflections`] the Nayar–Ikeuchi–Kanade iteration on top
//!      ([`crate::interreflect`]; Nayar, Ikeuchi & Kanade, "Shape from interreflections",
//!      IJCV 6(3), 1991), which also yields the depth.
//! 2. **Integration** of the normals into depth ([`crate::integrate`]); the integrator is
//!    [`Options::method`], or chosen from the mask ([`crate::integrate::choose_method`]):
//!    DCT Poisson on a full rectangle; otherwise masked least squares weighted by each
//!    gradient's trust ([`crate::integrate::trust_weights`]), followed by bilateral
//!    integration (BiNI) when that depth shows interior depth jumps
//!    ([`crate::integrate::choose_method_for`]); the integrator row of the figures says
//!    which and why. The mesh leaves BiNI's discontinuities open.
//! 3. **Mesh** from the depth ([`crate::mesh::from_depth`]).
//! 4. **Accuracy** against ground truth when the [`Job`] has some: angular error of the
//!    normals, depth RMSE after the best offset ([`crate::eval`]).
//!
//! [`solve`] runs them in memory and returns an [`Output`] with the products, the
//! figures (the rows of the report and of `run.json`), the warnings and the seconds of
//! each stage; [`RunSummary`] is what `run.json` holds, typed.
//! [`write_outputs`] writes the files of a run (through [`crate::io`] only);
//! [`run`] does the whole job from paths ([`Inputs`]) as the `run` subcommand does.
//!
//! Each stage is a small function of this module; a new stage takes its settings from
//! one new field of [`Options`] (with its default in `Options::default`) and adds its
//! rows to [`Output::figures`].

mod banded;
mod checks;
mod figures;
mod from_paths;
mod load;
mod outputs;
#[cfg(feature = "report")]
mod report_page;
mod spatial_stage;
mod stages;
mod summary;
mod timer;

use crate::error::{Error, Result};
use crate::image::{DepthMap, GrayImage, ImageStack, Lights, Mask, NormalMap};
use crate::progress::Progress;
use crate::warning::Warning;
use crate::{curvature, eval, integrate, interreflect, lambertian, lut, mesh, spatial, sphere};

pub use checks::NEIGHBOURS_WARN;
pub use figures::Titles;
pub use figures::{depth_range, masked_mean, warnings, LOW_CONFIDENCE};
pub use from_paths::run;
pub use load::{load, radiance_scale, scale_is_known, Inputs, Loaded, Run};
pub use outputs::{write_outputs, write_outputs_with, Written};
#[cfg(feature = "report")]
pub use report_page::build_report;
pub use summary::{
    AngularError, DepthError, Figure, InterreflectionFigures, Plot, RunSummary, StageTime,
};

/// A calibration made beforehand: the lookup table and, when known, the sphere
/// detection it was built from (for the report's circle figure and overlay).
#[derive(Clone, Debug)]
pub struct Calibration {
    /// The lookup table.
    pub table: lut::Table,
    /// The sphere detection the table came from (`None` for a table read from a file).
    pub detection: Option<sphere::Detection>,
}

/// Where the normals come from.
#[derive(Clone, Debug)]
pub enum Normals {
    /// Calibration-based: a lookup table from a sphere of the same material imaged
    /// under the same lights (`sphere_mask` restricts the sphere search).
    Lookup {
        sphere: ImageStack,
        sphere_mask: Option<Mask>,
    },
    /// Calibration-based with a table built beforehand.
    Calibrated(Box<Calibration>),
    /// Lambertian least squares with known lights (unit directions, surface → light).
    Lambertian { lights: Lights },
}

/// Ground truth, when known (synthetic data).
#[derive(Clone, Debug, Default)]
pub struct Truth {
    /// True normals (H, W).
    pub normals: Option<NormalMap>,
    /// True depth (H, W), pixels, larger = closer.
    pub depth: Option<DepthMap>,
}

/// One job, in memory.
#[derive(Clone, Debug)]
pub struct Job {
    /// The target's K images (for interreflection removal: in radiance units).
    pub target: ImageStack,
    /// The pixels to reconstruct (the full image when the dataset has no mask).
    pub mask: Mask,
    /// How to get the normals.
    pub normals: Normals,
    /// Ground truth for the accuracy stage.
    pub truth: Truth,
}

/// Settings of the pipeline: one field per option, each with its default in
/// [`Options::default`].
#[derive(Clone, Debug)]
pub struct Options {
    /// Integrator; `None` = chosen: DCT Poisson on a full rectangle, masked least squares
    /// otherwise, then BiNI where least squares leaves interior depth jumps
    /// ([`integrate::choose_method_for`]).
    pub method: Option<integrate::Method>,
    /// Remove interreflections (Nayar–Ikeuchi–Kanade iteration; Lambertian jobs only).
    pub interreflections: bool,
    /// Settings of the sphere detection ([`Normals::Lookup`]); when its `mask` is `None`
    /// the job's `sphere_mask` (the sphere folder's `mask.png`) is used, unless a search
    /// window (`region`) is given: the folder's mask is then the target's
    /// ([`sphere::DetectOptions::search_mask`]).
    pub detect: sphere::DetectOptions,
    /// Settings of the lookup-table build ([`Normals::Lookup`]).
    pub build: lut::BuildOptions,
    /// Settings of the lookup ([`Normals::Lookup`] and [`Normals::Calibrated`]).
    pub lookup: lut::Options,
    /// Settings of Lambertian photometric stereo (without interreflection removal).
    pub lambertian: lambertian::Options,
    /// The camera's black level in Lambertian photometric stereo (not used by a lookup,
    /// whose table carries the sphere's own): `Auto` (the default) measures it
    /// ([`lambertian::estimate_black_level`], band by band in a run by bands) and takes it
    /// off when [`lambertian::BlackLevel::is_taken`] (with [`Options::interreflections`]
    /// it measures nothing and takes nothing off: bounced light reads as an offset); `None` takes
    /// nothing off; `Given(v)` takes off v, a fraction of the images' full scale (times
    /// the image scale of a run from paths). The level taken is set as
    /// `lambertian.black_level` (`nik.lambertian.black_level` with interreflections; Auto
    /// and None add to the one set there) and reported in the figures' "black level" row.
    pub black_level: lambertian::BlackLevelChoice,
    /// Settings of the interreflection iteration; its integrator is [`Options::method`]
    /// (or the one chosen from the mask).
    pub nik: interreflect::NikOptions,
    /// The spatial stage after the lookup or the Lambertian solve ([`crate::spatial`]):
    /// pixels whose data say little about their normal take it from their neighbours.
    /// `None` = off (each pixel keeps its own normal; the standard errors are still
    /// computed). Not used with interreflection removal. Default on, with
    /// `spatial::Options::default()`.
    pub spatial: Option<spatial::Options>,
    /// Memory budget of a run from paths ([`run`]), bytes: the target's images are read
    /// by row bands that keep the run within it ([`crate::plan`]); a capture that
    /// cannot fit is refused before any pixel is read. `None` = half of the machine's
    /// memory ([`crate::plan::default_budget`]).
    pub memory: Option<u64>,
    /// At most this many image rows per band in a run from paths (`None` = as many as
    /// the memory budget allows). Smaller bands give finer progress; results do not
    /// depend on it.
    pub max_band_rows: Option<usize>,
    /// Curvature maps from the normals ([`crate::curvature`]) with these settings;
    /// `None` = not computed. Default on, smoothing σ = 1 px.
    pub curvature: Option<curvature::Options>,
    /// At most this many triangles in the mesh (`mesh.ply`): a bigger one is made on
    /// every s-th row and column ([`mesh::MeshOptions::max_faces`]). `None` = full
    /// resolution. Default [`DEFAULT_MESH_MAX_FACES`].
    pub mesh_max_faces: Option<usize>,
    /// Extra files for other tools, written by [`write_outputs`] (default: none).
    pub exports: Exports,
}

/// Default cap of the mesh's triangles: 8 million (a binary PLY of about 210 MB). Every
/// capture up to about 2000 × 2000 mask pixels keeps its full-resolution mesh; a bigger
/// one (a 4096² capture has ~20 M triangles: a 500 MB file, 0.5 GB of memory while
/// written, and slow to open in mesh viewers) gets every 2nd or 3rd pixel, while the
/// normals and depth keep every pixel.
pub const DEFAULT_MESH_MAX_FACES: usize = 8_000_000;

/// Extra files of a run for other tools ([`crate::io::export`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Exports {
    /// Also write `normal_map.png`, a 16-bit normal map in this convention (green up or
    /// down), flat (0, 0, 1) outside the mask.
    pub normal_map: Option<crate::io::NormalMapStyle>,
    /// Also write `normals.tif` (float32 RGB) and `depth.tif` (float32, NaN outside).
    pub float_tiff: bool,
}

// Written out (not derived) so that every new option states its default here.
#[allow(clippy::derivable_impls)]
impl Default for Options {
    fn default() -> Self {
        Options {
            method: None,
            interreflections: false,
            detect: sphere::DetectOptions::default(),
            build: lut::BuildOptions::default(),
            lookup: lut::Options::default(),
            lambertian: lambertian::Options::default(),
            black_level: lambertian::BlackLevelChoice::Auto,
            nik: interreflect::NikOptions::default(),
            spatial: Some(spatial::Options::default()),
            memory: None,
            max_band_rows: None,
            curvature: Some(curvature::Options::default()),
            mesh_max_faces: Some(DEFAULT_MESH_MAX_FACES),
            exports: Exports::default(),
        }
    }
}

/// Interreflection removal results.
#[derive(Clone, Debug)]
pub struct Interreflections {
    /// One-line summary of the iteration (converged or not, iterate kept).
    pub summary: String,
    /// Convergence table (CSV).
    pub csv: String,
    /// Plots (their file names and PNG bytes).
    pub plots: Vec<Plot>,
    /// Compensation steps done.
    pub iterations: usize,
    /// Depth of the concavity (depth range over the mask, px) of the raw reconstruction.
    pub depth_before: f32,
    /// The same for the kept iterate.
    pub depth_after: f32,
    /// Mean albedo over the mask of the raw reconstruction.
    pub albedo_before: f32,
    /// The same for the kept iterate.
    pub albedo_after: f32,
}

/// Accuracy against ground truth.
#[derive(Clone, Debug, Default)]
pub struct Accuracy {
    /// Angular error statistics of the normals and the error map (degrees).
    pub angular: Option<(eval::NormalStats, GrayImage)>,
    /// RMSE after the best offset, its depth range, and the signed error map (px).
    pub depth: Option<(eval::DepthStats, GrayImage)>,
}

/// Everything a job produced.
#[derive(Clone, Debug)]
pub struct Output {
    /// Unit normals (H, W), [0, 0, 0] outside the mask.
    pub normals: NormalMap,
    /// Albedo (Lambertian: absolute; lookup: relative to the sphere, with `normalize`).
    pub albedo: Option<GrayImage>,
    /// Confidence in [0, 1] (lookup only); after the spatial stage multiplied by
    /// [`Output::own_share`].
    pub confidence: Option<GrayImage>,
    /// Angular standard error (degrees) of each normal from its own data, from the noise
    /// measured on the target (lookup and Lambertian without interreflection removal).
    pub normals_sigma: Option<GrayImage>,
    /// Spatial stage: share in [0, 1] of each pixel's own data in its normal (1 = its own
    /// data decided it, 0 = its neighbours did).
    pub own_share: Option<GrayImage>,
    /// Figures of the spatial stage (when it ran).
    pub spatial: Option<spatial::Stats>,
    /// Depth (H, W), pixels, larger = closer, NaN outside the mask.
    pub depth: DepthMap,
    /// Triangle mesh of the depth.
    pub mesh: mesh::Mesh,
    /// The integrator used.
    pub method: integrate::Method,
    /// The calibration sphere's detection (lookup with a known detection).
    pub circle: Option<sphere::Detection>,
    /// Interreflection removal results (with [`Options::interreflections`]).
    pub interreflections: Option<Interreflections>,
    /// Accuracy against the job's ground truth.
    pub accuracy: Accuracy,
    /// (stage, seconds), in order.
    pub stages: Vec<(String, f64)>,
    /// The rows of the figures for the report and `run.json` ([`RunSummary`]), in order.
    pub figures: Vec<Figure>,
    /// How far not to trust the result, and why: shown at the top of the report, in
    /// `run.json` and (through [`Progress::note`]) on the terminal ([`warnings`]).
    pub warnings: Vec<Warning>,
    /// The chrome sphere the lights were calibrated from (its circle for the report and
    /// `chrome_overlay.png`), when [`run`] did that.
    pub chrome: Option<sphere::Detection>,
    /// Mean and Gaussian curvature of the normals (with [`Options::curvature`]).
    pub curvature: Option<curvature::Curvature>,
}

/// Run the job in memory; `progress` gets the stage lines and the progress of long stages.
///
/// Errors: those of the stages, wrapped with the stage's name ([`Error::Context`]);
/// [`Error::InvalidInput`] for interreflection removal on a lookup job.
pub fn solve(job: &Job, opts: &Options, progress: &dyn Progress) -> Result<Output> {
    solve_scaled(job, opts, 1.0, progress)
}

/// [`solve`] on images multiplied by an image scale: `full_scale` is the images' full
/// scale in the job's units (what a black level's "fraction of full scale" is of).
fn solve_scaled(
    job: &Job,
    opts: &Options,
    full_scale: f32,
    progress: &dyn Progress,
) -> Result<Output> {
    if opts.interreflections && !matches!(job.normals, Normals::Lambertian { .. }) {
        return Err(Error::invalid(
            "interreflection removal",
            "it needs Lambertian photometric stereo: use lambertian with known lights",
        ));
    }
    let has_truth = job.truth.normals.is_some() || job.truth.depth.is_some();
    let total = stages::planned(&job.normals, opts.interreflections)
        + usize::from(has_truth)
        + usize::from(opts.curvature.is_some());
    let mut st = timer::Stages::new(total, progress);
    let method = opts
        .method
        .unwrap_or_else(|| integrate::choose_method(&job.mask));
    let normals = stages::normals(&mut st, job, opts, method, full_scale)?;
    finish(st, job, opts, method, normals, None)
}

/// The stages after the normals: integration (unless NIK made the depth), mesh,
/// accuracy, and the figures and warnings of the output. The accuracy is against the
/// job's ground truth, or with `truth_dir` against that folder's, read only for that
/// stage (a run by bands: 16 B per pixel kept out of the integration's peak).
fn finish(
    mut st: timer::Stages,
    job: &Job,
    opts: &Options,
    method: integrate::Method,
    (est, circle, ir): stages::NormalsResult,
    truth_dir: Option<&std::path::Path>,
) -> Result<Output> {
    let progress = st.progress();
    let has_truth = job.truth.normals.is_some()
        || job.truth.depth.is_some()
        || truth_dir.is_some_and(crate::io::has_ground_truth);
    let (depth, cuts, method, why) = depth_stage(&mut st, job, opts, method, &est)?;
    let mesh = st.run("mesh", |_| {
        let mo = mesh::MeshOptions {
            cuts: cuts.as_ref(),
            max_faces: opts.mesh_max_faces,
            ..Default::default()
        };
        let albedo = est.albedo.as_ref();
        mesh::from_depth_with(&depth, &job.mask, Some(&est.normals), albedo, &mo)
    })?;
    let curv = match &opts.curvature {
        Some(co) => Some(st.run("curvature", |_| {
            curvature::solve(&est.normals, &job.mask, co)
        })?),
        None => None,
    };
    let accuracy = if has_truth {
        st.run("accuracy", |_| accuracy_of(job, &est, &depth, truth_dir))?
    } else {
        Accuracy::default()
    };
    let done = Finished {
        est: &est,
        depth: &depth,
        mesh: &mesh,
        method,
        accuracy: &accuracy,
        circle: circle.as_ref(),
        ir: &ir,
        why: why.as_deref(),
        curvature: curv.as_ref(),
    };
    let (figures, warnings) = report_rows(job, opts, &done);
    for w in &warnings {
        progress.note(&format!("warning: {w}"));
    }
    let sp = est.spatial;
    Ok(Output {
        normals: est.normals,
        albedo: est.albedo,
        confidence: est.confidence,
        normals_sigma: sp.as_ref().map(|s| s.sigma.clone()),
        own_share: sp.as_ref().and_then(|s| s.own_share.clone()),
        spatial: sp.and_then(|s| s.stats),
        depth,
        mesh,
        method,
        circle,
        interreflections: ir,
        accuracy,
        stages: st.list,
        figures,
        warnings,
        chrome: None,
        curvature: curv,
    })
}

/// The depth of the estimate: its own (interreflection removal made one), or the
/// integration stage's with the integrator `method` (or the automatic choice when the
/// options name none); also the cuts, the integrator used and why it changed.
fn depth_stage(
    st: &mut timer::Stages,
    job: &Job,
    opts: &Options,
    method: integrate::Method,
    est: &Estimate,
) -> Result<(
    DepthMap,
    Option<integrate::Discontinuities>,
    integrate::Method,
    Option<String>,
)> {
    if let Some(d) = est.depth.clone() {
        return Ok((d, None, method, None));
    }
    let auto = opts.method.is_none();
    let (out, why) = st.run("integration", |p| {
        stages::integrate_auto(est, &job.mask, method, auto, p)
    })?;
    Ok((out.depth, out.discontinuities, out.method, why))
}

/// Accuracy against the job's ground truth, or with `truth_dir` against that folder's
/// (read here, only for this stage).
fn accuracy_of(
    job: &Job,
    est: &Estimate,
    depth: &DepthMap,
    truth_dir: Option<&std::path::Path>,
) -> Result<Accuracy> {
    match truth_dir {
        Some(dir) => {
            let (normals, depth_gt) = crate::io::read_ground_truth(dir)?;
            let truth = Truth {
                normals,
                depth: depth_gt,
            };
            stages::accuracy(&truth, &job.mask, &est.normals, depth)
        }
        None => stages::accuracy(&job.truth, &job.mask, &est.normals, depth),
    }
}

/// What [`finish`] computed, for the report's rows.
struct Finished<'a> {
    est: &'a Estimate,
    depth: &'a DepthMap,
    mesh: &'a mesh::Mesh,
    method: integrate::Method,
    accuracy: &'a Accuracy,
    circle: Option<&'a sphere::Detection>,
    ir: &'a Option<Interreflections>,
    /// Why the automatic choice changed the integrator, when it did.
    why: Option<&'a str>,
    curvature: Option<&'a curvature::Curvature>,
}

/// The report's figure rows and the run's warnings.
fn report_rows(job: &Job, opts: &Options, done: &Finished<'_>) -> (Vec<Figure>, Vec<Warning>) {
    let est = done.est;
    let mut figures = Vec::new();
    if let Some(det) = done.circle {
        figures.push(Figure::new(
            "sphere circle (cx, cy, r) px",
            figures::circle(det),
        ));
    }
    figures.extend(figures::summary(
        job,
        est,
        done.depth,
        done.mesh,
        done.method,
        done.accuracy,
        done.ir,
    ));
    figures.extend(est.rows.iter().cloned());
    if let Some(info) = &est.spatial {
        figures.extend(spatial_stage::rows(info, &job.mask));
    }
    if let Some(why) = done.why {
        for row in figures.iter_mut().filter(|r| r.name == "integrator") {
            row.value = format!("{} ({why})", done.method.name());
        }
    }
    figures.extend(figures::picture_rows(job, est.albedo.as_ref(), done.depth));
    if let Some(c) = done.curvature {
        figures.push(figures::curvature_row(c));
    }
    let own_share = est.spatial.as_ref().and_then(|s| s.own_share.as_ref());
    let mut warnings = figures::warnings(job, est.confidence.as_ref(), own_share, opts);
    let stats = est.spatial.as_ref().and_then(|s| s.stats.as_ref());
    let (more, rows) = checks::warnings(job, done.circle, stats, opts);
    warnings.extend(more);
    figures.extend(rows);
    (figures, warnings)
}

/// The calibration of [`Normals::Lookup`]: detect the sphere (inside `sphere_mask` when
/// given) and build its table with `opts.detect` and `opts.build`.
pub fn calibrate(
    sphere_stack: &ImageStack,
    sphere_mask: Option<Mask>,
    opts: &Options,
) -> Result<Calibration> {
    let det = stages::detect(sphere_stack, sphere_mask, opts)?;
    let table = lut::Table::build(sphere_stack, &det.circle, &opts.build)?;
    Ok(Calibration {
        table,
        detection: Some(det),
    })
}

/// The normals (and albedo, confidence, and with NIK the depth) a normals stage gives.
struct Estimate {
    normals: NormalMap,
    albedo: Option<GrayImage>,
    confidence: Option<GrayImage>,
    depth: Option<DepthMap>,
    /// The spatial stage's products (when it ran).
    spatial: Option<spatial_stage::SpatialInfo>,
    /// Rows the normals stage adds to the figures (the black level a Lambertian solve
    /// took off).
    rows: Vec<Figure>,
}
