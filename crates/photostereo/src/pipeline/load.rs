//! The whole job from paths, as `photostereo run` does it: load the target (and the
//! sphere, the lights, the ground truth), [`super::solve`], [`super::write_outputs`].

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{Calibration, Job, Normals, Options, Output, RunSummary, Titles, Truth};
use crate::error::{Error, Result, Setting};
use crate::image::{Lights, Mask};
use crate::progress::Progress;
use crate::sphere::checks::MirrorCheck;
use crate::warning::{Warning, WarningCode};
use crate::{io, lambertian, lightcal, sphere};

/// The files of a run: the target dataset and where its normals come from. Exactly one
/// of `sphere`, `calibration` and `lambertian` says how to get the normals.
#[derive(Clone, Debug, Default)]
pub struct Inputs {
    /// Target dataset directory (DiLiGenT layout, see [`crate::io`]).
    pub target: PathBuf,
    /// Calibration sphere dataset of the same material under the same lights: the
    /// lookup table is built from it (its `mask.png`, if any, restricts the search).
    pub sphere: Option<PathBuf>,
    /// A calibration made beforehand (e.g. once for a batch of targets).
    pub calibration: Option<Calibration>,
    /// Lambertian photometric stereo with known lights: `lights`, else `chrome`, else the
    /// dataset's `light_directions.txt`.
    pub lambertian: bool,
    /// Light file instead of the dataset's (Lambertian): K lines `x y z`, an RTI `.lp`
    /// (matched to the images by file name) or an AliceVision `lights.json`.
    pub lights: Option<PathBuf>,
    /// Chrome sphere dataset under the same lights: lights from its highlights (Lambertian).
    pub chrome: Option<PathBuf>,
    /// Mask file instead of the dataset's `mask.png`.
    pub mask: Option<PathBuf>,
    /// Factor that brings the images to radiance units (Lambertian); `None` = with
    /// interreflection removal 65535/scale of the dataset's `meta.json` if it has one,
    /// else 1 ([`radiance_scale`]).
    pub image_scale: Option<f32>,
    /// Response curve of the images of the target, the sphere and the chrome sphere
    /// (default: sRGB for JPEG files, linear otherwise; see [`io::Response`]).
    pub response: io::Response,
}

/// A loaded job, with its titles and the timings of the loading.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The job, ready for [`super::solve`].
    pub job: Job,
    /// Title (the target's directory name) and subtitle (the method).
    pub titles: Titles,
    /// (stage, seconds) of the loading: `load`, and `lights` for a Lambertian job.
    pub stages: Vec<(String, f64)>,
    /// Whether the images' radiance scale is known (given, or from `meta.json` with
    /// interreflection removal; [`scale_is_known`]); [`run`](fn@super::run) passes it on as
    /// [`crate::interreflect::NikOptions::scale_known`].
    pub scale_known: bool,
    /// The factor the images were multiplied by and where it came from (Lambertian).
    pub image_scale: Option<(f32, &'static str)>,
    /// The chrome sphere the lights came from.
    pub chrome: Option<sphere::Detection>,
    /// Warnings about the inputs found while loading (a "chrome" sphere without mirror
    /// highlights); [`run`](fn@super::run) adds them to the output's.
    pub warnings: Vec<Warning>,
    /// The response curve the target's images were linearised with (resolved).
    pub response: io::Response,
}

/// A finished run.
#[derive(Clone, Debug)]
pub struct Run {
    /// The products, figures and timings of the pipeline.
    pub output: Output,
    /// The path of `report.html`.
    pub report: PathBuf,
    /// What `run.json` holds.
    pub summary: RunSummary,
}

impl Inputs {
    /// How the target's folder is read (with [`Inputs::mask`] and the response), and how
    /// the other folders (sphere, chrome) are (with the response only).
    pub(super) fn load_options(&self) -> (io::LoadOptions, io::LoadOptions) {
        let others = io::LoadOptions {
            response: self.response,
            ..Default::default()
        };
        let target = io::LoadOptions {
            mask_path: self.mask.clone(),
            ..others.clone()
        };
        (target, others)
    }
}

/// Load the job of `inputs`: the target (brought to radiance units for a Lambertian
/// job), the sphere or the lights, and `normal_gt.npy` / `depth_gt.npy` when present.
pub fn load(inputs: &Inputs, opts: &Options, progress: &dyn Progress) -> Result<Loaded> {
    check(inputs, opts)?;
    let t0 = Instant::now();
    let (load_opts, others) = inputs.load_options();
    let mut target = io::load_dataset(&inputs.target, &load_opts)?;
    let scale_known = inputs.lambertian
        && scale_is_known(&inputs.target, inputs.image_scale, opts.interreflections)?;
    let mut image_scale = None;
    if inputs.lambertian {
        let scale = radiance_scale(&inputs.target, inputs.image_scale, opts.interreflections)?;
        target.stack.data.iter_mut().for_each(|v| *v *= scale);
        let from = match (inputs.image_scale.is_some(), scale_known) {
            (true, _) => "given",
            (false, true) => "from meta.json (65535 / scale)",
            (false, false) => "not given: images taken as radiance units",
        };
        image_scale = Some((scale, from));
    }
    let mut stages = vec![("load".to_string(), t0.elapsed().as_secs_f64())];
    let mut mask = target
        .mask
        .clone()
        .unwrap_or_else(|| Mask::full(target.stack.width, target.stack.height));
    let mut warnings: Vec<Warning> = leave_out_sphere(inputs, opts, &mut mask)?
        .into_iter()
        .collect();
    let source = Source {
        k: target.stack.k,
        lights: target.lights.clone(),
        names: &target.stack.names,
        others: &others,
    };
    let (normals, chrome) = normals_of(inputs, &source, progress, &mut stages, &mut warnings)?;
    let response = target.response;
    let (tn, td) = io::read_ground_truth(&inputs.target)?;
    let job = Job {
        target: target.stack,
        mask,
        normals,
        truth: Truth {
            normals: tn,
            depth: td,
        },
    };
    let titles = Titles {
        title: io::dataset_name(&inputs.target),
        subtitle: subtitle(inputs, opts),
    };
    Ok(Loaded {
        job,
        titles,
        stages,
        scale_known,
        image_scale,
        chrome,
        warnings,
        response,
    })
}

/// What [`normals_of`] needs of the target: its number of images, its own light
/// directions and image file names, and how the other folders are read.
pub(super) struct Source<'a> {
    pub k: usize,
    pub lights: Option<Lights>,
    pub names: &'a [String],
    pub others: &'a io::LoadOptions,
}

/// How a run gets its normals: a calibration given, the sphere's table (its folder loaded
/// whole with `source.others`: it must have the target's K images) or the light
/// directions (timed as the `lights` stage, pushed on `stages`; a chrome sphere's
/// detection is returned for the report, its mirror check's warning pushed on `warnings`).
pub(super) fn normals_of(
    inputs: &Inputs,
    source: &Source<'_>,
    progress: &dyn Progress,
    stages: &mut Vec<(String, f64)>,
    warnings: &mut Vec<Warning>,
) -> Result<(Normals, Option<sphere::Detection>)> {
    if let Some(cal) = &inputs.calibration {
        return Ok((Normals::Calibrated(Box::new(cal.clone())), None));
    }
    if let Some(dir) = &inputs.sphere {
        let sphere = io::load_dataset(dir, source.others)?;
        if sphere.stack.k != source.k {
            return Err(k_mismatch(dir, sphere.stack.k, &inputs.target, source.k));
        }
        let normals = Normals::Lookup {
            sphere: sphere.stack,
            sphere_mask: sphere.mask,
        };
        return Ok((normals, None));
    }
    let t = Instant::now();
    let (lights, det) = lights(inputs, source.lights.clone(), source.names, progress)?;
    let mut chrome = None;
    if let Some((det, mirror)) = det {
        let code = WarningCode::NotAMirror;
        warnings.extend(mirror.warning().map(|m| Warning::new(code, m)));
        chrome = Some(det);
    }
    stages.push(("lights".to_string(), t.elapsed().as_secs_f64()));
    Ok((Normals::Lambertian { lights }, chrome))
}

/// The sphere folder `dir` has `sk` images where the target has `k`.
fn k_mismatch(dir: &Path, sk: usize, target: &Path, k: usize) -> Error {
    Error::invalid(
        format!(
            "the sphere {} has {sk} images, the target {} has {k}",
            dir.display(),
            target.display(),
        ),
        "image the sphere under the same lights as the target: one image per light, in \
         the same order (filenames.txt sets the order)",
    )
}

/// Margin (pixels) around a given circle inside which target pixels count as the
/// sphere's (its rim is blurred over a pixel or two).
const SPHERE_MARGIN_PX: f64 = 2.0;

/// Whether the sphere's images are the target's: the classic setup, one folder with the
/// sphere in a corner of the images and `mask.png` marking the target.
pub(super) fn sphere_is_target(inputs: &Inputs) -> bool {
    let Some(dir) = &inputs.sphere else {
        return false;
    };
    match (dir.canonicalize(), inputs.target.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => *dir == inputs.target,
    }
}

/// When the sphere shares the target's images ([`sphere_is_target`]): the pixels where
/// the sphere is searched (the given circle widened by 2 px, else the search window
/// within the given sphere mask, else that mask) are the sphere's, and are left out of
/// the target's `mask`; returns the warning that says so when the mask held any.
/// Without a circle, window or sphere mask nothing is left out.
///
/// Errors: [`Error::SizeMismatch`] for a sphere mask of another size than the images.
pub(super) fn leave_out_sphere(
    inputs: &Inputs,
    opts: &Options,
    mask: &mut Mask,
) -> Result<Option<Warning>> {
    if !sphere_is_target(inputs) {
        return Ok(None);
    }
    let d = &opts.detect;
    let (w, h) = (mask.width, mask.height);
    let inside_region = |r: usize, c: usize| {
        d.region
            .is_none_or(|(x, y, rw, rh)| (x..x + rw).contains(&c) && (y..y + rh).contains(&r))
    };
    let sphere = match (&d.circle, &d.region, &d.mask) {
        (Some(circle), _, _) => {
            let r = circle.radius + SPHERE_MARGIN_PX;
            Mask::from_fn(w, h, |row, col| {
                let (x, y) = (col as f64 + 0.5 - circle.cx, row as f64 + 0.5 - circle.cy);
                x * x + y * y <= r * r
            })
        }
        // nothing says where the sphere is: the folder's mask.png is searched (the rule
        // of a sphere folder), and a target given as its own sphere is warned about by
        // the shape check ("this is not a sphere")
        (None, None, None) => return Ok(None),
        (None, _, Some(m)) => {
            m.check_size(w, h, "sphere mask")?;
            Mask::from_fn(w, h, |r, c| *m.get(r, c) && inside_region(r, c))
        }
        (None, Some(_), None) => Mask::from_fn(w, h, inside_region),
    };
    let mut dropped = 0usize;
    for (t, s) in mask.data.iter_mut().zip(&sphere.data) {
        if *t && *s {
            *t = false;
            dropped += 1;
        }
    }
    Ok((dropped > 0).then(|| {
        let message = format!(
            "{dropped} pixels of the target's mask lie where the calibration sphere is searched \
             (the sphere shares the target's images): they are left out of the target. Keep the \
             sphere's search window (or mask) off the target"
        );
        Warning::new(WarningCode::SphereLeftOutOfMask, message)
    }))
}

pub(super) fn check(inputs: &Inputs, opts: &Options) -> Result<()> {
    if let Some(c) = &opts.curvature {
        c.check()?;
    }
    // before any pixel is read
    opts.black_level.check()?;
    let ways = usize::from(inputs.sphere.is_some())
        + usize::from(inputs.calibration.is_some())
        + usize::from(inputs.lambertian);
    if ways != 1 {
        return Err(Error::setting(
            Setting::Method,
            "say how to get normals",
            "give a calibration sphere of the target's material (or its table), or ask for \
             Lambertian photometric stereo: one of them",
        ));
    }
    if !inputs.lambertian && (inputs.lights.is_some() || inputs.chrome.is_some()) {
        return Err(Error::setting(
            Setting::Lambertian,
            "light directions or a chrome sphere",
            "they are for Lambertian photometric stereo, which was not asked for",
        ));
    }
    if !inputs.lambertian && (opts.interreflections || inputs.image_scale.is_some()) {
        return Err(Error::setting(
            Setting::Lambertian,
            "interreflection removal and the image scale",
            "they are for Lambertian photometric stereo, which was not asked for",
        ));
    }
    // a level given or refused is for the Lambertian solve (interreflection removal
    // included); a table carries the sphere's own
    let explicit = opts.black_level != lambertian::BlackLevelChoice::Auto;
    if explicit && !inputs.lambertian {
        return Err(Error::setting(
            Setting::Lambertian,
            "a black level to take off (or none)",
            "it is for Lambertian photometric stereo: leave it at auto (a lookup table \
             carries the sphere's own black level)",
        ));
    }
    Ok(())
}

/// The factor that brings a dataset's images to radiance units: `given` when set, else
/// (with `use_meta`) 65535/scale from its `meta.json` (renders that store radiance ×
/// scale in 16-bit PNGs), else 1. Interreflection removal needs it: the bounced light
/// depends on the absolute albedo, which photometric stereo only knows up to this factor.
pub fn radiance_scale(dir: &Path, given: Option<f32>, use_meta: bool) -> Result<f32> {
    let scale = match given {
        Some(s) => s,
        None if use_meta => io::read_meta_scale(dir)?.unwrap_or(1.0),
        None => 1.0,
    };
    if !(scale.is_finite() && scale > 0.0) {
        return Err(Error::setting(
            Setting::ImageScale,
            format!("image scale {scale}"),
            "use a finite factor > 0",
        ));
    }
    Ok(scale)
}

/// Whether [`radiance_scale`] knows the factor (`given`, or with `use_meta` a `meta.json`
/// scale) rather than assuming 1: [`crate::interreflect::NikOptions::scale_known`].
pub fn scale_is_known(dir: &Path, given: Option<f32>, use_meta: bool) -> Result<bool> {
    Ok(given.is_some() || (use_meta && io::read_meta_scale(dir)?.is_some()))
}

/// Light directions for `k` images: the `lights` file, the `chrome` calibration (with the
/// sphere's detection and its mirror check), or the dataset's own.
pub(super) fn lights(
    inputs: &Inputs,
    from_dataset: Option<Lights>,
    names: &[String],
    progress: &dyn Progress,
) -> Result<(Lights, Option<(sphere::Detection, MirrorCheck)>)> {
    let k = names.len();
    if let Some(file) = &inputs.lights {
        if !file.is_file() {
            return Err(Error::setting(
                Setting::LightsFile,
                format!("light directions {}: no such file", file.display()),
                format!(
                    "give a text file of {k} lines `x y z` (one light direction per image, in \
                     image order) or an RTI .lp file, or none to use the dataset's \
                     light_directions.txt"
                ),
            ));
        }
        // an .lp file is matched to the images by file name, other files by order
        let lights = io::read_lights_for(file, names)?;
        return Ok((lights, None));
    }
    if let Some(dir) = &inputs.chrome {
        let (lights, det, mirror) = chrome_lights(dir, inputs.response)?;
        progress.note(&format!(
            "lights calibrated from the chrome sphere {}",
            dir.display()
        ));
        return Ok((lights, Some((det, mirror))));
    }
    from_dataset.map(|l| (l, None)).ok_or_else(|| {
        Error::setting(
            Setting::Lights,
            format!("{}: no light_directions.txt", inputs.target.display()),
            "give a file of light directions, or a chrome sphere's images to calibrate them",
        )
    })
}

/// Lights from the highlights of a chrome sphere dataset, the sphere's detection, and
/// whether its highlights look like a mirror's.
fn chrome_lights(
    dir: &Path,
    response: io::Response,
) -> Result<(Lights, sphere::Detection, MirrorCheck)> {
    let load = io::LoadOptions {
        response,
        ..Default::default()
    };
    let chrome = io::load_dataset(dir, &load)?;
    let det = sphere::detect(
        &chrome.stack,
        &sphere::DetectOptions {
            // a mirror sphere's rim barely shows on a dark background: its
            // silhouette mask, when given, is the better outline
            mask_outline: chrome.mask.is_some(),
            mask: chrome.mask.clone(),
            ..Default::default()
        },
    )
    .map_err(|e| e.context(format!("finding the chrome sphere in {}", dir.display())))?;
    let (lights, _) = lightcal::from_chrome_sphere(&chrome.stack, &det.circle, &Default::default())
        .map_err(|e| e.context(format!("calibrating the lights from {}", dir.display())))?;
    let mirror = sphere::checks::check_mirror(&chrome.stack, &det.circle);
    Ok((lights, det, mirror))
}

pub(super) fn subtitle(inputs: &Inputs, opts: &Options) -> String {
    let ir = if opts.interreflections {
        ", interreflections removed"
    } else {
        ""
    };
    match (&inputs.sphere, &inputs.calibration, &inputs.chrome) {
        (Some(s), _, _) => format!(
            "calibration-based photometric stereo, sphere {}",
            s.display()
        ),
        (None, Some(_), _) => "calibration-based photometric stereo, table given".to_string(),
        (None, None, Some(c)) => format!(
            "Lambertian photometric stereo, lights from the chrome sphere {}{ir}",
            c.display()
        ),
        (None, None, None) => format!("Lambertian photometric stereo{ir}"),
    }
}
