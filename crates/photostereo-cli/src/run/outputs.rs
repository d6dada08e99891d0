//! Writing the products of a job: maps, mesh, `run.json` and `report.html`.

use std::path::{Path, PathBuf};

use anyhow::Result;
use photostereo::report::{raster::ColorMap, Report, Section};
use photostereo::{io, mesh, sphere};
use serde_json::{json, Value};

use super::pipeline::{Job, Products};

/// Write every product of `p` into `out`; returns the path of the report.
pub fn write_all(
    out: &Path,
    title: &str,
    subtitle: &str,
    job: &Job,
    p: &Products,
    extra_stages: &[(String, f64)],
) -> Result<PathBuf> {
    std::fs::create_dir_all(out).map_err(|e| photostereo::Error::io(out.to_path_buf(), e))?;
    let mask = &job.mask;
    io::write_normals(&out.join("normals.npy"), &p.normals)?;
    io::write_normals_png(&out.join("normals.png"), &p.normals, Some(mask))?;
    if let Some(a) = &p.albedo {
        io::write_gray_npy(&out.join("albedo.npy"), a)?;
        io::write_gray_png(&out.join("albedo.png"), a)?;
    }
    if let Some(c) = &p.confidence {
        io::write_gray_npy(&out.join("confidence.npy"), c)?;
        io::write_gray_png(&out.join("confidence.png"), c)?;
    }
    io::write_gray_npy(&out.join("depth.npy"), &p.depth)?;
    io::write_depth_png(&out.join("depth.png"), &p.depth, Some(mask))?;
    io::write_atomic(&out.join("mesh.ply"), |w| {
        mesh::write_ply_binary(&p.mesh, &mut *w)
    })?;
    if let Some(det) = &p.circle {
        let png = rgb_png(&sphere::overlay(&det.max_image, &det.circle))?;
        io::write_bytes(&out.join("sphere_overlay.png"), &png)?;
    }
    if let Some(ir) = &p.interreflections {
        io::write_text(&out.join("convergence.csv"), &ir.csv)?;
        for (name, png) in &ir.plots {
            io::write_bytes(&out.join(name), png)?;
        }
    }
    let mut stages: Vec<(String, f64)> = extra_stages.to_vec();
    stages.extend(p.stages.iter().cloned());
    let report_path = out.join("report.html");
    let html = build_report(title, subtitle, job, p, &stages)?;
    io::write_text(&report_path, &html)?;
    io::write_text(
        &out.join("run.json"),
        &run_json(title, p, &stages).to_string(),
    )?;
    Ok(report_path)
}

/// `run.json`: per-stage seconds and the figures.
pub fn run_json(title: &str, p: &Products, stages: &[(String, f64)]) -> Value {
    let stage_list: Vec<Value> = stages
        .iter()
        .map(|(n, s)| json!({"stage": n, "seconds": s}))
        .collect();
    let figures: serde_json::Map<String, Value> = p
        .figures
        .iter()
        .map(|(k, v)| (k.clone(), Value::String(v.clone())))
        .collect();
    let mut v = json!({
        "dataset": title,
        "integrator": p.method.name(),
        "stages": stage_list,
        "total_seconds": stages.iter().map(|s| s.1).sum::<f64>(),
        "figures": figures,
    });
    if let Some((st, _)) = &p.accuracy.angular {
        v["angular_error_deg"] = json!({"mean": st.mean, "median": st.median, "count": st.count});
    }
    if let Some((st, _)) = &p.accuracy.depth {
        v["depth_error_px"] = json!({"rmse": st.rmse, "range": st.range, "offset": st.offset});
    }
    if let Some(ir) = &p.interreflections {
        v["interreflections"] = json!({
            "depth_before_px": ir.depth_before,
            "depth_after_px": ir.depth_after,
            "mean_albedo_before": ir.albedo_before,
            "mean_albedo_after": ir.albedo_after,
            "iterations": ir.iterations,
            "summary": ir.summary,
        });
    }
    v
}

fn rgb_png(img: &photostereo::Image<[u8; 3]>) -> Result<Vec<u8>> {
    Ok(photostereo::report::raster::encode_png(img)?)
}

/// The HTML report of a job.
pub fn build_report(
    title: &str,
    subtitle: &str,
    job: &Job,
    p: &Products,
    stages: &[(String, f64)],
) -> Result<String> {
    let mask = Some(&job.mask);
    let mut r = Report::new(title);
    r.subtitle(subtitle);
    r.inputs(&job.target);
    r.surface(&p.depth, p.albedo.as_ref())?;
    r.normals(&p.normals, mask)?;
    if let Some(a) = &p.albedo {
        r.albedo(a, mask)?;
    }
    if let Some(c) = &p.confidence {
        r.scalar("confidence", c, mask, ColorMap::Viridis)?;
    }
    r.depth(&p.depth);
    if let Some(det) = &p.circle {
        let png = rgb_png(&sphere::overlay(&det.max_image, &det.circle))?;
        r.png(Section::Maps, "calibration sphere: circle found", png)?;
    }
    if let Some((st, map)) = &p.accuracy.angular {
        let max = (st.mean * 4.0).clamp(1.0, 30.0) as f32;
        r.error_map(
            "angular error of the normals",
            map,
            mask,
            max.round().max(1.0),
            "°",
        )?;
    }
    if let Some((st, map)) = &p.accuracy.depth {
        let abs = map.map(|v| v.abs());
        let max = (st.rmse * 3.0).max(0.01) as f32;
        r.error_map(
            "|depth error| after offset",
            &abs,
            mask,
            round_nice(max),
            "px",
        )?;
    }
    if let Some(ir) = &p.interreflections {
        for (name, png) in &ir.plots {
            r.png(
                Section::Interreflections,
                &name.replace(".png", ""),
                png.clone(),
            )?;
        }
    }
    for (k, v) in &p.figures {
        r.figure(k, v);
    }
    for (k, s) in stages {
        r.figure(format!("time: {k}"), format!("{s:.2} s"));
    }
    Ok(r.to_html()?)
}

fn round_nice(x: f32) -> f32 {
    let e = 10f32.powf(x.log10().floor());
    let m = x / e;
    let n = if m <= 1.0 {
        1.0
    } else if m <= 2.0 {
        2.0
    } else if m <= 5.0 {
        5.0
    } else {
        10.0
    };
    n * e
}
