//! [`super::run`] on captures of any size: the target's images are read by row bands
//! ([`crate::io::bands`]) within the memory budget ([`crate::plan`]), never held whole.
//!
//! The per-pixel stages run band by band and write into H×W maps: the lookup (one
//! [`lut::Lookup`] prepared once, solved per band) or the Lambertian solve (after a pass
//! that measures the camera's black level, [`lambertian::BlackLevelSums`]), the noise
//! samples ([`NoiseSampler`], which takes the samples of the whole stack in the same
//! order) and, for a lookup, the evidence of each pixel ([`spatial::info::from_table`]) in
//! a second pass, once the noise is known. The spatial solve is global: it runs on the
//! H×W evidence, and each re-linearisation pass re-reads the bands that hold pixels to
//! re-linearise. A lookup pixel's result depends only on its own samples (and the warm
//! start along its row, which a band keeps whole), so the maps are those of the
//! in-memory path, and so are the depth and the mesh made from them. When the whole
//! stack fits in the budget it is one band, read once.

use std::path::Path;
use std::time::Instant;

use super::load::{
    check, leave_out_sphere, normals_of, radiance_scale, scale_is_known, subtitle, Source,
};
use super::spatial_stage::{adopt, own_only, SpatialInfo};
use super::stages;
use super::timer::Stages;
use super::{Estimate, Figure, Inputs, Job, Normals, Options, Run, Titles, Truth};
use crate::error::Result;
use crate::image::{GrayImage, Image, ImageStack, Lights, Mask, NormalMap};
use crate::io::{self, DatasetBands};
use crate::progress::{NoProgress, Progress};
use crate::spatial::info::Reflectance;
use crate::spatial::{self, info::Evidence, Censor, NoiseModel, NoiseSampler};

/// The sensor's evidence model: the noise and the censoring bounds of the capture.
type Model<'a> = (&'a NoiseModel, &'a Censor);
use crate::warning::Warning;
use crate::{lambertian, lut, plan};

/// Longest side of the decimated copy of the images kept for the report's thumbnails.
const PREVIEW_SIDE: usize = 512;

/// The target, opened for reading by bands.
struct Capture {
    ds: DatasetBands,
    mask: Mask,
    band_rows: usize,
    /// Factor the images are multiplied by (radiance units, Lambertian).
    scale: Option<f32>,
    /// The one band, kept between passes when the whole stack is one band.
    whole: Option<ImageStack>,
}

impl Capture {
    fn height(&self) -> usize {
        self.mask.height
    }

    /// One pass over the bands, top to bottom: `f(band, first row)` on every band whose
    /// rows `need` says it needs (the reading stops after the last one), with progress.
    fn pass(
        &mut self,
        what: &str,
        progress: &dyn Progress,
        need: impl Fn(usize, usize) -> bool,
        mut f: impl FnMut(&ImageStack, usize) -> Result<()>,
    ) -> Result<()> {
        let (h, rows) = (self.height(), self.band_rows);
        let starts: Vec<usize> = (0..h)
            .step_by(rows)
            .filter(|&r0| need(r0, (r0 + rows).min(h)))
            .collect();
        let Some(&last) = starts.last() else {
            return Ok(());
        };
        progress.start(what, starts.len() as u64);
        if let Some(band) = &self.whole {
            f(band, 0)?;
            progress.advance(1);
            progress.finish();
            return Ok(());
        }
        let mut reader = self.ds.reader()?;
        while reader.next_row() <= last {
            let r0 = reader.next_row();
            let mut band = reader.next_band(rows)?;
            if !starts.contains(&r0) {
                continue;
            }
            if let Some(s) = self.scale {
                band.data.iter_mut().for_each(|v| *v *= s);
            }
            f(&band, r0)?;
            progress.advance(1);
            if rows >= h {
                self.whole = Some(band);
            }
        }
        progress.finish();
        Ok(())
    }
}

/// Rows `r0..r0 + n` of `img`.
fn rows_of<T: Clone>(img: &Image<T>, r0: usize, n: usize) -> Image<T> {
    let w = img.width;
    Image {
        width: w,
        height: n,
        data: img.data[r0 * w..(r0 + n) * w].to_vec(),
    }
}

/// Write `band` into `dst` from row `r0`.
fn put_rows<T: Clone>(dst: &mut Image<T>, band: &Image<T>, r0: usize) {
    let w = dst.width;
    dst.data[r0 * w..(r0 + band.height) * w].clone_from_slice(&band.data);
}

/// Whether rows `r0..r1` of the mask hold a pixel of it.
fn any_in(mask: &Mask, r0: usize, r1: usize) -> bool {
    mask.data[r0 * mask.width..r1 * mask.width]
        .iter()
        .any(|&m| m)
}

/// Every `step`-th row and column of the band's images, for the thumbnails.
fn decimate(preview: &mut Vec<f32>, band: &ImageStack, r0: usize, step: usize) {
    for r in (0..band.height).filter(|r| (r0 + r) % step == 0) {
        for c in (0..band.width).step_by(step) {
            preview.extend_from_slice(band.pixel(r, c));
        }
    }
}

/// The whole job from paths, the target read by bands (module docs).
pub(super) fn run(
    inputs: &Inputs,
    out: &Path,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Run> {
    check(inputs, opts)?;
    let t0 = Instant::now();
    let (load_opts, others) = inputs.load_options();
    let ds = io::open_dataset_bands(&inputs.target, &load_opts)?;
    let (w, h) = (ds.header.width, ds.header.height);
    // the sphere's stack, its decoding and its table (its folder is only opened here)
    let extra = match &inputs.sphere {
        Some(dir) => {
            let s = io::open_dataset_bands(dir, &others)?;
            (s.header.width * s.header.height * s.header.k() * 4 * 3) as u64
        }
        None => 0,
    };
    let budget = opts
        .memory
        .unwrap_or_else(|| plan::default_budget(io::system_memory()));
    let the_plan = plan::plan(&ds.header, extra, budget)?;
    progress.note(&the_plan.to_string());
    let image_scale = image_scale(inputs)?;
    let mut mask = ds.mask.clone().unwrap_or_else(|| Mask::full(w, h));
    let mut warnings: Vec<Warning> = leave_out_sphere(inputs, opts, &mut mask)?
        .into_iter()
        .collect();
    let mut stages = Vec::new();
    let names = file_names(&ds);
    let source = Source {
        k: ds.header.k(),
        lights: ds.lights.clone(),
        names: &names,
        others: &others,
    };
    let (normals, chrome) = normals_of(inputs, &source, progress, &mut stages, &mut warnings)?;
    stages.insert(0, ("load".to_string(), t0.elapsed().as_secs_f64()));
    let mut cap = Capture {
        ds,
        mask,
        band_rows: opts
            .max_band_rows
            .map_or(the_plan.band_rows, |r| r.clamp(1, the_plan.band_rows)),
        scale: image_scale.map(|s| s.0),
        whole: None,
    };
    crate::io::memtrace::mark("before the stages");
    let (job, mut output) = solve(&mut cap, normals, &inputs.target, opts, progress)?;
    if let Some((scale, from)) = image_scale {
        output.figures.push(Figure::new(
            "image scale (images ×)",
            format!("{scale} ({from})"),
        ));
    }
    // read by bands only when linear (io::readable_by_bands)
    output.figures.push(Figure::new(
        "image response",
        io::Response::Linear.to_string(),
    ));
    output.chrome = chrome;
    for w in &warnings {
        progress.note(&format!("warning: {w}"));
    }
    output.warnings.extend(warnings);
    let titles = Titles {
        title: io::dataset_name(&inputs.target),
        subtitle: subtitle(inputs, opts),
    };
    let written = super::write_outputs_with(out, &titles, &job, &output, &stages, &opts.exports)?;
    crate::io::memtrace::mark("outputs written");
    Ok(Run {
        output,
        report: written.report,
        summary: written.summary,
    })
}

/// The images' scale to radiance units for a Lambertian run, with where it came from.
fn image_scale(inputs: &Inputs) -> Result<Option<(f32, &'static str)>> {
    if !inputs.lambertian {
        return Ok(None);
    }
    let scale = radiance_scale(&inputs.target, inputs.image_scale, false)?;
    let from = match (
        inputs.image_scale.is_some(),
        scale_is_known(&inputs.target, inputs.image_scale, false)?,
    ) {
        (true, _) => "given",
        _ => "not given: images taken as radiance units",
    };
    Ok(Some((scale, from)))
}

/// The pipeline on the capture: normals by bands, then [`super::finish`] with the ground
/// truth of the `target` folder (read by the accuracy stage only: it is not needed
/// before, and would add 16 B per pixel to the peaks of the spatial stage and the
/// integration). Returns the job (its target the
/// decimated images of the thumbnails) and the output.
fn solve(
    cap: &mut Capture,
    normals: Normals,
    target: &Path,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<(Job, super::Output)> {
    let has_truth = io::has_ground_truth(target);
    let total = stages::planned(&normals, false)
        + usize::from(has_truth)
        + usize::from(opts.curvature.is_some());
    let mut st = Stages::new(total, progress);
    let (w, h, k) = (cap.mask.width, cap.mask.height, cap.ds.header.k());
    let method = opts
        .method
        .unwrap_or_else(|| crate::integrate::choose_method(&cap.mask));
    let step = w.max(h).div_ceil(PREVIEW_SIDE).max(1);
    let mut preview = Vec::new();
    let (est, circle, normals) = match normals {
        Normals::Lookup {
            sphere,
            sphere_mask,
        } => {
            let det = st.run("sphere detection", |p| {
                let det = stages::detect(&sphere, sphere_mask.clone(), opts)?;
                if let Some(w) = det.warning() {
                    p.note(&w);
                }
                Ok(det)
            })?;
            let table = st.run("lookup table", |_| {
                lut::Table::build(&sphere, &det.circle, &opts.build)
            })?;
            let est = lookup_stages(&mut st, cap, &table, opts, (&mut preview, step))?;
            // the sphere stays in the job: the checks of the circle look at it
            let normals = Normals::Lookup {
                sphere,
                sphere_mask,
            };
            (est, Some(det), normals)
        }
        Normals::Calibrated(cal) => {
            let est = lookup_stages(&mut st, cap, &cal.table, opts, (&mut preview, step))?;
            (est, cal.detection.clone(), Normals::Calibrated(cal))
        }
        Normals::Lambertian { lights } => {
            let est = lambertian_stages(&mut st, cap, &lights, opts, (&mut preview, step))?;
            (est, None, Normals::Lambertian { lights })
        }
    };
    let thumbnails = ImageStack {
        width: w.div_ceil(step),
        height: h.div_ceil(step),
        k,
        data: preview,
        names: file_names(&cap.ds),
    };
    // the ground truth is read by the accuracy stage (finish's truth_dir)
    let job = Job {
        target: thumbnails,
        mask: cap.mask.clone(),
        normals,
        truth: Truth {
            normals: None,
            depth: None,
        },
    };
    let result = (est, circle, None);
    let mut output = super::finish(st, &job, opts, method, result, Some(target))?;
    for row in output.figures.iter_mut().filter(|r| r.name == "images") {
        row.value = format!("{k} of {w}×{h}");
    }
    Ok((job, output))
}

/// The lookup by bands, then the spatial stage on its evidence (a second pass) with
/// re-linearisation passes over the bands that need it.
fn lookup_stages(
    st: &mut Stages,
    cap: &mut Capture,
    table: &lut::Table,
    opts: &Options,
    preview: (&mut Vec<f32>, usize),
) -> Result<Estimate> {
    let mask = cap.mask.clone();
    mask.check_not_empty("target mask")?;
    stages::note_split(table, opts, st.progress());
    let lookup = lut::Lookup::new(std::slice::from_ref(table), &opts.lookup)?;
    let mut sampler = NoiseSampler::new(&mask, cap.ds.header.k());
    let est = st.run("lookup", |p| {
        lookup_pass(cap, &lookup, &mask, &mut sampler, preview, p)
    })?;
    drop(lookup);
    st.run(super::spatial_stage::name(opts), |p| {
        spatial_pass(cap, table, opts, &mask, sampler, est, p)
    })
}

/// The lookup band by band into H×W maps; each band also feeds the noise `sampler` and
/// the report's decimated `preview`.
fn lookup_pass(
    cap: &mut Capture,
    lookup: &lut::Lookup,
    mask: &Mask,
    sampler: &mut NoiseSampler,
    preview: (&mut Vec<f32>, usize),
    p: &dyn Progress,
) -> Result<Estimate> {
    let (w, h) = (mask.width, mask.height);
    let mut normals = NormalMap::filled(w, h, [0.0; 3]);
    let mut confidence = GrayImage::filled(w, h, 0.0);
    let mut albedo: Option<GrayImage> = None;
    solve_bands(cap, "lookup", mask, sampler, preview, p, |band, bm, r0| {
        let out = lookup.solve(band, bm, &NoProgress)?;
        put_rows(&mut normals, &out.normals, r0);
        put_rows(&mut confidence, &out.confidence, r0);
        if let Some(a) = &out.albedo {
            let all = albedo.get_or_insert_with(|| GrayImage::filled(w, h, 0.0));
            put_rows(all, a, r0);
        }
        Ok(())
    })?;
    Ok(Estimate {
        normals,
        albedo,
        confidence: Some(confidence),
        depth: None,
        spatial: None,
        rows: lookup
            .outline_check()
            .map(stages::outline_row)
            .into_iter()
            .collect(),
    })
}

/// The spatial stage (or the pixels' own uncertainty without it) on the lookup's
/// estimate, with the noise and censoring measured by `sampler`; evidence is re-read by
/// bands.
fn spatial_pass(
    cap: &mut Capture,
    table: &lut::Table,
    opts: &Options,
    mask: &Mask,
    sampler: NoiseSampler,
    mut est: Estimate,
    p: &dyn Progress,
) -> Result<Estimate> {
    let (noise, censor) = sampler.finish_with_censor();
    let model = (&noise, &censor);
    // taken out of the estimate while the stage borrows both (no second copy)
    let albedo = est.albedo.take();
    let refl = spatial::info::Reflectance::new(table, &noise);
    let table = &refl;
    let info = match &opts.spatial {
        None => {
            let level = opts.lookup.shadow_level;
            let tp = (table, model, level);
            let ev = evidence(cap, tp, (&est.normals, albedo.as_ref()), None, p)?;
            own_only(noise, ev.sigma_deg(mask))
        }
        Some(sp_opts) => {
            let tp = (table, model, sp_opts.shadow_level);
            let ev = evidence(cap, tp, (&est.normals, albedo.as_ref()), None, p)?;
            let mut data = BandData {
                cap,
                tp,
                matches: (&est.normals, albedo.as_ref()),
                progress: p,
            };
            let pair = (mask, &est.normals);
            let sp = spatial::solve_with_rejection(ev, pair, &noise, sp_opts, &mut data)?;
            adopt(&mut est, noise, sp)
        }
    };
    est.albedo = albedo;
    est.spatial = Some(info);
    Ok(est)
}

/// A capture's own data read again by row bands for the spatial stage.
struct BandData<'a> {
    cap: &'a mut Capture,
    tp: (&'a Reflectance<'a>, Model<'a>, f32),
    matches: (&'a NormalMap, Option<&'a GrayImage>),
    progress: &'a dyn Progress,
}

impl spatial::OwnData for BandData<'_> {
    fn relinearise(&mut self, normals: &NormalMap, far: &[bool], ev: &mut Evidence) -> Result<()> {
        let only = Some((far, ev));
        let albedo = self.matches.1;
        evidence(self.cap, self.tp, (normals, albedo), only, self.progress).map(|_| ())
    }

    fn cost_rise(&mut self, solution: &NormalMap, moved: &[bool]) -> Result<Vec<f32>> {
        let pair = ((self.matches.0, solution), self.matches.1);
        own_cost_rise(self.cap, self.tp, pair, moved, self.progress)
    }
}

/// The evidence of the lookup's matches ([`spatial::info::from_table`]) by bands; or,
/// with `only = (far, ev)`, the costs of the `far` pixels linearised at `normals`
/// ([`spatial::info::linearise`]) written into `ev` at those pixels, reading only the
/// bands that hold them (then the evidence returned is empty).
fn evidence(
    cap: &mut Capture,
    (table, model, level): (&Reflectance, Model, f32),
    (normals, albedo): (&NormalMap, Option<&GrayImage>),
    mut only: Option<(&[bool], &mut Evidence)>,
    progress: &dyn Progress,
) -> Result<Evidence> {
    let mask = cap.mask.clone();
    let (w, h) = (mask.width, mask.height);
    let n_all = if only.is_some() { 0 } else { w * h };
    let mut ev = Evidence {
        width: w,
        height: h,
        u: vec![[0.0; 2]; n_all],
        a: vec![[0.0; 3]; n_all],
        g: Vec::new(),
    };
    let far = only.as_ref().map(|(f, _)| *f);
    let need = |r0: usize, r1: usize| match far {
        None => any_in(&mask, r0, r1),
        Some(f) => f[r0 * w..r1 * w].iter().any(|&x| x),
    };
    let what = if far.is_some() {
        "re-linearisation"
    } else {
        "evidence"
    };
    cap.pass(what, progress, need, |band, r0| {
        let n = band.height;
        let span = r0 * w..(r0 + n) * w;
        let bm = rows_of(&mask, r0, n);
        let bn = rows_of(normals, r0, n);
        let ba = albedo.map(|a| rows_of(a, r0, n));
        let lin = |f: &[bool]| {
            spatial::info::linearise(band, &bm, table, &bn, ba.as_ref(), model, level, f)
        };
        match only.as_mut() {
            None => {
                let e = spatial::info::from_table(band, &bm, table, &bn, ba.as_ref(), model, level);
                ev.u[span.clone()].copy_from_slice(&e.u);
                ev.a[span].copy_from_slice(&e.a);
            }
            Some((f, dst)) => {
                let e = lin(&f[span.clone()]);
                for (j, i) in span.enumerate().filter(|&(_, i)| f[i]) {
                    (dst.u[i], dst.a[i], dst.g[i]) = (e.u[j], e.a[j], e.g[j]);
                }
            }
        }
        Ok(())
    })?;
    Ok(ev)
}

/// For the `moved` pixels, by how much their own data's cost rises from the lookup's
/// matches to the spatial solution (`pair`; [`spatial::info::cost_increase`]), reading
/// only the bands that hold such pixels.
fn own_cost_rise(
    cap: &mut Capture,
    (table, model, level): (&Reflectance, Model, f32),
    ((matches, solution), albedo): ((&NormalMap, &NormalMap), Option<&GrayImage>),
    moved: &[bool],
    progress: &dyn Progress,
) -> Result<Vec<f32>> {
    let mask = cap.mask.clone();
    let w = mask.width;
    let mut rise = vec![0f32; moved.len()];
    let need = |r0: usize, r1: usize| moved[r0 * w..r1 * w].iter().any(|&x| x);
    cap.pass("own-data check", progress, need, |band, r0| {
        let n = band.height;
        let span = r0 * w..(r0 + n) * w;
        let bm = rows_of(&mask, r0, n);
        let pair = (&rows_of(matches, r0, n), &rows_of(solution, r0, n));
        let ba = albedo.map(|a| rows_of(a, r0, n));
        let (ba, sel) = (ba.as_ref(), &moved[span.clone()]);
        let r = spatial::info::cost_increase(band, &bm, table, pair, ba, model, level, sel);
        rise[span].copy_from_slice(&r);
        Ok(())
    })?;
    Ok(rise)
}

/// The Lambertian solve by bands (after a pass that measures the black level when
/// [`Options::black_level`] is `Auto`), then the spatial stage (its evidence needs the
/// normals and the noise only, not the images).
fn lambertian_stages(
    st: &mut Stages,
    cap: &mut Capture,
    lights: &Lights,
    opts: &Options,
    preview: (&mut Vec<f32>, usize),
) -> Result<Estimate> {
    let mask = cap.mask.clone();
    mask.check_not_empty("mask")?;
    let (w, h, k) = (mask.width, mask.height, cap.ds.header.k());
    let mut lo = opts.lambertian.clone();
    let (mut est, sampler, decision) = st.run("Lambertian photometric stereo", |p| {
        let d = black_level(cap, lights, opts, &mask, p)?;
        stages::note_black_level(&d, p);
        lo.black_level = d.level;
        // the noise of the samples as the solve sees them, the level taken off
        let mut sampler = NoiseSampler::new(&mask, k).above(d.level);
        let est = lambertian_pass(cap, lights, &lo, &mask, &mut sampler, preview, p)?;
        Ok((est, sampler, d))
    })?;
    est.rows.push(stages::black_level_row(&decision));
    st.run(super::spatial_stage::name(opts), |_| {
        let noise = sampler.finish();
        // from_lambertian takes the images' size from the stack, not their samples
        let size = ImageStack {
            width: w,
            height: h,
            k,
            data: Vec::new(),
            names: Vec::new(),
        };
        let albedo = est
            .albedo
            .clone()
            .unwrap_or_else(|| GrayImage::filled(w, h, 1.0));
        let ev =
            spatial::info::from_lambertian(&size, &mask, lights, &est.normals, &albedo, &noise);
        let info: SpatialInfo = match &opts.spatial {
            None => own_only(noise, ev.sigma_deg(&mask)),
            Some(sp_opts) => {
                let sp = spatial::solve(&ev, &mask, sp_opts)?;
                adopt(&mut est, noise, sp)
            }
        };
        est.spatial = Some(info);
        Ok(est)
    })
}

/// The black level of [`Options::black_level`] in the capture's units (its full scale is
/// the image scale): for `Auto`, measured by one pass over the bands that hold mask
/// pixels ([`lambertian::BlackLevelSums`], the estimate of the whole stack), and when it
/// is taken off, refined by one more pass per round ([`lambertian::measure_black_level`]),
/// as the whole stack's solve does it.
fn black_level(
    cap: &mut Capture,
    lights: &Lights,
    opts: &Options,
    mask: &Mask,
    p: &dyn Progress,
) -> Result<lambertian::BlackLevelDecision> {
    use lambertian::BlackLevelDecision as Decision;
    opts.black_level.check()?;
    let (base, full_scale) = (opts.lambertian.black_level, cap.scale.unwrap_or(1.0));
    if let Some(d) = Decision::without_measuring(opts.black_level, base, full_scale) {
        return Ok(d);
    }
    let measure = |level: f32| {
        let lo = lambertian::Options {
            black_level: level,
            ..opts.lambertian.clone()
        };
        let mut sums = lambertian::BlackLevelSums::new(lights, &lo.for_black_level())?;
        let need = |r0: usize, r1: usize| any_in(mask, r0, r1);
        cap.pass("black level", p, need, |band, r0| {
            sums.add(band, &rows_of(mask, r0, band.height))
        })?;
        Ok((sums.finish(), ()))
    };
    Ok(lambertian::measure_black_level(base, full_scale, measure)?.0)
}

/// The Lambertian solve with `lo` band by band into H×W maps; each band also feeds the
/// noise `sampler` and the report's decimated `preview`.
fn lambertian_pass(
    cap: &mut Capture,
    lights: &Lights,
    lo: &lambertian::Options,
    mask: &Mask,
    sampler: &mut NoiseSampler,
    preview: (&mut Vec<f32>, usize),
    p: &dyn Progress,
) -> Result<Estimate> {
    let (w, h) = (mask.width, mask.height);
    let mut normals = NormalMap::filled(w, h, [0.0; 3]);
    let mut albedo = GrayImage::filled(w, h, 0.0);
    solve_bands(
        cap,
        "Lambertian",
        mask,
        sampler,
        preview,
        p,
        |band, bm, r0| {
            let out = lambertian::solve(band, bm, lights, lo)?;
            put_rows(&mut normals, &out.normals, r0);
            put_rows(&mut albedo, &out.albedo, r0);
            Ok(())
        },
    )?;
    Ok(Estimate {
        normals,
        albedo: Some(albedo),
        confidence: None,
        depth: None,
        spatial: None,
        rows: Vec::new(),
    })
}

/// One pass over every band (`what` on `p`): each band feeds the noise `sampler` and the
/// report's decimated `preview`; `solve` gets the bands that hold mask pixels, with the
/// mask's rows of the band and the band's first row.
fn solve_bands(
    cap: &mut Capture,
    what: &str,
    mask: &Mask,
    sampler: &mut NoiseSampler,
    (buf, step): (&mut Vec<f32>, usize),
    p: &dyn Progress,
    mut solve: impl FnMut(&ImageStack, &Mask, usize) -> Result<()>,
) -> Result<()> {
    cap.pass(
        what,
        p,
        |_, _| true,
        |band, r0| {
            sampler.feed(band, r0);
            decimate(buf, band, r0, step);
            let bm = rows_of(mask, r0, band.height);
            if bm.count() == 0 {
                return Ok(());
            }
            solve(band, &bm, r0)
        },
    )
}

/// The images' file names (as [`ImageStack::names`]), in light order: what a light file
/// naming its images (`.lp`) is matched against.
fn file_names(ds: &DatasetBands) -> Vec<String> {
    (ds.header.files.iter())
        .map(|f| {
            f.file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect()
}
