//! `photostereo lights`: light directions from the images of a calibration sphere,
//! matte (least squares over the lit pixels) or chrome (highlight → mirror reflection).

use crate::Global;
use anyhow::Context;
use photostereo::io;
use photostereo::lightcal::{self, ChromeOptions, MatteOptions};
use photostereo::sphere::{self, Circle, DetectOptions, Detection};
use photostereo::{ImageStack, Lights, Mask};
use std::path::{Path, PathBuf};

/// Arguments of `photostereo lights`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
photostereo lights data/chrome --chrome -o data/chrome/light_directions.txt\n  \
photostereo lights data/matte_ball --matte -o lights.txt\n\n\
SPHERE_DIR holds the K sphere images (DiLiGenT layout: filenames.txt or 001.png, 002.png, ...). \
The sphere is found in the maximum of the images or, for a dark chrome sphere, from the edges \
where its rim contrasts with what lies behind it; where the rim does not show at all the outline \
of the mask (SPHERE_DIR/mask.png or --mask) is used. \
NAME_overlay.png (the circle on the maximum image; NAME = the output's file name without \
extension) is written beside the output: check it. With --matte the relative intensities go to \
NAME_intensities.txt (light_intensities.txt when the output is light_directions.txt, the \
dataset layout).")]
pub struct Args {
    /// Directory with the sphere's images.
    #[arg(value_name = "SPHERE_DIR")]
    dir: PathBuf,
    /// Chrome (mirror) sphere: lights from the highlight positions (the default).
    #[arg(long, conflicts_with = "matte")]
    chrome: bool,
    /// Matte (Lambertian) sphere: lights and relative intensities by least squares.
    #[arg(long)]
    matte: bool,
    /// Use this circle instead of detecting it: centre x (along columns), centre y
    /// (along rows) and radius, in pixels; pixel (r, c) is centred at (c+0.5, r+0.5).
    #[arg(long, value_name = "CX,CY,R", value_parser = parse_circle)]
    circle: Option<Circle>,
    /// Search the sphere only in this window: left column, top row, width, height.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_region)]
    sphere_region: Option<(usize, usize, usize, usize)>,
    /// Sphere mask (PNG/TIFF/.npy, non-zero = sphere); default SPHERE_DIR/mask.png if present.
    #[arg(long = "sphere-mask", visible_alias = "mask", value_name = "MASK")]
    mask: Option<PathBuf>,
    /// Fit the circle to the mask's outline directly (do not look at the images).
    #[arg(long)]
    mask_outline: bool,
    /// Skip this many pixels along the rim (grazing normals, mixed pixels).
    #[arg(long, value_name = "PX")]
    rim: Option<f64>,
    /// Response curve of the images: linear, srgb or gamma=G (default: srgb for JPEG
    /// files, linear for PNG/TIFF). Lambertian photometric stereo and light calibration
    /// need linear values: camera JPEGs are linearised from sRGB on reading.
    #[arg(long, value_name = "CURVE", value_parser = crate::parse_response)]
    response: Option<photostereo::io::Response>,
    /// Output light directions file: one `x y z` line per image, in image order, or,
    /// when the name ends in `.lp`, an RTIBuilder / Relight light file (count, then
    /// `filename x y z` per image).
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> anyhow::Result<()> {
    let load = io::LoadOptions {
        mask_path: args.mask.clone(),
        require_mask: args.mask.is_some() || args.mask_outline,
        response: args.response.unwrap_or_default(),
        ..io::LoadOptions::default()
    };
    let data = io::load_dataset(&args.dir, &load)
        .with_context(|| format!("loading the sphere images from {}", args.dir.display()))?;
    let (det, source) = find_circle(&data.stack, data.mask.as_ref(), &args)?;
    let c = det.circle;
    let say = |s: String| {
        if !global.quiet {
            println!("{s}");
        }
    };
    say(circle_line(source, &det));
    if let Some(w) = det.warning() {
        eprintln!("{w} ({})", crate::advice::UNCERTAIN_CIRCLE);
    }
    // --chrome is the default; it only documents the choice
    let matte = args.matte && !args.chrome;
    let lights = calibrate_lights(&data.stack, &c, matte, &args, &say)?;
    say(table(&data.stack.names, &lights));
    // everything is computed before the first file is written
    let png = sphere::encode_png(&sphere::overlay(&det.max_image, &c))?;
    let overlay_path = side_file(&args.output, "overlay.png");
    if io::LightFormat::of(&args.output) == io::LightFormat::Lp {
        // an .lp names the image of each light, so RTI tools can pair them
        io::write_lp(&args.output, &data.stack.names, &lights)?;
    } else {
        io::write_light_directions(&args.output, &lights)?;
    }
    if matte {
        let path = intensities_file(&args.output);
        io::write_intensities(&path, &lights)?;
        say(format!(
            "relative intensities written to {}",
            path.display()
        ));
    }
    io::write_bytes(&overlay_path, &png)?;
    say(format!(
        "light directions written to {}; check the circle in {}",
        args.output.display(),
        overlay_path.display()
    ));
    Ok(())
}

/// The light directions from a matte sphere's shading (`matte`) or a chrome sphere's
/// highlights (with its mirror check, and each image's highlight printed).
fn calibrate_lights(
    stack: &ImageStack,
    c: &Circle,
    matte: bool,
    args: &Args,
    say: &dyn Fn(String),
) -> anyhow::Result<Lights> {
    Ok(if matte {
        let opts = MatteOptions {
            rim_px: args.rim.unwrap_or(MatteOptions::default().rim_px),
            ..MatteOptions::default()
        };
        lightcal::from_matte_sphere(stack, c, &opts)?
    } else {
        let opts = ChromeOptions {
            rim_px: args.rim.unwrap_or(ChromeOptions::default().rim_px),
            ..ChromeOptions::default()
        };
        let (lights, highlights) = lightcal::from_chrome_sphere(stack, c, &opts)?;
        if let Some(w) = sphere::checks::check_mirror(stack, c).warning() {
            eprintln!("warning: {w} (`lights --matte` for a matte sphere)");
        }
        for (name, h) in stack.names.iter().zip(&highlights) {
            say(format!(
                "  {name}: highlight at ({:.2}, {:.2}), {} px, peak {:.3}",
                h.x, h.y, h.pixels, h.peak
            ));
        }
        lights
    })
}

/// The circle: given, detected in the images, or fitted to the mask's outline when the
/// images show no sphere (a dark chrome sphere) and a mask is at hand.
fn find_circle(
    stack: &photostereo::ImageStack,
    mask: Option<&Mask>,
    args: &Args,
) -> anyhow::Result<(Detection, &'static str)> {
    let opts = DetectOptions {
        circle: args.circle,
        region: args.sphere_region,
        mask: mask.cloned(),
        mask_outline: args.mask_outline,
        ..DetectOptions::default()
    };
    let source = match (args.circle.is_some(), args.mask_outline) {
        (true, _) => "given",
        (false, true) => "mask outline",
        (false, false) => "detected in the images",
    };
    // A dataset mask restricts the image search only when asked for with --mask.
    let image_opts = DetectOptions {
        mask: if args.mask.is_some() {
            opts.mask.clone()
        } else {
            None
        },
        ..opts.clone()
    };
    match sphere::detect(stack, &image_opts) {
        Ok(d) => Ok((d, source)),
        Err(err @ photostereo::Error::SphereNotFound { .. }) if mask.is_some() => {
            let outline = DetectOptions {
                mask_outline: true,
                ..opts
            };
            let d = sphere::detect(stack, &outline).with_context(|| {
                format!("{err}\n(the outline of the sphere mask did not give a circle either)")
            })?;
            Ok((
                d,
                "outline of the sphere mask; the rim does not show in the images",
            ))
        }
        Err(e) => Err(e.into()),
    }
}

fn table(names: &[String], lights: &Lights) -> String {
    let mut s =
        String::from("image                 x          y          z   off-axis  intensity\n");
    for (i, (d, e)) in lights
        .directions
        .iter()
        .zip(&lights.intensities)
        .enumerate()
    {
        let name = names.get(i).map_or("?", String::as_str);
        let angle = d[2].clamp(-1.0, 1.0).acos().to_degrees();
        s += &format!(
            "{name:<14} {:+.6} {:+.6} {:+.6}  {angle:7.2}°  {e:9.4}\n",
            d[0], d[1], d[2]
        );
    }
    s
}

/// The light directions of a `--lights FILE` option for a target whose images are
/// `names`, with messages that name the file and say what to do. An RTI `.lp` file is
/// matched to the images by file name; other files hold one light per image, in order.
pub(crate) fn read_lights_option(file: &Path, names: &[String]) -> anyhow::Result<Lights> {
    let k = names.len();
    if !file.is_file() {
        anyhow::bail!(
            "--lights {}: no such file; give a text file of {k} lines `x y z` (one light \
             direction per image, in image order) or an RTI .lp file, or leave --lights out \
             to use the dataset's light_directions.txt",
            file.display()
        );
    }
    io::read_lights_for(file, names).with_context(|| format!("--lights {}", file.display()))
}

/// A file beside `output` named after it: `out/sphere.lut` + `overlay.png` →
/// `out/sphere_overlay.png`, so that runs with different outputs do not overwrite each other.
pub(crate) fn side_file(output: &Path, suffix: &str) -> PathBuf {
    let stem = output
        .file_stem()
        .map_or_else(|| "output".into(), |s| s.to_string_lossy().into_owned());
    output.with_file_name(format!("{stem}_{suffix}"))
}

/// Where `lights --matte` writes the relative intensities: `light_intensities.txt` beside a
/// dataset's `light_directions.txt` (where the loader looks), else `NAME_intensities.txt`.
fn intensities_file(output: &Path) -> PathBuf {
    if output
        .file_name()
        .is_some_and(|n| n == "light_directions.txt")
    {
        output.with_file_name("light_intensities.txt")
    } else {
        side_file(output, "intensities.txt")
    }
}

/// The circle line of `lights` and `calibrate`: the fit quality only when there was a fit.
pub(crate) fn circle_line(source: &str, det: &Detection) -> String {
    format!("sphere circle ({source}): {}", det.describe())
}

fn numbers<const N: usize>(s: &str, what: &str) -> Result<[f64; N], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{what}: {e} in `{s}`"))?;
    v.try_into()
        .map_err(|_| format!("{what}: expected {N} comma-separated numbers, got `{s}`"))
}

pub(crate) fn parse_circle(s: &str) -> Result<Circle, String> {
    let [cx, cy, radius] = numbers::<3>(s, "--circle cx,cy,r")?;
    let finite = cx.is_finite() && cy.is_finite() && radius.is_finite();
    if !finite || radius <= 0.0 {
        return Err(format!(
            "--circle cx,cy,r: the radius must be > 0, got `{s}`"
        ));
    }
    Ok(Circle { cx, cy, radius })
}

pub(crate) fn parse_region(s: &str) -> Result<(usize, usize, usize, usize), String> {
    let v = numbers::<4>(s, "--sphere-region x,y,w,h")?;
    if v.iter().any(|x| *x < 0.0 || x.fract() != 0.0) {
        return Err(format!(
            "--sphere-region x,y,w,h: whole pixel numbers >= 0 expected, got `{s}`"
        ));
    }
    Ok((v[0] as usize, v[1] as usize, v[2] as usize, v[3] as usize))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn side_files_are_named_after_the_output() {
        let p = |s: &str| PathBuf::from(s);
        assert_eq!(
            side_file(&p("out/a.lut"), "overlay.png"),
            p("out/a_overlay.png")
        );
        assert_eq!(
            side_file(&p("lights.txt"), "overlay.png"),
            p("lights_overlay.png")
        );
        assert_eq!(
            intensities_file(&p("d/light_directions.txt")),
            p("d/light_intensities.txt")
        );
        assert_eq!(intensities_file(&p("d/l2.txt")), p("d/l2_intensities.txt"));
    }
}
