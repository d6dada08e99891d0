//! The HTML report of a job (the `report` feature): maps, figures, timings, the 3-D
//! view of the mesh.

use super::figures::Titles;
use super::{Job, Normals, Output, RunSummary};
use crate::error::Result;
use crate::picture::ColorMap;
use crate::report::{Report, Section};
use crate::sphere;

/// The HTML report of a job: the maps of `p`, and the warnings, figures and timings of
/// its `summary` (what `run.json` holds).
pub fn build_report(
    titles: &Titles,
    job: &Job,
    p: &Output,
    summary: &RunSummary,
) -> Result<String> {
    let mask = Some(&job.mask);
    let mut r = Report::new(&titles.title);
    r.subtitle(&titles.subtitle);
    for w in &summary.warnings {
        r.warning(&w.message);
    }
    r.inputs(&job.target);
    r.surface(&p.depth, p.albedo.as_ref())?;
    r.relight(&p.normals, p.albedo.as_ref(), mask)?;
    r.normals(&p.normals, mask)?;
    if let Some(a) = &p.albedo {
        r.albedo(a, mask)?;
    }
    if let Some(c) = &p.confidence {
        r.scalar("confidence", c, mask, ColorMap::Viridis)?;
    }
    if let Some(sigma) = &p.normals_sigma {
        let caption = "angular standard error of the normals from their own data (°)";
        r.scalar(caption, sigma, mask, ColorMap::Viridis)?;
    }
    if let Some(s) = &p.own_share {
        let caption =
            "spatial stage: share of each pixel's own data (0 = decided by its neighbours)";
        r.scalar(caption, s, mask, ColorMap::Viridis)?;
    }
    r.depth(&p.depth);
    if let Some(c) = &p.curvature {
        let caption = "mean curvature from the normals (red: bulges toward the camera, \
                       blue: hollows; curvature.npy)";
        r.signed(caption, &c.mean, mask, c.display_limit, "1/px")?;
    }
    if let Some(det) = &p.circle {
        r.png(
            Section::Maps,
            "calibration sphere: circle found",
            sphere::encode_png(&sphere::overlay(&det.max_image, &det.circle))?,
        )?;
    }
    if let Normals::Lambertian { lights } = &job.normals {
        r.lights("light directions seen from the camera (lights.txt)", lights);
    }
    if let Some(det) = &p.chrome {
        r.png(
            Section::Lights,
            "chrome sphere: circle found (chrome_overlay.png)",
            sphere::encode_png(&sphere::overlay(&det.max_image, &det.circle))?,
        )?;
    }
    error_maps(&mut r, job, p)?;
    if let Some(ir) = &p.interreflections {
        for plot in &ir.plots {
            let caption = plot.file.replace(".png", "");
            r.png(Section::Interreflections, &caption, plot.png.clone())?;
        }
    }
    for f in &summary.figures {
        r.figure(&f.name, &f.value);
    }
    for t in &summary.stages {
        r.figure(format!("time: {}", t.stage), format!("{:.2} s", t.seconds));
    }
    r.to_html()
}

fn error_maps(r: &mut Report, job: &Job, p: &Output) -> Result<()> {
    let mask = Some(&job.mask);
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
    Ok(())
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
