//! `photostereo normals`: normals of a target from lookup tables (calibration-based) or
//! by Lambertian least squares.

use crate::progress::Bar;
use crate::Global;
use anyhow::Context;
use photostereo::io;
use photostereo::lambertian;
use photostereo::lut::{self, Method, Table};
use photostereo::{normals, spatial};
use photostereo::{GrayImage, Mask, NormalMap};
use std::path::{Path, PathBuf};

/// Arguments of `photostereo normals`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
photostereo normals data/vase --lut sphere.lut -o out/normals\n  \
photostereo normals data/vase --lut matte.lut --lut sphere.lut -o out/two_tables\n  \
photostereo normals data/vase --lut sphere.lut --normalize -o out/normalized\n  \
photostereo normals data/matte_ball --lambertian -o out/lambertian\n  \
photostereo normals data/matte_ball --lambertian --lights lights.txt -o out/lambertian\n\n\
Writes normals.npy (float32 H×W×3), normals.png, confidence.npy (lookup: 1 = perfect match, \
low where lights are shadowed or the match is poor), residual.npy, albedo.npy (--normalize or \
--lambertian) and weights_1.npy, weights_2.npy, weights_sigma.npy (two tables: the mix of \
each material and its standard error; the confidence is low where the mix is undetermined), \
normals_sigma.npy/png (angular standard error of each normal from its own data, degrees, from \
the noise measured on the target) and own_share.npy (spatial stage: 1 = the pixel's own data \
decided its normal, 0 = its neighbours did; the confidence is multiplied by it).\n\n\
Sphere and target in the same images (one folder, mask.png marking the target): make the table \
with `calibrate TARGET_DIR --sphere-region x,y,w,h` (the region around the sphere; the folder's \
mask.png is not used to find it), then `normals TARGET_DIR --lut TABLE`: the mask is the \
target's. Keep the sphere out of it: without a mask every pixel, the sphere's too, is solved.")]
pub struct Args {
    /// Directory with the target's images (DiLiGenT layout).
    #[arg(value_name = "TARGET_DIR")]
    dir: PathBuf,
    /// Lookup table from `photostereo calibrate`; give two for a mix of two materials.
    #[arg(
        long = "lut",
        value_name = "FILE",
        required_unless_present = "lambertian"
    )]
    luts: Vec<PathBuf>,
    /// For albedo changes (the target's albedo varies or differs from the sphere's):
    /// match brightness-normalised tuples, or, when the table is specular (a shiny
    /// sphere: its highlight is more than 2% of its light) and the lookup refined, fit
    /// diffuse + specular as --split-specular does (only the diffuse part scales with
    /// the albedo); a line says which. Writes the albedo relative to the sphere's.
    #[arg(long)]
    normalize: bool,
    /// With --normalize on a specular table: brightness-normalised matching all the
    /// same (no diffuse/specular split; faster, less accurate where the albedo varies).
    #[arg(long, requires = "normalize", conflicts_with = "split_specular")]
    no_split: bool,
    /// Shiny target whose albedo varies: split the table into its Lambertian part and
    /// the rest (highlight) and fit a·diffuse + b·specular at each pixel, so that only
    /// the diffuse part scales with the albedo; writes the albedo (a). One table only;
    /// slower than --normalize.
    #[arg(long, conflicts_with = "lambertian")]
    split_specular: bool,
    /// Lookup method: refined (sub-pixel, shadow handling), nearest (best table
    /// entry) or idw (6 nearest entries weighted by inverse distance, the baseline).
    #[arg(
        long = "lookup",
        visible_alias = "method",
        default_value = "refined",
        value_parser = ["refined", "nearest", "idw"]
    )]
    method: String,
    /// Lambertian least squares with the lights of TARGET_DIR/light_directions.txt
    /// instead of a lookup table (drops shadowed and highlight samples unless --plain).
    #[arg(long, conflicts_with_all = ["luts", "normalize"])]
    lambertian: bool,
    /// With --lambertian: plain least squares over all samples (no rejection).
    #[arg(long, requires = "lambertian")]
    plain: bool,
    /// With --lambertian: light directions file (K lines `x y z`) instead of
    /// TARGET_DIR/light_directions.txt.
    #[arg(long, value_name = "FILE", requires = "lambertian")]
    lights: Option<PathBuf>,
    #[arg(
        long,
        value_name = "LEVEL",
        requires = "lambertian",
        help = crate::black_level::HELP
    )]
    black_level: Option<String>,
    /// Keep every pixel's own normal: no spatial stage (by default pixels whose data say
    /// little about their normal take it from their neighbours; see `photostereo::spatial`).
    #[arg(long)]
    no_spatial: bool,
    /// No occluding-contour prior in the spatial stage: by default the mask's edge is taken
    /// as the object's silhouette, where the normal is perpendicular to the view and to the
    /// edge (Ikeuchi & Horn 1981). Turn it off where the mask's edge is not a silhouette:
    /// the object rests on a support, the mask cuts through a surface, or a concave fold.
    /// (Edge pixels on the image border never count as contour.)
    #[arg(long)]
    no_contour: bool,
    /// Object mask (PNG/TIFF/.npy, non-zero = object); default TARGET_DIR/mask.png,
    /// else the whole image.
    #[arg(long, value_name = "MASK")]
    mask: Option<PathBuf>,
    /// Response curve of the images: linear, srgb or gamma=G (default: srgb for JPEG
    /// files, linear for PNG/TIFF). Lambertian photometric stereo and light calibration
    /// need linear values: camera JPEGs are linearised from sRGB on reading.
    #[arg(long, value_name = "CURVE", value_parser = crate::parse_response)]
    response: Option<photostereo::io::Response>,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "OUT_DIR")]
    output: PathBuf,
}

/// Named gray images written as NAME.npy.
type Grays = Vec<(&'static str, GrayImage)>;

/// What a run produced, written only once everything is computed.
struct Results {
    normals: NormalMap,
    grays: Grays,
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> anyhow::Result<()> {
    // a bad --black-level is refused before any image is read
    let black = crate::black_level::parse(args.black_level.as_deref())?;
    let load = io::LoadOptions {
        require_lights: args.lambertian && args.lights.is_none(),
        mask_path: args.mask.clone(),
        require_mask: args.mask.is_some(),
        response: args.response.unwrap_or_default(),
        ..io::LoadOptions::default()
    };
    let data = io::load_dataset(&args.dir, &load)
        .with_context(|| format!("loading the target images from {}", args.dir.display()))?;
    let mask = data.mask.clone().unwrap_or_else(|| {
        if !global.quiet {
            println!("no mask: solving every pixel of the image");
        }
        Mask::full(data.stack.width, data.stack.height)
    });
    let results = if args.lambertian {
        lambertian_normals(&data, &mask, (&args, black), global)?
    } else {
        lookup_normals(&args, &data.stack, &mask, global)?
    };
    write_results(&args.output, &results, &mask)?;
    if !global.quiet {
        println!("normals written to {}", args.output.display());
    }
    Ok(())
}

/// The library's errors name the file and the fix already: no context around them.
fn read_table(path: &Path) -> anyhow::Result<Table> {
    Ok(io::read_table(path)?)
}

fn lookup_normals(
    args: &Args,
    stack: &photostereo::ImageStack,
    mask: &Mask,
    global: Global,
) -> anyhow::Result<Results> {
    let tables = args
        .luts
        .iter()
        .map(|p| read_table(p))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let asked = lookup_options(args);
    // said before the lookup's progress, as the lookup resolves it (lut::options_for)
    let split = lut::options_for(&tables, &asked).split_specular && !args.split_specular;
    if split && !global.quiet {
        println!(
            "--normalize: the table is specular ({:.1}% of its light is not Lambertian): fitting \
             diffuse + specular (as --split-specular; --no-split for normalised matching)",
            100.0 * lut::specular_share(&tables[0])
        );
    }
    let input = normals::Input::Tables(&tables, &asked);
    let bar = Bar::new(global.quiet);
    let out = normals::pixelwise(stack, mask, &input, &bar).with_context(|| {
        let files: Vec<String> = args.luts.iter().map(|p| p.display().to_string()).collect();
        format!("applying {} to {}", files.join(" + "), args.dir.display())
    })?;
    if let (Some(s), false) = (&out.lookup, global.quiet) {
        println!(
            "{} pixels: {} with cast-shadowed lights dropped, {} with confidence < 0.5, mean residual {:.5}",
            s.pixels, s.shadowed_pixels, s.low_confidence_pixels, s.mean_residual
        );
        if let Some(c) = s.outline_check {
            println!("mask outline: coverage correction {}", c.describe());
        }
    }
    let mut out = normals::spatial_stage(stack, mask, &input, &normals_options(args), out)
        .context("spatial stage after the lookup")?;
    say_spatial(&out, mask, global);
    if let (Some(_), [table], false) = (&out.spatial, &tables[..], global.quiet) {
        say_outline_weight(table);
    }
    let mut grays = spatial_grays(&mut out);
    let mixture = mixture_grays(&mut out, args, global);
    grays.extend(out.confidence.map(|c| ("confidence", c)));
    grays.push(("residual", out.residual));
    grays.extend(out.albedo.map(|a| ("albedo", a)));
    grays.extend(mixture);
    Ok(Results {
        normals: out.normals,
        grays,
    })
}

/// One line when the sphere's rim was blurred enough for the spatial stage to weight the
/// target's outline down (`spatial::outline_weight`).
fn say_outline_weight(table: &Table) {
    if let Some((blur, weight)) = spatial::blurred_outline(table) {
        println!(
            "the sphere's rim is blurred (σ {blur:.2} px, above {} px): the target's outline \
             pixels count with weight {weight:.2} in the spatial stage",
            spatial::SHARP_OUTLINE_PX
        );
    }
}

/// The lookup's options from the flags.
fn lookup_options(args: &Args) -> lut::Options {
    let method = match args.method.as_str() {
        "nearest" => Method::Nearest,
        "idw" => Method::InverseDistance { neighbours: 6 },
        _ => Method::Refined,
    };
    lut::Options {
        method,
        normalize: args.normalize || args.split_specular,
        split_specular: args.split_specular,
        split_if_specular: args.normalize && !args.no_split,
        ..lut::Options::default()
    }
}

/// A mixture's weights and their standard error (two tables), taken out of `out`.
fn mixture_grays(out: &mut normals::Output, args: &Args, global: Global) -> Grays {
    let mut grays = Grays::new();
    if let Some(w) = out.weights.take() {
        for ((img, name), path) in w
            .into_iter()
            .zip(["weights_1", "weights_2"])
            .zip(&args.luts)
        {
            if !global.quiet {
                println!("{name}.npy: weight of {}", path.display());
            }
            grays.push((name, img));
        }
    }
    grays.extend(out.weight_sigma.take().map(|s| ("weights_sigma", s)));
    grays
}

/// The maps of the spatial stage, in the order they are written: normals_sigma, then
/// own_share (when the stage ran). Takes them out of `out`.
fn spatial_grays(out: &mut normals::Output) -> Grays {
    let sigma = out.normals_sigma.take().map(|s| ("normals_sigma", s));
    let share = out.own_share.take().map(|s| ("own_share", s));
    sigma.into_iter().chain(share).collect()
}

/// The lines about the noise and the spatial stage.
fn say_spatial(out: &normals::Output, mask: &Mask, global: Global) {
    if global.quiet {
        return;
    }
    for w in &out.warnings {
        println!("note: {w}");
    }
    let Some(noise) = &out.noise else { return };
    println!(
        "noise measured on the target: σ = √({:.3e}² + {:.3e}·I), at least the \
         quantisation step {:.3e} / √12",
        noise.read, noise.gain, noise.step
    );
    match (&out.spatial, &out.normals_sigma) {
        (Some(s), _) => println!(
            "spatial stage: {} of {} pixels decided by their neighbours, {} discontinuity cuts, \
             {} kept their own match (their data reject the neighbours' normal); angular \
             standard error of the own data: mean {:.2}° (normals_sigma.npy)",
            s.decided_by_neighbours, s.pixels, s.cut_triples, s.kept_own, s.mean_sigma_deg
        ),
        (None, Some(sigma)) => println!(
            "angular standard error: mean {:.2}° (normals_sigma.npy)",
            spatial::mean_in(sigma, mask)
        ),
        (None, None) => {}
    }
}

fn lambertian_normals(
    data: &io::Dataset,
    mask: &Mask,
    (args, black): (&Args, lambertian::BlackLevelChoice),
    global: Global,
) -> anyhow::Result<Results> {
    let from_file = match &args.lights {
        Some(file) => Some(crate::lights::read_lights_option(file, &data.stack.names)?),
        None => None,
    };
    let lights = from_file
        .as_ref()
        .or(data.lights.as_ref())
        .context("--lambertian needs TARGET_DIR/light_directions.txt or --lights FILE")?;
    let mut opts = if args.plain {
        lambertian::Options::plain()
    } else {
        lambertian::Options::default()
    };
    // measured on the robust fits whatever the solver (Options::for_black_level); the
    // level is taken off by the solve and the spatial stage, not from a copy of the stack
    let stack = &data.stack;
    let (out, decision) =
        lambertian::solve_with_black_level(black, (stack, mask, lights), &opts, 1.0)?;
    if !global.quiet && (decision.measured.is_some() || decision.level > 0.0) {
        println!("{}", decision.describe());
    }
    opts.black_level = decision.level;
    let input = normals::Input::Lambertian(lights, &opts);
    let out = normals::from_lambertian(out);
    if !global.quiet {
        println!("Lambertian least squares on {} pixels", mask.count());
    }
    let mut out = normals::spatial_stage(stack, mask, &input, &normals_options(args), out)
        .context("spatial stage after the Lambertian solve")?;
    if let (Some(s), false) = (&out.spatial, global.quiet) {
        println!(
            "spatial stage: {} of {} pixels decided by their neighbours",
            s.decided_by_neighbours, s.pixels
        );
    }
    let spatial = spatial_grays(&mut out);
    let mut grays: Grays = out.albedo.map(|a| ("albedo", a)).into_iter().collect();
    grays.push(("residual", out.residual));
    grays.extend(spatial);
    Ok(Results {
        normals: out.normals,
        grays,
    })
}

fn write_results(dir: &Path, r: &Results, mask: &Mask) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    io::write_normals(&dir.join("normals.npy"), &r.normals)?;
    io::write_normals_png(&dir.join("normals.png"), &r.normals, Some(mask))?;
    for (name, img) in &r.grays {
        io::write_gray_npy(&dir.join(format!("{name}.npy")), img)?;
        if *name == "normals_sigma" {
            // false colour over 0–10°
            io::write_colormap_png(
                &dir.join("normals_sigma.png"),
                img,
                Some(mask),
                Some((0.0, 10.0)),
            )?;
        }
    }
    Ok(())
}

/// The settings after the lookup or the Lambertian solve: the spatial stage with its
/// defaults (none under `--no-spatial`), without the contour prior under
/// `--no-contour`.
fn normals_options(args: &Args) -> normals::Options {
    let mut opts = spatial::Options::default();
    if args.no_contour {
        opts.contour_sigma = None;
    }
    normals::Options {
        spatial: (!args.no_spatial).then_some(opts),
    }
}
