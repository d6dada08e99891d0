//! The stages of [`super::solve`], each a small function (the timer that runs them is
//! in `timer.rs`).

use super::timer::Stages;
use super::{
    spatial_stage, Accuracy, Estimate, Figure, Interreflections, Job, Normals, Options, Plot, Truth,
};
use crate::error::Result;
use crate::image::{DepthMap, GrayImage, ImageStack, Lights, Mask, NormalMap};
use crate::progress::Progress;
use crate::{eval, integrate, interreflect, lambertian, lut, normals, sphere};

/// Stages before the accuracy one: normals (1 to 4, the spatial stage included), integration (unless NIK made the
/// depth), mesh.
pub(super) fn planned(normals: &Normals, interreflections: bool) -> usize {
    match normals {
        Normals::Lookup { .. } => 6,
        Normals::Calibrated(_) => 4,
        Normals::Lambertian { .. } if interreflections => 2,
        Normals::Lambertian { .. } => 4,
    }
}

pub(super) type NormalsResult = (
    Estimate,
    Option<sphere::Detection>,
    Option<Interreflections>,
);

/// Normals (and albedo, confidence, and with NIK the depth) by the job's method.
pub(super) fn normals(
    st: &mut Stages,
    job: &Job,
    opts: &Options,
    method: integrate::Method,
    full_scale: f32,
) -> Result<NormalsResult> {
    Ok(match &job.normals {
        Normals::Lookup {
            sphere,
            sphere_mask,
        } => {
            let det = st.run("sphere detection", |p| {
                let det = detect(sphere, sphere_mask.clone(), opts)?;
                if let Some(w) = det.warning() {
                    p.note(&w);
                }
                Ok(det)
            })?;
            let table = st.run("lookup table", |_| {
                lut::Table::build(sphere, &det.circle, &opts.build)
            })?;
            let est = lookup(st, job, &table, opts)?;
            (est, Some(det), None)
        }
        Normals::Calibrated(cal) => {
            let est = lookup(st, job, &cal.table, opts)?;
            (est, cal.detection.clone(), None)
        }
        Normals::Lambertian { lights } if !opts.interreflections => {
            let est = lambertian(st, job, lights, opts, full_scale)?;
            (est, None, None)
        }
        Normals::Lambertian { lights } => {
            let truth = job.truth.depth.as_ref();
            let (ir, est) = st.run("interreflection removal", |p| {
                nik(job, lights, opts, (method, full_scale), truth, p)
            })?;
            (est, None, Some(ir))
        }
    })
}

/// The sphere detection of a lookup job: inside `opts.detect.mask` when given, else
/// inside `sphere_mask` (the sphere folder's `mask.png`) when there is one and no search
/// window is given ([`sphere::DetectOptions::search_mask`]).
pub(super) fn detect(
    stack: &ImageStack,
    sphere_mask: Option<Mask>,
    opts: &Options,
) -> Result<sphere::Detection> {
    let d = sphere::DetectOptions {
        mask: opts.detect.search_mask(sphere_mask),
        ..opts.detect.clone()
    };
    sphere::detect(stack, &d)
}

/// Says on `p` when the lookup fits diffuse + specular for albedo changes on a specular
/// table ([`lut::Options::split_if_specular`]) rather than normalised matching.
pub(super) fn note_split(table: &lut::Table, opts: &Options, p: &dyn Progress) {
    let used = lut::options_for(std::slice::from_ref(table), &opts.lookup);
    if used.split_specular && !opts.lookup.split_specular {
        p.note(&format!(
            "albedo changes on a specular table ({:.1}% of the sphere's light is not \
             Lambertian): the diffuse + specular fit is used, not brightness-normalised matching",
            100.0 * lut::specular_share(table)
        ));
    }
}

/// The lookup in `table` and the spatial stage, as two timed stages.
fn lookup(st: &mut Stages, job: &Job, table: &lut::Table, opts: &Options) -> Result<Estimate> {
    let tables = std::slice::from_ref(table);
    let input = normals::Input::Tables(tables, &opts.lookup);
    normals_of(st, job, opts, &input, "lookup")
}

/// [`normals::pixelwise`] as the stage `name`, then [`normals::spatial_stage`].
fn normals_of(
    st: &mut Stages,
    job: &Job,
    opts: &Options,
    input: &normals::Input,
    name: &str,
) -> Result<Estimate> {
    let (stack, mask) = (&job.target, &job.mask);
    let out = st.run(name, |p| {
        if let normals::Input::Tables([table], _) = input {
            note_split(table, opts, p);
        }
        normals::pixelwise(stack, mask, input, p)
    })?;
    spatial_of(st, job, opts, input, out)
}

/// The Lambertian solve with the black level of [`Options::black_level`] (measured on
/// the whole stack for `Auto`; `full_scale`: the images' full scale in the job's units),
/// then the spatial stage; the level taken is a row of the figures.
fn lambertian(
    st: &mut Stages,
    job: &Job,
    lights: &Lights,
    opts: &Options,
    full_scale: f32,
) -> Result<Estimate> {
    let (stack, mask) = (&job.target, &job.mask);
    let mut lo = opts.lambertian.clone();
    let (out, decision) = st.run("Lambertian photometric stereo", |p| {
        let data = (stack, mask, lights);
        let (out, d) = lambertian::solve_with_black_level(opts.black_level, data, &lo, full_scale)?;
        note_black_level(&d, p);
        lo.black_level = d.level;
        Ok((normals::from_lambertian(out), d))
    })?;
    let input = normals::Input::Lambertian(lights, &lo);
    let mut est = spatial_of(st, job, opts, &input, out)?;
    est.rows.push(black_level_row(&decision));
    Ok(est)
}

/// Says on `p` the black level measured or given (nothing when none was asked for).
pub(super) fn note_black_level(d: &lambertian::BlackLevelDecision, p: &dyn Progress) {
    if d.measured.is_some() || d.level > 0.0 {
        p.note(&d.describe());
    }
}

/// The figures' row of the black level taken off.
pub(super) fn black_level_row(d: &lambertian::BlackLevelDecision) -> Figure {
    Figure::new("black level", d.summary())
}

/// The spatial stage after [`normals::pixelwise`] gave `out` with `input`, as a timed stage.
fn spatial_of(
    st: &mut Stages,
    job: &Job,
    opts: &Options,
    input: &normals::Input,
    out: normals::Output,
) -> Result<Estimate> {
    let (stack, mask) = (&job.target, &job.mask);
    let n_opts = normals::Options {
        spatial: opts.spatial.clone(),
    };
    let mut out = st.run(spatial_stage::name(opts), |_| {
        normals::spatial_stage(stack, mask, input, &n_opts, out)
    })?;
    let spatial = spatial_stage::info_of(&mut out);
    let outline = out.lookup.as_ref().and_then(|s| s.outline_check);
    Ok(Estimate {
        normals: out.normals,
        albedo: out.albedo,
        confidence: out.confidence,
        depth: None,
        spatial,
        rows: outline.map(outline_row).into_iter().collect(),
    })
}

/// The figure row of the lookup's check of the outline correction on the sphere's own
/// outline ([`lut::Lookup::outline_check`]).
pub(super) fn outline_row(check: lut::OutlineCheck) -> Figure {
    Figure::new("mask outline coverage correction", check.describe())
}

/// Depth from the normals; masked least squares and BiNI weight each pixel by its
/// trust ([`integrate::trust_weights`]: albedo, lookup confidence, slope).
pub(super) fn integrate_normals(
    est: &Estimate,
    mask: &Mask,
    method: integrate::Method,
    progress: &dyn Progress,
) -> Result<integrate::Output> {
    let weighted = matches!(
        method,
        integrate::Method::Lsq | integrate::Method::Bilateral { .. }
    );
    let weights = weighted.then(|| trust(est, mask));
    let opts = integrate::Options {
        method,
        weights,
        ..Default::default()
    };
    integrate::solve_with_progress(&est.normals, mask, &opts, progress)
}

/// The trust of each pixel's gradient ([`integrate::trust_weights`]).
fn trust(est: &Estimate, mask: &Mask) -> GrayImage {
    integrate::trust_weights(
        &est.normals,
        mask,
        est.albedo.as_ref(),
        est.confidence.as_ref(),
        &integrate::TrustOptions::default(),
    )
}

/// [`integrate_normals`]; with `auto` (no integrator named) and least squares, BiNI
/// instead where the least-squares depth has interior depth jumps. Returns the result
/// and, with `auto`, why that integrator.
pub(super) fn integrate_auto(
    est: &Estimate,
    mask: &Mask,
    method: integrate::Method,
    auto: bool,
    progress: &dyn Progress,
) -> Result<(integrate::Output, Option<String>)> {
    let first = integrate_normals(est, mask, method, progress)?;
    if !auto || method != integrate::Method::Lsq {
        return Ok((first, None));
    }
    let trust = trust(est, mask);
    let (chosen, jumps) =
        integrate::choose_method_for(&first.depth, &est.normals, mask, Some(&trust));
    let limit = integrate::JUMP_EDGES;
    if chosen == integrate::Method::Lsq {
        let why = format!("chosen: {jumps} edges where least squares jumps, fewer than {limit}");
        return Ok((first, Some(why)));
    }
    let out = integrate_normals(est, mask, chosen, progress)?;
    let cut = out.discontinuities.as_ref().map_or(0, |d| d.count());
    let why = format!(
        "chosen: least squares jumps across {jumps} edges (≥ {limit}); BiNI cut {cut} edges"
    );
    Ok((out, Some(why)))
}

/// The interreflection iteration with `method` and the black level of
/// [`Options::black_level`] ([`nik_black_level`]; `full_scale`: the images' full scale in
/// the job's units).
fn nik(
    job: &Job,
    lights: &Lights,
    opts: &Options,
    (method, full_scale): (integrate::Method, f32),
    truth: Option<&DepthMap>,
    progress: &dyn Progress,
) -> Result<(Interreflections, Estimate)> {
    let mask = &job.mask;
    let mut nik_opts = opts.nik.clone();
    nik_opts.integrate.method = method;
    let decision = nik_black_level(
        opts.black_level,
        nik_opts.lambertian.black_level,
        full_scale,
    );
    note_black_level(&decision, progress);
    if opts.black_level == lambertian::BlackLevelChoice::Auto {
        progress.note(
            "black level: not measured under interreflection removal (bounced light reads \
             as an offset); none taken off: give the camera's level if it has one",
        );
    }
    nik_opts.lambertian.black_level = decision.level;
    let out = interreflect::solve(&job.target, mask, lights, &nik_opts, progress)?;
    let plots = nik_plots(&out, mask, truth)?;
    let best = out.best_shape().clone();
    let ir = Interreflections {
        summary: out.summary(),
        csv: out.convergence_csv(),
        plots,
        iterations: out.iterations.len() - 1,
        depth_before: out.iterations[0].depth_range,
        depth_after: out.iterations[out.best].depth_range,
        albedo_before: out.iterations[0].mean_albedo,
        albedo_after: out.iterations[out.best].mean_albedo,
    };
    let est = Estimate {
        normals: best.normals,
        albedo: Some(best.albedo),
        confidence: None,
        depth: Some(best.depth),
        spatial: None,
        rows: vec![black_level_row(&decision)],
    };
    Ok((ir, est))
}

/// The black level of the interreflection iteration: as given (or none) by `choice`,
/// added to `base`, the level already set. `Auto` measures nothing there and takes
/// nothing off: light bounced between facets varies little with the light and reads as
/// an offset (0.6% of full scale on the Mitsuba V-groove without any), so a camera's
/// level must be given.
fn nik_black_level(
    choice: lambertian::BlackLevelChoice,
    base: f32,
    full_scale: f32,
) -> lambertian::BlackLevelDecision {
    lambertian::BlackLevelDecision::without_measuring(choice, base, full_scale).unwrap_or(
        lambertian::BlackLevelDecision {
            level: base,
            measured: None,
            full_scale,
        },
    )
}

/// The NIK run's plots (profiles along the middle row, convergence) as PNG bytes.
#[cfg(feature = "report")]
fn nik_plots(
    out: &interreflect::NikOutput,
    mask: &Mask,
    truth: Option<&DepthMap>,
) -> Result<Vec<Plot>> {
    let row = interreflect::plot::middle_row(mask).unwrap_or(mask.height / 2);
    Ok(vec![
        Plot {
            file: "profiles.png".to_string(),
            png: interreflect::profile_plot_png(out, mask, row, truth)?,
        },
        Plot {
            file: "convergence.png".to_string(),
            png: interreflect::convergence_plot_png(out)?,
        },
    ])
}

/// No plots without the `report` feature (plotters and its font are left out).
#[cfg(not(feature = "report"))]
fn nik_plots(
    _out: &interreflect::NikOutput,
    _mask: &Mask,
    _truth: Option<&DepthMap>,
) -> Result<Vec<Plot>> {
    Ok(Vec::new())
}

/// Angular error of the normals and depth error after the best offset, where the job
/// has the truth.
pub(super) fn accuracy(
    truth: &Truth,
    mask: &Mask,
    normals: &NormalMap,
    depth: &DepthMap,
) -> Result<Accuracy> {
    let angular = match &truth.normals {
        Some(gt) => Some((
            eval::angular_errors(normals, gt, mask)?,
            eval::angular_error_map(normals, gt, mask)?,
        )),
        None => None,
    };
    let depth_acc = match &truth.depth {
        Some(gt) => {
            let stats = eval::depth_rmse(depth, gt, mask)?;
            let off = stats.offset as f32;
            let map = GrayImage {
                width: depth.width,
                height: depth.height,
                data: depth
                    .data
                    .iter()
                    .zip(&gt.data)
                    .zip(&mask.data)
                    .map(|((e, g), &m)| if m { e + off - g } else { f32::NAN })
                    .collect(),
            };
            Some((stats, map))
        }
        None => None,
    };
    Ok(Accuracy {
        angular,
        depth: depth_acc,
    })
}
