//! `photostereo run`: the whole job on a dataset directory — normals (lookup table from a
//! calibration sphere, or Lambertian with known lights), integration with an integrator
//! chosen from the mask, mesh, and a self-contained `report.html`.

pub mod outputs;
pub mod pipeline;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use photostereo::image::{Lights, Mask};
use photostereo::{integrate, io};

use crate::Global;
use pipeline::{Job, Normals, Truth};

/// Arguments of `photostereo run`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    photostereo run --sphere data/sphere data/vase -o out/vase\n  \
    photostereo run --lambertian --chrome real/chrome real/buddha -o out/buddha\n  \
    photostereo run --lambertian --interreflections data/bowl -o out/bowl")]
pub struct Args {
    /// Target dataset directory (DiLiGenT layout: images, optional filenames.txt,
    /// light_directions.txt, light_intensities.txt, mask.png).
    pub target: PathBuf,
    /// Output directory (created).
    #[arg(short, long)]
    pub out: PathBuf,
    /// Calibration sphere dataset of the same material under the same lights:
    /// calibration-based photometric stereo (lookup table).
    #[arg(long, conflicts_with = "lambertian")]
    pub sphere: Option<PathBuf>,
    /// Lambertian photometric stereo with known lights (from the dataset's
    /// light_directions.txt, --lights or --chrome).
    #[arg(long)]
    pub lambertian: bool,
    /// Light directions file (K lines `x y z`), instead of the dataset's.
    #[arg(long, requires = "lambertian", conflicts_with = "chrome")]
    pub lights: Option<PathBuf>,
    /// Chrome sphere dataset under the same lights: calibrate the light directions from
    /// its highlights.
    #[arg(long, requires = "lambertian")]
    pub chrome: Option<PathBuf>,
    /// Remove interreflections (Nayar–Ikeuchi–Kanade iteration; Lambertian only).
    #[arg(long, requires = "lambertian")]
    pub interreflections: bool,
    /// Multiply the target images by this factor to bring them to radiance units, so
    /// that the albedo is absolute (interreflection removal depends on it). Default:
    /// with --interreflections, 65535/scale from the dataset's meta.json if it has one;
    /// else 1 (calibrated light_intensities.txt do the same job).
    #[arg(long, requires = "lambertian", allow_negative_numbers = true)]
    pub image_scale: Option<f32>,
    /// Integrator: path, fc, fc-reflect, dct, lsq (default: dct on a full rectangle,
    /// lsq with a mask).
    #[arg(long)]
    pub method: Option<String>,
    /// Mask file instead of the dataset's mask.png.
    #[arg(long)]
    pub mask: Option<PathBuf>,
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> Result<()> {
    if args.sphere.is_none() && !args.lambertian {
        bail!("say how to get normals: --sphere SPHERE_DIR (calibration-based) or --lambertian");
    }
    let t0 = Instant::now();
    let target = load_target(&args)?;
    let load_time = t0.elapsed().as_secs_f64();
    let mask = target
        .mask
        .clone()
        .unwrap_or_else(|| Mask::full(target.stack.width, target.stack.height));
    let method = args
        .method
        .as_deref()
        .map(integrate::Method::from_name)
        .transpose()?;
    let mut extra = vec![("load".to_string(), load_time)];
    let normals = match &args.sphere {
        Some(dir) => {
            let sphere = io::load_dataset(dir, &io::LoadOptions::default())?;
            Normals::Lookup {
                sphere: sphere.stack,
                sphere_mask: sphere.mask,
            }
        }
        None => {
            let t = Instant::now();
            let lights = lights(&args, target.lights.clone(), global)?;
            extra.push(("lights".to_string(), t.elapsed().as_secs_f64()));
            Normals::Lambertian {
                lights,
                interreflections: args.interreflections,
            }
        }
    };
    let job = Job {
        target: target.stack,
        mask,
        normals,
        method,
        truth: ground_truth(&args.target)?,
    };
    let products = pipeline::run(&job, global.quiet)?;
    let title = dataset_name(&args.target);
    let subtitle = subtitle(&args);
    let report = outputs::write_all(&args.out, &title, &subtitle, &job, &products, &extra)?;
    if !global.quiet {
        for (k, v) in &products.figures {
            println!("{k:>36}: {v}");
        }
        println!("report: {}", report.display());
    }
    Ok(())
}

/// The target dataset; with `--lambertian`, brought to radiance units by `--image-scale`
/// (or, for interreflection removal, by the factor of its meta.json).
fn load_target(args: &Args) -> Result<io::Dataset> {
    let opts = io::LoadOptions {
        mask_path: args.mask.clone(),
        ..Default::default()
    };
    let mut target = io::load_dataset(&args.target, &opts)?;
    if args.lambertian {
        let scale = crate::interreflect::radiance_scale(
            &args.target,
            args.image_scale,
            args.interreflections,
        )?;
        target.stack.data.iter_mut().for_each(|v| *v *= scale);
    }
    Ok(target)
}

/// Light directions: --lights file, --chrome calibration, or the dataset's own.
fn lights(args: &Args, from_dataset: Option<Lights>, global: Global) -> Result<Lights> {
    if let Some(file) = &args.lights {
        return Ok(io::read_lights(file)?);
    }
    if let Some(dir) = &args.chrome {
        let chrome = io::load_dataset(dir, &io::LoadOptions::default())?;
        let det = photostereo::sphere::detect(
            &chrome.stack,
            &photostereo::sphere::DetectOptions {
                // a mirror sphere's rim barely shows on a dark background: its
                // silhouette mask, when given, is the better outline
                mask_outline: chrome.mask.is_some(),
                mask: chrome.mask.clone(),
                ..Default::default()
            },
        )
        .with_context(|| format!("finding the chrome sphere in {}", dir.display()))?;
        let (lights, _) = photostereo::lightcal::from_chrome_sphere(
            &chrome.stack,
            &det.circle,
            &Default::default(),
        )
        .with_context(|| format!("calibrating the lights from {}", dir.display()))?;
        if !global.quiet {
            eprintln!("lights calibrated from the chrome sphere {}", dir.display());
        }
        return Ok(lights);
    }
    from_dataset.with_context(|| {
        format!(
            "{}: no light_directions.txt; give --lights FILE or --chrome CHROME_DIR",
            args.target.display()
        )
    })
}

/// `normal_gt.npy` and `depth_gt.npy` of the target directory, when present.
fn ground_truth(dir: &Path) -> Result<Truth> {
    let n = dir.join("normal_gt.npy");
    let d = dir.join("depth_gt.npy");
    Ok(Truth {
        normals: n.is_file().then(|| io::read_normals_npy(&n)).transpose()?,
        depth: d.is_file().then(|| io::read_gray_npy(&d)).transpose()?,
    })
}

fn dataset_name(dir: &Path) -> String {
    dir.canonicalize()
        .ok()
        .as_deref()
        .unwrap_or(dir)
        .file_name()
        .map_or_else(
            || dir.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
}

fn subtitle(args: &Args) -> String {
    match (&args.sphere, &args.chrome, args.interreflections) {
        (Some(s), _, _) => format!(
            "calibration-based photometric stereo, sphere {}",
            s.display()
        ),
        (None, Some(c), ir) => format!(
            "Lambertian photometric stereo, lights from the chrome sphere {}{}",
            c.display(),
            if ir { ", interreflections removed" } else { "" }
        ),
        (None, None, ir) => format!(
            "Lambertian photometric stereo{}",
            if ir { ", interreflections removed" } else { "" }
        ),
    }
}
