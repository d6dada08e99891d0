//! `photostereo run`: the whole job on a dataset directory — normals (lookup table from a
//! calibration sphere, or Lambertian with known lights), integration with an integrator
//! chosen from the mask, mesh, and a self-contained `report.html`.

use std::path::PathBuf;

use anyhow::Result;
use photostereo::{integrate, pipeline};

use crate::progress::Bar;
use crate::Global;

/// Arguments of `photostereo run`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    photostereo run --sphere data/sphere data/vase -o out/vase\n  \
    photostereo run --chrome real/chrome real/buddha -o out/buddha\n  \
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
    #[arg(long, conflicts_with_all = ["lambertian", "chrome"])]
    pub sphere: Option<PathBuf>,
    /// Lambertian photometric stereo with known lights (from the dataset's
    /// light_directions.txt, --lights or --chrome).
    #[arg(long)]
    pub lambertian: bool,
    /// Light directions file (K lines `x y z`), instead of the dataset's.
    #[arg(long, requires = "lambertian", conflicts_with = "chrome")]
    pub lights: Option<PathBuf>,
    /// Chrome sphere dataset under the same lights: calibrate the light directions from
    /// its highlights (implies --lambertian). Writes lights.txt and chrome_overlay.png.
    #[arg(long)]
    pub chrome: Option<PathBuf>,
    /// Remove interreflections (Nayar–Ikeuchi–Kanade iteration; Lambertian only).
    #[arg(long)]
    pub interreflections: bool,
    /// Facet size in pixels for --interreflections (1 = per pixel; larger is faster).
    /// Default: the smallest block (at least 2) giving at most 4096 facet cells.
    #[arg(long, requires = "interreflections")]
    pub block: Option<usize>,
    /// Multiply the target images by this factor to bring them to radiance units, so
    /// that the albedo is absolute (interreflection removal depends on it). Default:
    /// with --interreflections, 65535/scale from the dataset's meta.json if it has one;
    /// else 1 (calibrated light_intensities.txt do the same job).
    #[arg(long, allow_negative_numbers = true)]
    pub image_scale: Option<f32>,
    /// Integrator: path, fc, fc-reflect, dct, lsq (default: dct on a full rectangle,
    /// lsq with a mask).
    #[arg(long)]
    pub method: Option<String>,
    /// Mask file instead of the dataset's mask.png.
    #[arg(long)]
    pub mask: Option<PathBuf>,
    /// Keep every pixel's own normal: no spatial stage (by default pixels whose data say
    /// little about their normal take it from their neighbours; see `photostereo::spatial`).
    /// normals_sigma.npy is written either way; own_share.npy only with the stage.
    #[arg(long)]
    pub no_spatial: bool,
    /// No occluding-contour prior in the spatial stage: by default the mask's edge is taken
    /// as the object's silhouette, where the normal is perpendicular to the view and to the
    /// edge (Ikeuchi & Horn 1981). Turn it off where the mask's edge is not a silhouette:
    /// the object rests on a support, the mask cuts through a surface, or a concave fold.
    /// (Edge pixels on the image border never count as contour.)
    #[arg(long)]
    pub no_contour: bool,
}

/// Run the subcommand.
pub fn run(mut args: Args, global: Global) -> Result<()> {
    crate::check_output_dir(&args.out)?;
    args.lambertian |= args.chrome.is_some();
    let inputs = pipeline::Inputs {
        target: args.target.clone(),
        sphere: args.sphere.clone(),
        calibration: None,
        lambertian: args.lambertian,
        lights: args.lights.clone(),
        chrome: args.chrome.clone(),
        mask: args.mask.clone(),
        image_scale: args.image_scale,
    };
    let opts = pipeline::Options {
        method: args
            .method
            .as_deref()
            .map(integrate::Method::from_name)
            .transpose()?,
        interreflections: args.interreflections,
        ..Default::default()
    };
    let opts = pipeline::Options {
        spatial: opts.spatial.filter(|_| !args.no_spatial),
        ..opts
    };
    let mut opts = opts;
    if let Some(sp) = opts.spatial.as_mut().filter(|_| args.no_contour) {
        sp.contour_sigma = None;
    }
    opts.nik.radiosity.block = args.block.unwrap_or(0);
    let done = pipeline::run(&inputs, &args.out, &opts, &Bar::new(global.quiet))?;
    if !global.quiet {
        for (k, v) in &done.output.figures {
            println!("{k:>36}: {v}");
        }
        println!("report: {}", done.report.display());
    }
    Ok(())
}
