//! `photostereo interreflect`: remove interreflections from a Lambertian dataset with the
//! Nayar–Ikeuchi–Kanade iteration and write every iterate, the convergence table and plots.

use crate::progress::Bar;
use crate::Global;
use anyhow::Context;
use photostereo::interreflect::{self, NikOptions, NikOutput, RadiosityOptions, Visibility};
use photostereo::io;
use std::path::PathBuf;

/// Arguments of `photostereo interreflect`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  photostereo interreflect data/vgroove -o out/vgroove --max-iter 10 --tol 0.01 --block 2\n\n\
The images must be linear and scaled so that a white Lambertian surface facing a unit light\n\
reads 1 (the albedo enters the compensation I_direct = I_raw - albedo * K * I_raw). With a\n\
meta.json holding \"scale\" (Mitsuba renders) the 16-bit images are rescaled automatically;\n\
otherwise use --image-scale."
)]
pub struct Args {
    /// Dataset directory (DiLiGenT layout: images, light_directions.txt, mask.png).
    pub dataset: PathBuf,
    /// Output directory.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Most compensation steps after the raw reconstruction.
    #[arg(long, default_value_t = 10)]
    pub max_iter: usize,
    /// Stop when the spread of the depth change / depth range is below this (0.01 = 1 %).
    #[arg(long, default_value_t = 0.01)]
    pub tol: f32,
    /// Facet size in pixels for the interreflection kernel (1 = per pixel; larger is faster).
    /// Default: the smallest block (at least 2) giving at most 4096 facet cells.
    #[arg(long)]
    pub block: Option<usize>,
    /// Azimuths of the horizon visibility test (0 = no visibility test).
    #[arg(long, default_value_t = 64)]
    pub azimuths: usize,
    /// Multiply the loaded images by this factor (default: 65535/scale from meta.json, else 1).
    #[arg(long, allow_negative_numbers = true)]
    pub image_scale: Option<f32>,
    /// The camera's black level as a fraction of full scale (e.g. 0.03), taken off the
    /// images before the iteration (default: none). It is not measured here: bounced light
    /// reads as an offset.
    #[arg(long, value_name = "LEVEL", value_parser = parse_level)]
    pub black_level: Option<f32>,
    /// Image row of the cross-section plot (default: the middle of the mask).
    #[arg(long)]
    pub row: Option<usize>,
}

/// `--black-level LEVEL`: a level in [0, MAX_BLACK_LEVEL) of full scale.
fn parse_level(text: &str) -> Result<f32, String> {
    use photostereo::lambertian::{BlackLevelChoice, MAX_BLACK_LEVEL};
    match text.parse::<f32>() {
        Ok(v) if BlackLevelChoice::Given(v).check().is_ok() => Ok(v),
        _ => Err(format!(
            "give a level in [0, {MAX_BLACK_LEVEL}) as a fraction of full scale (e.g. 0.03)"
        )),
    }
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> anyhow::Result<()> {
    crate::check_output_dir(&args.output)?;
    let opts = io::LoadOptions {
        require_lights: true,
        require_mask: true,
        ..Default::default()
    };
    let mut data = io::load_dataset(&args.dataset, &opts)
        .with_context(|| format!("loading {}", args.dataset.display()))?;
    let scale = photostereo::pipeline::radiance_scale(&args.dataset, args.image_scale, true)?;
    data.stack.data.iter_mut().for_each(|v| *v *= scale);
    let lights = data.lights.clone().context("light directions")?;
    let mask = data.mask.clone().context("mask")?;
    let mut nik = NikOptions {
        max_iter: args.max_iter,
        tol: args.tol,
        radiosity: RadiosityOptions {
            block: args.block.unwrap_or(0),
            visibility: if args.azimuths == 0 {
                Visibility::None
            } else {
                Visibility::Horizon {
                    azimuths: args.azimuths,
                }
            },
            ..Default::default()
        },
        scale_known: photostereo::pipeline::scale_is_known(&args.dataset, args.image_scale, true)?,
        ..Default::default()
    };
    // a fraction of the images' full scale, which the image scale has multiplied
    nik.lambertian.black_level = args.black_level.unwrap_or(0.0) * scale;
    let out = interreflect::solve(&data.stack, &mask, &lights, &nik, &Bar::new(global.quiet))
        .context("interreflection iteration")?;
    let truth_path = args.dataset.join("depth_gt.npy");
    let truth = if truth_path.exists() {
        Some(io::read_gray_npy(&truth_path)?)
    } else {
        None
    };
    write_outputs(&args, &out, &mask, truth.as_ref())?;
    if !global.quiet {
        print_table(&out, &mask, truth.as_ref());
        println!("{}", out.summary());
        println!("wrote {}", args.output.display());
    }
    Ok(())
}

fn write_outputs(
    args: &Args,
    out: &NikOutput,
    mask: &photostereo::Mask,
    truth: Option<&photostereo::DepthMap>,
) -> anyhow::Result<()> {
    let dir = &args.output;
    for (t, it) in out.iterations.iter().enumerate() {
        io::write_gray_npy(&dir.join(format!("depth_iter{t:02}.npy")), &it.shape.depth)?;
        io::write_gray_npy(
            &dir.join(format!("albedo_iter{t:02}.npy")),
            &it.shape.albedo,
        )?;
    }
    let best = out.best_shape();
    io::write_normals(&dir.join("normals.npy"), &best.normals)?;
    io::write_normals_png(&dir.join("normals.png"), &best.normals, Some(mask))?;
    io::write_gray_npy(&dir.join("albedo.npy"), &best.albedo)?;
    io::write_gray_npy(&dir.join("depth.npy"), &best.depth)?;
    io::write_text(&dir.join("convergence.csv"), &out.convergence_csv())?;
    let row = match args.row {
        Some(r) => r,
        None => interreflect::plot::middle_row(mask).context("the mask is empty")?,
    };
    // `profiles.png` as `run` names it; `profile.png` is its earlier name, kept.
    let profiles = interreflect::profile_plot_png(out, mask, row, truth)?;
    io::write_bytes(&dir.join("profiles.png"), &profiles)?;
    io::write_bytes(&dir.join("profile.png"), &profiles)?;
    io::write_bytes(
        &dir.join("convergence.png"),
        &interreflect::convergence_plot_png(out)?,
    )?;
    Ok(())
}

fn print_table(out: &NikOutput, mask: &photostereo::Mask, truth: Option<&photostereo::DepthMap>) {
    let true_range = truth.map(|z| interreflect::nik::depth_range(z, mask));
    println!(
        "{:>4} {:>12} {:>10} {:>11} {:>12} {:>12}",
        "iter", "depth range", "vs truth", "rel change", "mean albedo", "fit resid."
    );
    for (t, it) in out.iterations.iter().enumerate() {
        let ratio = true_range.map_or(String::from("-"), |r| {
            format!("{:.3}", it.depth_range / r.max(1e-9))
        });
        println!(
            "{t:>4} {:>12.3} {ratio:>10} {:>11.4} {:>12.4} {:>12.5}{}",
            it.depth_range,
            it.relative_change,
            it.mean_albedo,
            it.fit_residual,
            if t == out.best { "  <- kept" } else { "" }
        );
    }
}
