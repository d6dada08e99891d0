//! Writing the products of a job — maps, mesh, `run.json` and `report.html` — through
//! [`crate::io`] (every file atomically: a failed run leaves no half-written file).

use std::path::{Path, PathBuf};

use super::figures::Titles;
use super::{Exports, Job, Normals, Output, RunSummary};
use crate::error::Result;
use crate::picture as raster;
use crate::{io, mesh, sphere};

/// What [`write_outputs`] did: the report's path and what `run.json` holds, with the
/// names of the files written (`files`) and of the stale ones removed (`stale_removed`).
#[derive(Clone, Debug)]
pub struct Written {
    /// The path of `report.html` (of `run.json` without the `report` feature).
    pub report: PathBuf,
    /// What `run.json` holds.
    pub summary: RunSummary,
}

/// Write every product of `p` into the directory `out` (created): `normals.npy/png`,
/// `albedo.npy/png`, `confidence.npy/png`, `normals_sigma.npy/png` and `own_share.npy`
/// (spatial stage), `depth.npy/png`, `mesh.ply`, `curvature.npy/png` and
/// `gaussian_curvature.npy` (with [`super::Options::curvature`]), `normal_map.png`,
/// `normals.tif` and `depth.tif` (those `exports` asks for),
/// `sphere_overlay.png`, `lights.txt` (Lambertian), `chrome_overlay.png` (lights from a
/// chrome sphere), `convergence.csv` and plots (those the run has), `report.html` (with
/// the `report` feature) and `run.json`. `albedo.png` and `depth.png` are the report's
/// pictures ([`raster::albedo_picture`], [`raster::depth_picture`]; their ranges are
/// figure rows). `extra_stages` (e.g. loading) come before the pipeline's own stages in
/// the timings.
///
/// When `out` holds an earlier run's outputs, those this run does not write (another
/// mode's `confidence.*`, `sphere_overlay.png`, ...) are removed once the new ones are
/// written, so that no file of the folder belongs to another run; `run.json` lists the
/// files written (`files`) and those removed (`stale_removed`).
pub fn write_outputs(
    out: &Path,
    titles: &Titles,
    job: &Job,
    p: &Output,
    extra_stages: &[(String, f64)],
) -> Result<Written> {
    write_outputs_with(out, titles, job, p, extra_stages, &Exports::default())
}

/// [`write_outputs`] and the files for other tools that `exports` asks for.
pub fn write_outputs_with(
    out: &Path,
    titles: &Titles,
    job: &Job,
    p: &Output,
    extra_stages: &[(String, f64)],
    exports: &Exports,
) -> Result<Written> {
    let earlier = io::previous_run_files(out);
    let mut stages: Vec<(String, f64)> = extra_stages.to_vec();
    stages.extend(p.stages.iter().cloned());
    let mut summary = RunSummary::of(&titles.title, p, &stages);
    // the report is built while the maps are written (it reads none of them, nor the
    // list of files): two cores' worth of encoding
    let (files, html) = rayon::join(
        || -> Result<Vec<&'static str>> {
            let mut files = write_maps(out, job, p)?;
            files.extend(write_exports(out, job, p, exports)?);
            Ok(files)
        },
        || report_html(titles, job, p, &summary),
    );
    let mut files = files?;
    let html = html?;
    if html.is_some() {
        files.push("report.html");
    }
    files.push("run.json");
    let stale: Vec<String> = earlier
        .into_iter()
        .filter(|f| !files.contains(&f.as_str()))
        .collect();
    summary.files = files.iter().map(|f| f.to_string()).collect();
    summary.stale_removed = stale;
    let json_path = out.join("run.json");
    let report = match html {
        Some(html) => {
            let report = out.join("report.html");
            io::write_text(&report, &html)?;
            report
        }
        None => json_path.clone(),
    };
    io::write_text(&json_path, &summary.to_json().to_string())?;
    io::remove_files(out, &summary.stale_removed)?;
    Ok(Written { report, summary })
}

/// The text of `report.html` (`None` without the `report` feature).
#[cfg(feature = "report")]
fn report_html(titles: &Titles, job: &Job, p: &Output, s: &RunSummary) -> Result<Option<String>> {
    super::report_page::build_report(titles, job, p, s).map(Some)
}

#[cfg(not(feature = "report"))]
fn report_html(_: &Titles, _: &Job, _: &Output, _: &RunSummary) -> Result<Option<String>> {
    Ok(None)
}

/// Write the maps, mesh and pictures of `p`; returns the names of the files written.
fn write_maps(out: &Path, job: &Job, p: &Output) -> Result<Vec<&'static str>> {
    let mask = &job.mask;
    let mut files = vec!["normals.npy", "normals.png"];
    io::write_normals(&out.join("normals.npy"), &p.normals)?;
    io::write_normals_png(&out.join("normals.png"), &p.normals, Some(mask))?;
    if let Some(a) = &p.albedo {
        io::write_gray_npy(&out.join("albedo.npy"), a)?;
        let (rgb, _) = raster::albedo_picture(a, Some(mask));
        io::write_bytes(&out.join("albedo.png"), &raster::encode_png(&rgb)?)?;
        files.extend(["albedo.npy", "albedo.png"]);
    }
    if let Some(c) = &p.confidence {
        io::write_gray_npy(&out.join("confidence.npy"), c)?;
        io::write_gray_png(&out.join("confidence.png"), c)?;
        files.extend(["confidence.npy", "confidence.png"]);
    }
    if let Some(sigma) = &p.normals_sigma {
        io::write_gray_npy(&out.join("normals_sigma.npy"), sigma)?;
        // false colour over 0–10°, as `photostereo normals` writes it
        let png = out.join("normals_sigma.png");
        io::write_colormap_png(&png, sigma, Some(mask), Some((0.0, 10.0)))?;
        files.extend(["normals_sigma.npy", "normals_sigma.png"]);
    }
    if let Some(s) = &p.own_share {
        io::write_gray_npy(&out.join("own_share.npy"), s)?;
        files.push("own_share.npy");
    }
    io::write_gray_npy(&out.join("depth.npy"), &p.depth)?;
    let (rgb, _) = raster::depth_picture(&p.depth, Some(mask));
    io::write_bytes(&out.join("depth.png"), &raster::encode_png(&rgb)?)?;
    io::write_atomic(&out.join("mesh.ply"), |w| {
        mesh::write_ply_binary(&p.mesh, &mut *w)
    })?;
    files.extend(["depth.npy", "depth.png", "mesh.ply"]);
    if let Some(c) = &p.curvature {
        io::write_gray_npy(&out.join("curvature.npy"), &c.mean)?;
        io::write_gray_npy(&out.join("gaussian_curvature.npy"), &c.gaussian)?;
        let rgb = raster::signed_picture(&c.mean, Some(mask), c.display_limit);
        io::write_bytes(&out.join("curvature.png"), &raster::encode_png(&rgb)?)?;
        files.extend(["curvature.npy", "curvature.png", "gaussian_curvature.npy"]);
    }
    files.extend(write_sides(out, job, p)?);
    Ok(files)
}

/// The lights, overlays and interreflection files of `p`; returns their names.
fn write_sides(out: &Path, job: &Job, p: &Output) -> Result<Vec<&'static str>> {
    let mut files = Vec::new();
    if let Normals::Lambertian { lights } = &job.normals {
        io::write_light_directions(&out.join("lights.txt"), lights)?;
        files.push("lights.txt");
    }
    if let Some(det) = &p.chrome {
        io::write_bytes(&out.join("chrome_overlay.png"), &overlay_png(det)?)?;
        files.push("chrome_overlay.png");
    }
    if let Some(det) = &p.circle {
        io::write_bytes(&out.join("sphere_overlay.png"), &overlay_png(det)?)?;
        files.push("sphere_overlay.png");
    }
    if let Some(ir) = &p.interreflections {
        io::write_text(&out.join("convergence.csv"), &ir.csv)?;
        files.push("convergence.csv");
        for plot in &ir.plots {
            io::write_bytes(&out.join(&plot.file), &plot.png)?;
            // the plots are named by the pipeline; list them by their RUN_FILES name
            if let Some(n) = io::RUN_FILES.iter().find(|n| **n == plot.file.as_str()) {
                files.push(n);
            }
        }
    }
    Ok(files)
}

/// The files for other tools that `exports` asks for; returns their names.
fn write_exports(
    out: &Path,
    job: &Job,
    p: &Output,
    exports: &Exports,
) -> Result<Vec<&'static str>> {
    let mut files = Vec::new();
    if let Some(style) = exports.normal_map {
        io::write_normal_map_png(&out.join("normal_map.png"), &p.normals, &job.mask, style)?;
        files.push("normal_map.png");
    }
    if exports.float_tiff {
        io::write_normals_tiff(&out.join("normals.tif"), &p.normals)?;
        io::write_depth_tiff(&out.join("depth.tif"), &p.depth)?;
        files.extend(["normals.tif", "depth.tif"]);
    }
    Ok(files)
}

fn overlay_png(det: &sphere::Detection) -> Result<Vec<u8>> {
    crate::picture::encode_png(&sphere::overlay(&det.max_image, &det.circle))
}
