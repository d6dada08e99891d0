//! The whole job in memory: normals (lookup table or Lambertian, optionally with
//! interreflection removal) → depth → mesh, timed stage by stage, with accuracy figures
//! when ground truth is known. Shared by `photostereo run` and `photostereo demo`.

use std::time::Instant;

use anyhow::{Context, Result};
use photostereo::image::{DepthMap, GrayImage, ImageStack, Lights, Mask, NormalMap};
use photostereo::{eval, integrate, interreflect, lambertian, lut, mesh, sphere};

use crate::progress::Bar;

/// Where the normals come from.
pub enum Normals {
    /// Calibration-based: a lookup table from a sphere of the same material imaged
    /// under the same lights (`sphere_mask` restricts the sphere search).
    Lookup {
        sphere: ImageStack,
        sphere_mask: Option<Mask>,
    },
    /// Lambertian least squares with known lights; with `interreflections`, the
    /// Nayar–Ikeuchi–Kanade iteration on top.
    Lambertian {
        lights: Lights,
        interreflections: bool,
    },
}

/// Ground truth, when known (synthetic data).
#[derive(Default)]
pub struct Truth {
    pub normals: Option<NormalMap>,
    pub depth: Option<DepthMap>,
}

/// One job.
pub struct Job {
    pub target: ImageStack,
    pub mask: Mask,
    pub normals: Normals,
    /// Integrator; `None` = [`integrate::choose_method`] from the mask.
    pub method: Option<integrate::Method>,
    pub truth: Truth,
}

/// Interreflection removal results.
pub struct Interreflections {
    /// One-line summary of the iteration (converged or not, iterate kept).
    pub summary: String,
    /// Convergence table (CSV).
    pub csv: String,
    /// Plots: (file name, PNG bytes).
    pub plots: Vec<(String, Vec<u8>)>,
    /// Compensation steps done.
    pub iterations: usize,
    /// Depth of the concavity (depth range over the mask, px) of the raw reconstruction
    /// and of the kept iterate.
    pub depth_before: f32,
    pub depth_after: f32,
    /// Mean albedo over the mask of the raw reconstruction and of the kept iterate.
    pub albedo_before: f32,
    pub albedo_after: f32,
}

/// Accuracy against ground truth.
pub struct Accuracy {
    pub angular: Option<(eval::NormalStats, GrayImage)>,
    /// RMSE after the best offset, its depth range, and the signed error map (px).
    pub depth: Option<(eval::DepthStats, GrayImage)>,
}

/// Everything the job produced.
pub struct Products {
    pub normals: NormalMap,
    pub albedo: Option<GrayImage>,
    pub confidence: Option<GrayImage>,
    pub depth: DepthMap,
    pub mesh: mesh::Mesh,
    pub method: integrate::Method,
    pub circle: Option<sphere::Detection>,
    pub interreflections: Option<Interreflections>,
    pub accuracy: Accuracy,
    /// (stage, seconds), in order.
    pub stages: Vec<(String, f64)>,
    /// (figure, value) rows for the report and `run.json`, in order.
    pub figures: Vec<(String, String)>,
}

/// Runs named stages, printing `[i/n] stage ... s` and timing each.
pub struct Stages {
    pub list: Vec<(String, f64)>,
    total: usize,
    quiet: bool,
}

impl Stages {
    pub fn new(total: usize, quiet: bool) -> Self {
        Stages {
            list: Vec::new(),
            total,
            quiet,
        }
    }

    pub fn run<T>(&mut self, name: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
        let i = self.list.len() + 1;
        if !self.quiet {
            eprintln!("[{i}/{}] {name} ...", self.total.max(i));
        }
        let t0 = Instant::now();
        let out = f().with_context(|| format!("stage '{name}' failed"))?;
        let dt = t0.elapsed().as_secs_f64();
        if !self.quiet {
            eprintln!("[{i}/{}] {name}: {dt:.2} s", self.total.max(i));
        }
        self.list.push((name.to_string(), dt));
        Ok(out)
    }
}

struct Estimate {
    normals: NormalMap,
    albedo: Option<GrayImage>,
    confidence: Option<GrayImage>,
    depth: Option<DepthMap>,
}

/// Run the job; `quiet` silences stage lines and progress bars.
pub fn run(job: &Job, quiet: bool) -> Result<Products> {
    let bar = Bar::new(quiet);
    let has_truth = job.truth.normals.is_some() || job.truth.depth.is_some();
    let mut st = Stages::new(planned_stages(&job.normals) + usize::from(has_truth), quiet);
    let method = job
        .method
        .unwrap_or_else(|| integrate::choose_method(&job.mask));
    let (est, circle, ir) = normals_stage(&mut st, &bar, job, method)?;
    let depth = match est.depth.clone() {
        Some(d) => d,
        None => st.run("integration", || {
            let conf = est.confidence.as_ref();
            integrate_normals(&est.normals, &job.mask, conf, method, &bar)
        })?,
    };
    let mesh = st.run("mesh", || {
        let albedo = est.albedo.as_ref();
        Ok(mesh::from_depth(
            &depth,
            &job.mask,
            Some(&est.normals),
            albedo,
        )?)
    })?;
    let accuracy = if has_truth {
        st.run("accuracy", || accuracy(job, &est.normals, &depth))?
    } else {
        Accuracy {
            angular: None,
            depth: None,
        }
    };
    let mut figures = Vec::new();
    if let Some(det) = &circle {
        figures.push(("sphere circle (cx, cy, r) px".into(), circle_text(det)));
    }
    figures.extend(summary_figures(
        job, &est, &depth, &mesh, method, &accuracy, &ir,
    ));
    Ok(Products {
        normals: est.normals,
        albedo: est.albedo,
        confidence: est.confidence,
        depth,
        mesh,
        method,
        circle,
        interreflections: ir,
        accuracy,
        stages: st.list,
        figures,
    })
}

/// Stages before the accuracy one: normals (1 to 3), integration (unless NIK made the
/// depth), mesh.
fn planned_stages(normals: &Normals) -> usize {
    match normals {
        Normals::Lookup { .. } => 5,
        Normals::Lambertian {
            interreflections: false,
            ..
        } => 3,
        Normals::Lambertian { .. } => 2,
    }
}

type NormalsResult = (
    Estimate,
    Option<sphere::Detection>,
    Option<Interreflections>,
);

/// Normals (and albedo, confidence, and with NIK the depth) by the job's method.
fn normals_stage(
    st: &mut Stages,
    bar: &Bar,
    job: &Job,
    method: integrate::Method,
) -> Result<NormalsResult> {
    Ok(match &job.normals {
        Normals::Lookup {
            sphere,
            sphere_mask,
        } => {
            let (det, est) = lookup(st, bar, job, sphere, sphere_mask.clone())?;
            (est, Some(det), None)
        }
        Normals::Lambertian {
            lights,
            interreflections: false,
        } => {
            let est = st.run("Lambertian photometric stereo", || {
                lambertian_normals(&job.target, &job.mask, lights)
            })?;
            (est, None, None)
        }
        Normals::Lambertian {
            lights,
            interreflections: true,
        } => {
            let truth = job.truth.depth.as_ref();
            let (ir, est) = st.run("interreflection removal", || {
                nik(&job.target, &job.mask, lights, method, truth, bar)
            })?;
            (est, None, Some(ir))
        }
    })
}

fn circle_text(det: &sphere::Detection) -> String {
    let c = det.circle;
    format!(
        "{:.2}, {:.2}, {:.2} (fit rms {:.2} px)",
        c.cx, c.cy, c.radius, det.rms_residual_px
    )
}

fn lookup(
    st: &mut Stages,
    bar: &Bar,
    job: &Job,
    sphere_stack: &ImageStack,
    sphere_mask: Option<Mask>,
) -> Result<(sphere::Detection, Estimate)> {
    let det = st.run("sphere detection", || {
        let opts = sphere::DetectOptions {
            mask: sphere_mask,
            ..Default::default()
        };
        Ok(sphere::detect(sphere_stack, &opts)?)
    })?;
    let table = st.run("lookup table", || {
        Ok(lut::Table::build(
            sphere_stack,
            &det.circle,
            &lut::BuildOptions::default(),
        )?)
    })?;
    let out = st.run("lookup", || {
        Ok(lut::solve(
            &job.target,
            &job.mask,
            std::slice::from_ref(&table),
            &lut::Options::default(),
            bar,
        )?)
    })?;
    let est = Estimate {
        normals: out.normals,
        albedo: out.albedo,
        confidence: Some(out.confidence),
        depth: None,
    };
    Ok((det, est))
}

fn lambertian_normals(stack: &ImageStack, mask: &Mask, lights: &Lights) -> Result<Estimate> {
    let out = lambertian::solve(stack, mask, lights, &lambertian::Options::default())?;
    Ok(Estimate {
        normals: out.normals,
        albedo: Some(out.albedo),
        confidence: None,
        depth: None,
    })
}

fn integrate_normals(
    normals: &NormalMap,
    mask: &Mask,
    confidence: Option<&GrayImage>,
    method: integrate::Method,
    bar: &Bar,
) -> Result<DepthMap> {
    let opts = integrate::Options {
        method,
        weights: confidence
            .filter(|_| method == integrate::Method::Lsq)
            .cloned(),
        ..Default::default()
    };
    Ok(integrate::solve_with_progress(normals, mask, &opts, bar)?.depth)
}

fn nik(
    raw: &ImageStack,
    mask: &Mask,
    lights: &Lights,
    method: integrate::Method,
    truth: Option<&DepthMap>,
    bar: &Bar,
) -> Result<(Interreflections, Estimate)> {
    let mut opts = interreflect::NikOptions::default();
    opts.integrate.method = method;
    let out = interreflect::solve(raw, mask, lights, &opts, bar)?;
    let row = interreflect::plot::middle_row(mask).unwrap_or(mask.height / 2);
    let plots = vec![
        (
            "profiles.png".to_string(),
            interreflect::profile_plot_png(&out, mask, row, truth)?,
        ),
        (
            "convergence.png".to_string(),
            interreflect::convergence_plot_png(&out)?,
        ),
    ];
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
    };
    Ok((ir, est))
}

/// Depth range (max − min) over the mask, pixels.
pub fn depth_range(depth: &DepthMap, mask: &Mask) -> f32 {
    let (lo, hi) = depth
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(d, &m)| m && d.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), (d, _)| {
            (lo.min(*d), hi.max(*d))
        });
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}

/// Mean over the mask of the finite values.
pub fn masked_mean(img: &GrayImage, mask: &Mask) -> f32 {
    let (sum, n) = img
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(v, &m)| m && v.is_finite())
        .fold((0.0f64, 0usize), |(s, n), (v, _)| {
            (s + f64::from(*v), n + 1)
        });
    if n == 0 {
        f32::NAN
    } else {
        (sum / n as f64) as f32
    }
}

fn accuracy(job: &Job, normals: &NormalMap, depth: &DepthMap) -> Result<Accuracy> {
    let angular = match &job.truth.normals {
        Some(gt) => Some((
            eval::angular_errors(normals, gt, &job.mask)?,
            eval::angular_error_map(normals, gt, &job.mask)?,
        )),
        None => None,
    };
    let depth_acc = match &job.truth.depth {
        Some(gt) => {
            let stats = eval::depth_rmse(depth, gt, &job.mask)?;
            let off = stats.offset as f32;
            let map = GrayImage {
                width: depth.width,
                height: depth.height,
                data: depth
                    .data
                    .iter()
                    .zip(&gt.data)
                    .zip(&job.mask.data)
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

fn summary_figures(
    job: &Job,
    est: &Estimate,
    depth: &DepthMap,
    mesh: &mesh::Mesh,
    method: integrate::Method,
    acc: &Accuracy,
    ir: &Option<Interreflections>,
) -> Vec<(String, String)> {
    let s = &job.target;
    let mut f = vec![
        (
            "images".to_string(),
            format!("{} of {}×{}", s.k, s.width, s.height),
        ),
        ("pixels in the mask".into(), job.mask.count().to_string()),
        ("integrator".into(), method.name().to_string()),
        (
            "depth range (px)".into(),
            format!("{:.2}", depth_range(depth, &job.mask)),
        ),
        (
            "mesh".into(),
            format!(
                "{} vertices, {} triangles",
                mesh.vertices.len(),
                mesh.faces.len()
            ),
        ),
    ];
    if let Some(c) = &est.confidence {
        let mean = masked_mean(c, &job.mask);
        f.push(("mean confidence".into(), format!("{mean:.3}")));
    }
    if let Some(a) = &est.albedo {
        let mean = masked_mean(a, &job.mask);
        f.push(("mean albedo".into(), format!("{mean:.3}")));
    }
    if let Some((st, _)) = &acc.angular {
        f.push(("mean angular error (°)".into(), format!("{:.3}", st.mean)));
        f.push((
            "median angular error (°)".into(),
            format!("{:.3}", st.median),
        ));
    }
    if let Some((st, _)) = &acc.depth {
        f.push((
            "depth RMSE after offset (px)".into(),
            format!(
                "{:.3} ({:.2}% of the range {:.1})",
                st.rmse,
                100.0 * st.rmse / st.range.max(1e-9),
                st.range
            ),
        ));
    }
    if let Some(ir) = ir {
        f.push(("interreflections".into(), ir.summary.clone()));
        f.push((
            "concavity depth before → after (px)".into(),
            format!("{:.2} → {:.2}", ir.depth_before, ir.depth_after),
        ));
        f.push((
            "mean albedo before → after".into(),
            format!("{:.3} → {:.3}", ir.albedo_before, ir.albedo_after),
        ));
    }
    f
}
