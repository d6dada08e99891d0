//! `photostereo run`: the whole job on a dataset directory — normals (lookup table from a
//! calibration sphere, or Lambertian with known lights), integration with an integrator
//! chosen from the mask, mesh, and a self-contained `report.html`.

use std::path::PathBuf;

use anyhow::Result;
use photostereo::sphere::Circle;
use photostereo::{integrate, io, pipeline};

use crate::progress::Bar;
use crate::Global;

/// Arguments of `photostereo run`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    photostereo run --sphere data/vase/sphere data/vase -o out/vase\n  \
    photostereo run --lut sphere.lut --normalize data/vase -o out/vase_lut\n  \
    photostereo run --sphere data/vase/sphere --circle 102,102,100 data/vase -o out/vase_circle\n  \
    photostereo run --chrome data/chrome data/matte_ball -o out/matte_ball\n  \
    photostereo run --lambertian --interreflections data/vgroove -o out/vgroove_run\n\n\
    Sphere and target in the same images (one folder, the sphere in a corner, mask.png marking \
    the target): give the folder as both --sphere and TARGET, with --sphere-region around the \
    sphere (or --sphere-mask, or --circle); the folder's mask.png is the target's.")]
pub struct Args {
    /// Target dataset directory (DiLiGenT layout: images, optional filenames.txt,
    /// light_directions.txt, light_intensities.txt, mask.png).
    pub target: PathBuf,
    /// Output directory (created).
    #[arg(short, long = "output", visible_alias = "out", value_name = "OUT_DIR")]
    pub out: PathBuf,
    /// Calibration sphere dataset of the same material under the same lights:
    /// calibration-based photometric stereo (lookup table).
    #[arg(long, conflicts_with_all = ["lambertian", "chrome", "lut"])]
    pub sphere: Option<PathBuf>,
    /// Use this circle for the sphere instead of finding it (as `calibrate --circle`):
    /// centre x (along columns), centre y (along rows) and radius, in pixels.
    #[arg(long, value_name = "CX,CY,R", requires = "sphere", value_parser = crate::lights::parse_circle)]
    pub circle: Option<Circle>,
    /// Search the sphere only in this window of its images (as `calibrate
    /// --sphere-region`): left column, top row, width, height. The sphere folder's
    /// mask.png is then not used for the search. Sphere and target in the same images:
    /// give the target folder as --sphere and this window around the sphere; mask.png
    /// marks the target, and target pixels inside the window are left out (a warning
    /// says how many).
    #[arg(long, value_name = "X,Y,W,H", requires = "sphere", value_parser = crate::lights::parse_region)]
    pub sphere_region: Option<(usize, usize, usize, usize)>,
    /// Search the sphere only inside this mask (PNG/TIFF/.npy, non-zero = sphere) instead
    /// of the sphere folder's mask.png (as `calibrate --sphere-mask`).
    #[arg(long, value_name = "MASK", requires = "sphere")]
    pub sphere_mask: Option<PathBuf>,
    /// A lookup table from `photostereo calibrate` instead of a sphere folder.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["lambertian", "chrome"])]
    pub lut: Option<PathBuf>,
    /// For albedo changes (the target's albedo varies or differs from the sphere's), as
    /// `normals --normalize`: brightness-normalised matching, or on a specular table
    /// (a shiny sphere) the diffuse + specular fit; albedo.npy is then relative to the
    /// sphere's.
    #[arg(long, conflicts_with = "lambertian")]
    pub normalize: bool,
    /// With --normalize on a specular table: brightness-normalised matching all the
    /// same (no diffuse/specular split), as `normals --no-split`.
    #[arg(long, requires = "normalize")]
    pub no_split: bool,
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
    // Lambertian only (checked in `run`: --chrome implies --lambertian); with
    // --interreflections `auto` measures nothing (the library's Options::black_level)
    #[arg(long, value_name = "LEVEL", help = crate::black_level::RUN_HELP)]
    pub black_level: Option<String>,
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
    /// Integrator: path, fc, fc-reflect, dct, lsq, bini (default: dct on a full
    /// rectangle, lsq with a mask, then bini where lsq leaves depth jumps).
    #[arg(long = "integrator", visible_alias = "method", value_name = "METHOD")]
    pub method: Option<String>,
    /// Response curve of the images: linear, srgb or gamma=G (default: srgb for JPEG
    /// files, linear for PNG/TIFF). Lambertian photometric stereo and light calibration
    /// need linear values: camera JPEGs are linearised from sRGB on reading.
    #[arg(long, value_name = "CURVE", value_parser = crate::parse_response)]
    pub response: Option<photostereo::io::Response>,
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
    /// Memory budget, e.g. 1.5G or 800M (binary units). The images are read by row
    /// bands sized to keep the run within it (the plan is printed first); a capture that
    /// cannot fit stops before any pixel is read, saying how much it needs. Default:
    /// half of the machine's memory. Not used with --interreflections (whole stack).
    #[arg(long, value_name = "SIZE", value_parser = parse_memory)]
    pub memory: Option<u64>,
    /// Smoothing scale (Gaussian σ, pixels) of the curvature maps computed from the
    /// normals: curvature.npy (mean curvature, 1/px, positive where the surface bulges
    /// toward the camera), gaussian_curvature.npy and curvature.png (blue hollow, red
    /// bump). Larger = less noise, finer defects flattened. 0 = no smoothing.
    #[arg(
        long,
        value_name = "PX",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub curvature_sigma: f32,
    /// Do not compute the curvature maps.
    #[arg(long, conflicts_with = "curvature_sigma")]
    pub no_curvature: bool,
    /// At most this many triangles in mesh.ply: a bigger mesh is made on every 2nd (3rd…)
    /// pixel, its vertices still on the full-resolution depth (depth.npy keeps every
    /// pixel). 0 = full resolution whatever the size. The default keeps every capture up
    /// to about 2000 × 2000 mask pixels whole.
    #[arg(long, value_name = "N", default_value_t = photostereo::pipeline::DEFAULT_MESH_MAX_FACES)]
    pub mesh_max_faces: usize,
    /// Also write normal_map.png, a 16-bit normal map for 3-D and relighting tools:
    /// opengl (green up: Blender, Maya, Unity, Godot, three.js; the same encoding as
    /// normals.png) or directx (green down: Unreal Engine, 3ds Max). Outside the mask it
    /// is the flat normal (0, 0, 1).
    #[arg(long, value_name = "STYLE", value_parser = parse_normal_map)]
    pub normal_map: Option<photostereo::io::NormalMapStyle>,
    /// Also write normals.tif (float32 RGB, camera frame) and depth.tif (float32, NaN
    /// outside the mask), for GIS and image tools that read float TIFF.
    #[arg(long)]
    pub tiff: bool,
}

fn parse_normal_map(text: &str) -> std::result::Result<photostereo::io::NormalMapStyle, String> {
    photostereo::io::NormalMapStyle::from_name(text).map_err(|e| e.to_string())
}

fn parse_memory(text: &str) -> std::result::Result<u64, String> {
    photostereo::plan::parse_size(text).map_err(|e| e.to_string())
}

/// Run the subcommand.
pub fn run(mut args: Args, global: Global) -> Result<()> {
    crate::check_output_dir(&args.out)?;
    args.lambertian |= args.chrome.is_some();
    if args.black_level.is_some() && !args.lambertian {
        anyhow::bail!(
            "--black-level is for Lambertian photometric stereo: add --lambertian (or --chrome), \
             or leave it out (a lookup table carries the sphere's own black level)"
        );
    }
    let inputs = inputs(&args)?;
    let opts = options(&args)?;
    // a sphere not found: main's hint names --sphere-region, --sphere-mask and --circle,
    // which `run` takes as `calibrate` does
    let done = pipeline::run(&inputs, &args.out, &opts, &Bar::new(global.quiet))?;
    if global.quiet {
        return Ok(());
    }
    // the terminal table is run.json's summary, in the report's order
    let summary = &done.summary;
    for f in &summary.figures {
        println!("{:>36}: {}", f.name, f.value);
    }
    println!("report: {}", done.report.display());
    if !summary.stale_removed.is_empty() {
        println!(
            "removed from {} the files of an earlier run that this run does not write: {}",
            args.out.display(),
            summary.stale_removed.join(", ")
        );
    }
    Ok(())
}

/// Where the target, the sphere (or table) and the lights come from.
fn inputs(args: &Args) -> Result<pipeline::Inputs> {
    let calibration = match &args.lut {
        Some(path) => Some(pipeline::Calibration {
            table: io::read_table(path)?,
            detection: None,
        }),
        None => None,
    };
    Ok(pipeline::Inputs {
        target: args.target.clone(),
        sphere: args.sphere.clone(),
        calibration,
        lambertian: args.lambertian,
        lights: args.lights.clone(),
        chrome: args.chrome.clone(),
        mask: args.mask.clone(),
        image_scale: args.image_scale,
        response: args.response.unwrap_or_default(),
    })
}

/// The pipeline's settings from the flags.
fn options(args: &Args) -> Result<pipeline::Options> {
    let mut opts = pipeline::Options {
        method: args
            .method
            .as_deref()
            .map(integrate::Method::from_name)
            .transpose()?,
        interreflections: args.interreflections,
        black_level: crate::black_level::parse(args.black_level.as_deref())?,
        ..Default::default()
    };
    if args.no_spatial {
        opts.spatial = None;
    }
    if let Some(sp) = opts.spatial.as_mut().filter(|_| args.no_contour) {
        sp.contour_sigma = None;
    }
    opts.nik.radiosity.block = args.block.unwrap_or(0);
    opts.memory = args.memory;
    opts.mesh_max_faces = (args.mesh_max_faces > 0).then_some(args.mesh_max_faces);
    opts.exports = pipeline::Exports {
        normal_map: args.normal_map,
        float_tiff: args.tiff,
    };
    opts.curvature = (!args.no_curvature).then_some(photostereo::curvature::Options {
        sigma: args.curvature_sigma,
    });
    opts.lookup.normalize = args.normalize;
    opts.lookup.split_if_specular = args.normalize && !args.no_split;
    opts.detect.circle = args.circle;
    opts.detect.region = args.sphere_region;
    if let Some(path) = &args.sphere_mask {
        opts.detect.mask = Some(io::read_mask_any(path)?);
    }
    Ok(opts)
}
