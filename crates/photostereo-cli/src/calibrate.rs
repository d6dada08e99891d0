//! `photostereo calibrate`: find the calibration sphere and build its lookup table.

use crate::Global;
use anyhow::Context;
use photostereo::io;
use photostereo::lut::{BuildOptions, Denoise, Table};
use photostereo::sphere::{self, Circle, DetectOptions, Detection};
use std::path::PathBuf;

/// Arguments of `photostereo calibrate`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Examples (after those of `photostereo synth --help`):\n  \
photostereo calibrate data/vase/sphere -o sphere.lut --material 'red plastic'\n  \
photostereo calibrate data/vase/sphere --sphere-region 0,0,204,204 -o sphere_region.lut\n  \
photostereo calibrate data/vase/sphere --circle 102,102,100 --rim 3 -o sphere_given.lut\n  \
photostereo calibrate data/matte_ball -o matte.lut\n\n\
SPHERE_DIR holds the K images of a sphere of the target's material under the target's lights \
(DiLiGenT layout). The sphere is found in the maximum of the images; NAME_overlay.png (the circle \
on that image; NAME = the table's file name without extension) is written beside the table: check it.\n\n\
Sphere and target in the same images (one folder, the sphere in a corner, mask.png marking the \
target): give --sphere-region around the sphere; the folder's mask.png is then the target's and is \
not used to find the sphere."
)]
pub struct Args {
    /// Directory with the sphere's images.
    #[arg(value_name = "SPHERE_DIR")]
    dir: PathBuf,
    /// Use this circle instead of detecting it: centre x (along columns), centre y
    /// (along rows) and radius, in pixels; pixel (r, c) is centred at (c+0.5, r+0.5).
    #[arg(long, value_name = "CX,CY,R", value_parser = crate::lights::parse_circle)]
    circle: Option<Circle>,
    /// Search the sphere only in this window (when the sphere shares the images with the
    /// target): left column, top row, width, height. SPHERE_DIR/mask.png is then the
    /// target's mask and is not used for the search (--sphere-mask still is).
    #[arg(long, value_name = "X,Y,W,H", value_parser = crate::lights::parse_region)]
    sphere_region: Option<(usize, usize, usize, usize)>,
    /// Search the sphere only inside this mask (PNG/TIFF/.npy, non-zero = sphere);
    /// default SPHERE_DIR/mask.png if present and no --sphere-region is given, as in
    /// `run --sphere`. The mask only says where to look: the circle is always fitted to
    /// the rim in the images.
    #[arg(long = "sphere-mask", visible_alias = "mask", value_name = "MASK")]
    mask: Option<PathBuf>,
    /// Free-text name of the sphere's material, stored in the table.
    #[arg(long, value_name = "NAME", default_value = "")]
    material: String,
    /// Leave out this many pixels inside the rim (grazing normals, mixed pixels).
    #[arg(long, value_name = "PX", default_value_t = BuildOptions::default().rim)]
    rim: f64,
    /// Gaussian blur of the sphere images against noise (pixels); default: chosen from
    /// the noise measured on the sphere (none on clean images).
    #[arg(long, value_name = "PX")]
    smooth: Option<f64>,
    /// How the sphere's noise is removed: `normal` = a local quadratic fit over the
    /// normal sphere (width chosen by cross-validation, 1–4 × the blur's), `image` = the
    /// Gaussian blur of the images, `auto` (default) = the fit when the blur would be ≥ 1 px.
    #[arg(long, value_name = "HOW", value_parser = parse_denoise)]
    denoise: Option<Denoise>,
    /// Response curve of the images: linear, srgb or gamma=G (default: srgb for JPEG
    /// files, linear for PNG/TIFF). Lambertian photometric stereo and light calibration
    /// need linear values: camera JPEGs are linearised from sRGB on reading.
    #[arg(long, value_name = "CURVE", value_parser = crate::parse_response)]
    response: Option<photostereo::io::Response>,
    /// Output table file.
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> anyhow::Result<()> {
    let load = io::LoadOptions {
        mask_path: args.mask.clone(),
        require_mask: args.mask.is_some(),
        response: args.response.unwrap_or_default(),
        ..io::LoadOptions::default()
    };
    let data = io::load_dataset(&args.dir, &load)
        .with_context(|| format!("loading the sphere images from {}", args.dir.display()))?;
    let det = find_circle(&args, &data, global.quiet)?;
    let c = det.circle;
    let say = |s: String| {
        if !global.quiet {
            println!("{s}");
        }
    };
    let opts = BuildOptions {
        rim: args.rim,
        material: args.material.clone(),
        smooth: args.smooth,
        denoise: args.denoise.unwrap_or_default(),
    };
    let table = Table::build(&data.stack, &c, &opts)
        .with_context(|| format!("building the lookup table from {}", args.dir.display()))?;
    describe_table(&table, opts.denoise, &say);
    // everything is computed before the first file is written
    let bytes = table.to_bytes();
    let png = sphere::encode_png(&sphere::overlay(&det.max_image, &c))?;
    let overlay_path = crate::lights::side_file(&args.output, "overlay.png");
    io::write_bytes(&args.output, &bytes)?;
    io::write_bytes(&overlay_path, &png)?;
    say(format!(
        "lookup table written to {}; check the circle in {}",
        args.output.display(),
        overlay_path.display()
    ));
    Ok(())
}

/// The sphere's circle (given with `--circle`, else found in the images), with the checks
/// of a given circle against the images or of a found one's shape printed and warned.
fn find_circle(args: &Args, data: &io::Dataset, quiet: bool) -> anyhow::Result<Detection> {
    // the mask (--sphere-mask, else the folder's mask.png unless --sphere-region is
    // given, the same rule as `run --sphere`) restricts the search; the circle itself
    // always comes from the images' rim
    let given = DetectOptions {
        circle: args.circle,
        region: args.sphere_region,
        mask: args.mask.as_ref().and(data.mask.clone()),
        ..DetectOptions::default()
    };
    let detect = DetectOptions {
        mask: given.search_mask(data.mask.clone()),
        ..given
    };
    let det = sphere::detect(&data.stack, &detect)
        .with_context(|| format!("finding the sphere in {}", args.dir.display()))?;
    let say = |s: String| {
        if !quiet {
            println!("{s}");
        }
    };
    let source = if args.circle.is_some() {
        "given"
    } else {
        "detected"
    };
    say(crate::lights::circle_line(source, &det));
    if let Some(w) = det.warning() {
        eprintln!("{w} ({})", crate::advice::UNCERTAIN_CIRCLE);
    }
    if let Some(given) = &args.circle {
        let check = sphere::checks::check_given_circle(&data.stack, given, &detect);
        say(check.describe());
        if let Some(w) = check.warning() {
            eprintln!("warning: {w} (leave out --circle)");
        }
    }
    // a given circle is checked against the one found above; a found one here
    if args.circle.is_none() {
        let shape = sphere::checks::check_shape(&det, detect.mask.as_ref());
        say(shape.describe());
        if let Some(w) = shape.warning() {
            eprintln!("warning: {w}");
        }
    }
    Ok(det)
}

/// Print the table's size and build, and how `--normalize` treats its material.
fn describe_table(table: &Table, denoise: Denoise, say: &dyn Fn(String)) {
    say(format!(
        "table: {} entries, K = {}, rim {} px, {}, material '{}'",
        table.entries.len(),
        table.k,
        table.rim,
        denoising(denoise, table.smooth),
        table.material
    ));
    let share = photostereo::lut::specular_share(table);
    let kind = if share > photostereo::lut::SPECULAR_SHARE {
        "specular: `normals --normalize` fits diffuse + specular for albedo changes"
    } else {
        "matte: `normals --normalize` matches brightness-normalised tuples"
    };
    say(format!(
        "{:.1}% of the sphere's light is not Lambertian ({kind})",
        100.0 * share
    ));
    if let Some((blur, weight)) = photostereo::spatial::blurred_outline(table) {
        say(format!(
            "the images are blurred (σ {blur:.2} px on the sphere's rim, kept in the table): \
             a target's mask outline will count with weight {weight:.2} in the spatial stage"
        ));
    }
}

/// How the table was denoised, for the log line: the blur's σ, or the normal-space fit
/// built on it (the same rule as `Table::build`'s [`Denoise::Auto`]).
fn denoising(how: Denoise, sigma_px: f64) -> String {
    match how.resolve(sigma_px) {
        _ if sigma_px <= 0.0 => "not denoised".into(),
        Denoise::NormalSpace { .. } => {
            format!("denoised in normal space (base width {sigma_px:.2} px)")
        }
        _ => format!("blur {sigma_px:.2} px"),
    }
}

/// `--denoise`'s values, spelled as the library's [`Denoise`] parses them.
fn parse_denoise(s: &str) -> Result<Denoise, String> {
    s.parse().map_err(|e: photostereo::Error| e.to_string())
}
