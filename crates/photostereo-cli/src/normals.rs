//! `photostereo normals`: normals of a target from lookup tables (calibration-based) or
//! by Lambertian least squares.

use crate::progress::Bar;
use crate::Global;
use anyhow::Context;
use photostereo::io;
use photostereo::lambertian;
use photostereo::lut::{self, Method, Table};
use photostereo::{GrayImage, Mask, NormalMap};
use std::path::{Path, PathBuf};

/// Arguments of `photostereo normals`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
photostereo normals data/target --lut sphere.lut -o out\n  \
photostereo normals data/target --lut diffuse.lut --lut specular.lut -o out\n  \
photostereo normals data/target --lut sphere.lut --normalize -o out\n  \
photostereo normals data/target --lambertian -o out\n  \
photostereo normals data/target --lambertian --lights lights.txt -o out\n\n\
Writes normals.npy (float32 H×W×3), normals.png, confidence.npy (lookup: 1 = perfect match, \
low where lights are shadowed or the match is poor), residual.npy, albedo.npy (--normalize or \
--lambertian) and weights_1.npy, weights_2.npy, weights_sigma.npy (two tables: the mix of \
each material and its standard error; the confidence is low where the mix is undetermined).")]
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
    /// Match brightness-normalised tuples (target albedo differs from the sphere's);
    /// writes the albedo relative to the sphere.
    #[arg(long)]
    normalize: bool,
    /// Lookup method: refined (sub-pixel, shadow handling), nearest (best table
    /// entry) or idw (6 nearest entries weighted by inverse distance, the baseline).
    #[arg(long, default_value = "refined", value_parser = ["refined", "nearest", "idw"])]
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
    /// Object mask (PNG/TIFF/.npy, non-zero = object); default TARGET_DIR/mask.png,
    /// else the whole image.
    #[arg(long, value_name = "MASK")]
    mask: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "OUT_DIR")]
    output: PathBuf,
}

/// What a run produced, written only once everything is computed.
struct Results {
    normals: NormalMap,
    grays: Vec<(&'static str, GrayImage)>,
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> anyhow::Result<()> {
    let load = io::LoadOptions {
        require_lights: args.lambertian && args.lights.is_none(),
        mask_path: args.mask.clone(),
        require_mask: args.mask.is_some(),
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
        lambertian_normals(&data, &mask, &args, global)?
    } else {
        lookup_normals(&args, &data.stack, &mask, global)?
    };
    write_results(&args.output, &results, &mask)?;
    if !global.quiet {
        println!("normals written to {}", args.output.display());
    }
    Ok(())
}

fn read_table(path: &Path) -> anyhow::Result<Table> {
    io::read_table(path).with_context(|| format!("reading the lookup table {}", path.display()))
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
    let method = match args.method.as_str() {
        "nearest" => Method::Nearest,
        "idw" => Method::InverseDistance { neighbours: 6 },
        _ => Method::Refined,
    };
    let opts = lut::Options {
        method,
        normalize: args.normalize,
        ..lut::Options::default()
    };
    let bar = Bar::new(global.quiet);
    let out = lut::solve(stack, mask, &tables, &opts, &bar).with_context(|| {
        let files: Vec<String> = args.luts.iter().map(|p| p.display().to_string()).collect();
        format!("applying {} to {}", files.join(" + "), args.dir.display())
    })?;
    if !global.quiet {
        let s = &out.stats;
        println!(
            "{} pixels: {} with cast-shadowed lights dropped, {} with confidence < 0.5, mean residual {:.5}",
            s.pixels, s.shadowed_pixels, s.low_confidence_pixels, s.mean_residual
        );
    }
    let mut grays = vec![("confidence", out.confidence), ("residual", out.residual)];
    if let Some(a) = out.albedo {
        grays.push(("albedo", a));
    }
    if let Some(w) = out.weights {
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
    if let Some(sigma) = out.weight_sigma {
        grays.push(("weights_sigma", sigma));
    }
    Ok(Results {
        normals: out.normals,
        grays,
    })
}

fn lambertian_normals(
    data: &io::Dataset,
    mask: &Mask,
    args: &Args,
    global: Global,
) -> anyhow::Result<Results> {
    let from_file = match &args.lights {
        Some(file) => Some(crate::lights::read_lights_option(file, data.stack.k)?),
        None => None,
    };
    let lights = from_file
        .as_ref()
        .or(data.lights.as_ref())
        .context("--lambertian needs TARGET_DIR/light_directions.txt or --lights FILE")?;
    let opts = if args.plain {
        lambertian::Options::plain()
    } else {
        lambertian::Options::default()
    };
    let out = lambertian::solve(&data.stack, mask, lights, &opts)?;
    if !global.quiet {
        println!("Lambertian least squares on {} pixels", mask.count());
    }
    Ok(Results {
        normals: out.normals,
        grays: vec![("albedo", out.albedo), ("residual", out.residual)],
    })
}

fn write_results(dir: &Path, r: &Results, mask: &Mask) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    io::write_normals(&dir.join("normals.npy"), &r.normals)?;
    io::write_normals_png(&dir.join("normals.png"), &r.normals, Some(mask))?;
    for (name, img) in &r.grays {
        io::write_gray_npy(&dir.join(format!("{name}.npy")), img)?;
    }
    Ok(())
}
