//! `photostereo synth`: render a synthetic dataset with ground truth.
//!
//! Output directory (DiLiGenT layout, read back by `photostereo` and most tools):
//! `001.png` … (16-bit gray, or 8-bit with `--bits 8`), `filenames.txt`, `light_directions.txt`,
//! `light_intensities.txt`, `mask.png`, and the ground truth `normal_gt.npy` (H, W, 3),
//! `normal_gt.png`, `depth_gt.npy` (NaN outside the mask), `albedo_gt.npy`, plus
//! `scene.json` (the parameters). With `--calib-sphere R`, `DIR/sphere/` holds a sphere
//! of radius R of the same material under the same lights, in the same layout.
//!
//! Exposure: images are written as e·radiance (blurred by `--blur`, plus the black level
//! `--black-level`) clipped to [0, 1] and every light intensity is written as e, so a
//! loader that divides by the intensities gets the radiance back (plus black level / e).
//! `--exposure auto` (default) picks e = min(1, (0.98 − black level)/peak radiance) over
//! the target and the sphere, so highlights do not clip; `--exposure peak` puts the
//! brightest highlight exactly at full scale (a camera exposed for it); a factor above
//! those clips the highlights at full scale. `--noise` is in units of the written images
//! (full scale 1), i.e. σ/e in radiance units after loading.

use crate::progress::Bar;
use crate::Global;
use anyhow::Context;
use photostereo::io;
use photostereo::synth::{
    default_lights, exposure_for_full_scale, render_calibration_sphere, render_with_progress,
    Camera, Material, Scene, SceneOptions, Shape, ShapeKind,
};
use std::path::{Path, PathBuf};

/// Arguments of `photostereo synth`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Examples (these and the other subcommands' run in sequence from an empty folder: synth, \
calibrate, lights, normals, integrate, eval, interreflect, run):
  photostereo synth --shape vase --material plastic -k 16 --size 256 --noise 0.01 --calib-sphere 100 -o data/vase
  photostereo synth --shape sphere --material metal --size 128 -o data/chrome
  photostereo synth --shape sphere --material lambertian --size 128 -o data/matte_ball
  photostereo synth --shape vgroove --material lambertian --size 64 --interreflections -o data/vgroove
  photostereo synth --shape bowl --material lambertian --albedo-texture --size 128 -o data/bowl
  photostereo synth --material metal --calib-sphere 100 --bits 8 --exposure peak --blur 0.8 --black-level 0.03 -o data/camera"
)]
pub struct Args {
    /// Shape: blob, sphere, vase, bowl or vgroove (scaled to the image size).
    #[arg(long, default_value = "blob")]
    pub shape: String,
    /// Material: lambertian (albedo 0.8), plastic (GGX kd 0.7, F0 0.04, α 0.1),
    /// metal (GGX kd 0, F0 0.9, α 0.2) or phong (Blinn–Phong kd 0.7, ks 0.5, n 50).
    #[arg(long, default_value = "plastic")]
    pub material: String,
    /// GGX width α of the plastic or metal instead of its default (0.1 / 0.2): smaller is
    /// shinier (a metal at α 0.15 leaves over a third of an 8-bit target dark under 16
    /// lights).
    #[arg(long, value_name = "ALPHA")]
    pub roughness: Option<f32>,
    /// Number of lights, spread 15–60° from the view axis.
    #[arg(
        short = 'k',
        long = "light-count",
        visible_alias = "lights",
        default_value_t = 16
    )]
    pub lights: usize,
    /// Image width and height (pixels).
    #[arg(long, default_value_t = 256)]
    pub size: usize,
    /// Standard deviation of Gaussian noise, relative to the full scale of the images.
    #[arg(long, default_value_t = 0.0)]
    pub noise: f32,
    /// Spatially varying albedo (a smooth texture in [0.4, 1]).
    #[arg(long)]
    pub albedo_texture: bool,
    /// No cast shadows (attached shadows stay).
    #[arg(long)]
    pub no_shadows: bool,
    /// Seed of the noise and of the albedo texture.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Exposure: `auto` (brightest sample at 0.98 of full scale, nothing clipped), `peak`
    /// (brightest highlight exactly at full scale) or a factor applied to every radiance
    /// (samples above full scale are clipped).
    #[arg(long, default_value = "auto")]
    pub exposure: String,
    /// Bits per sample of the written images (8 or 16): the quantisation of the camera.
    #[arg(long, default_value_t = 16)]
    pub bits: u8,
    /// Gaussian optical blur of every image, standard deviation in pixels (before the
    /// black level, the noise and the quantisation).
    #[arg(long, default_value_t = 0.0, value_name = "SIGMA")]
    pub blur: f32,
    /// Black level added to every sample, as a fraction of full scale (e.g. 0.03), before
    /// the noise and the quantisation; it is in the images and not removed on loading.
    #[arg(long, default_value_t = 0.0, value_name = "FRAC")]
    pub black_level: f32,
    /// Value of the background outside the mask (0 = black).
    #[arg(long, default_value_t = 0.0)]
    pub background: f32,
    /// Also render a calibration sphere of this radius (pixels) into DIR/sphere/.
    #[arg(long, value_name = "RADIUS")]
    pub calib_sphere: Option<f64>,
    /// Add interreflections: all bounces by radiosity on square facets (Lambertian only).
    #[arg(long)]
    pub interreflections: bool,
    /// Facet size in pixels for --interreflections (1 = per pixel; larger is faster).
    /// Default: the smallest block (at least 2) giving at most 4096 facet cells.
    #[arg(long, requires = "interreflections")]
    pub block: Option<usize>,
    /// Output directory (created).
    #[arg(short = 'o', long = "output", value_name = "DIR")]
    pub output: PathBuf,
}

fn material(name: &str, roughness: Option<f32>) -> anyhow::Result<Material> {
    let m = preset_material(name)?;
    let Some(alpha) = roughness else {
        return Ok(m);
    };
    anyhow::ensure!(
        alpha.is_finite() && alpha > 0.0 && alpha <= 1.0,
        "--roughness {alpha}: give a GGX width in (0, 1], e.g. 0.15"
    );
    match m {
        Material::Ggx { kd, ks, .. } => Ok(Material::Ggx {
            kd,
            ks,
            roughness: alpha,
        }),
        _ => anyhow::bail!(
            "--roughness applies to the GGX materials: use --material plastic or metal"
        ),
    }
}

fn preset_material(name: &str) -> anyhow::Result<Material> {
    Ok(match name.to_ascii_lowercase().as_str() {
        "lambertian" | "matte" => Material::lambertian(0.8),
        "plastic" | "ggx" => Material::shiny_plastic(),
        "metal" => Material::metal(),
        "phong" | "blinn-phong" => Material::phong(),
        other => {
            anyhow::bail!("unknown material `{other}`: use lambertian, plastic, metal or phong")
        }
    })
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> anyhow::Result<()> {
    crate::check_output_dir(&args.output)?;
    anyhow::ensure!(
        matches!(args.bits, 8 | 16),
        "--bits {}: give 8 or 16",
        args.bits
    );
    let kind: ShapeKind = args.shape.parse()?;
    let mut opts = SceneOptions {
        width: args.size,
        height: args.size,
        shape: Shape::preset(kind, args.size, args.size),
        material: material(&args.material, args.roughness)?,
        lights: default_lights(args.lights),
        cast_shadows: !args.no_shadows,
        albedo_texture: args.albedo_texture,
        noise_sigma: args.noise,
        camera: Camera {
            bits: Some(args.bits as u32),
            blur_sigma: args.blur,
            black_level: args.black_level,
        },
        seed: args.seed,
        exposure: 1.0,
        background: args.background,
    };
    opts.exposure = exposure(&args, &opts)?;
    let bar = Bar::new(global.quiet);
    let scene = if args.interreflections {
        let radiosity = photostereo::interreflect::RadiosityOptions {
            block: args.block.unwrap_or(0),
            ..Default::default()
        };
        photostereo::interreflect::render_with_interreflections_report(&opts, &radiosity, &bar)
            .context("rendering with interreflections")?
            .0
    } else {
        render_with_progress(&opts, &bar).context("rendering the scene")?
    };
    let sphere = match args.calib_sphere {
        Some(r) => Some(render_calibration_sphere(&opts, r).context("rendering the sphere")?),
        None => None,
    };
    write_scene(
        &args.output,
        &scene,
        &opts,
        &opts.shape,
        opts.albedo_texture,
    )?;
    if let (Some(s), Some(radius)) = (&sphere, args.calib_sphere) {
        let shape = Shape::Sphere { radius };
        write_scene(&args.output.join("sphere"), s, &opts, &shape, false)?;
    }
    if !global.quiet {
        println!(
            "wrote {} ({}x{}, {} lights, {} pixels in the mask, exposure {:.4}){}",
            args.output.display(),
            opts.width,
            opts.height,
            opts.lights.len(),
            scene.mask.count(),
            opts.exposure,
            if sphere.is_some() { " and sphere/" } else { "" }
        );
    }
    Ok(())
}

/// Brightest sample of an auto-exposed dataset, as a fraction of full scale (below 1 so
/// that loaders do not flag it as clipped).
const HEADROOM: f32 = 0.98;

/// The exposure factor: parsed, `peak` (brightest sample at full scale) or `auto` =
/// min(1, that at 0.98 of full scale), over target and sphere.
fn exposure(args: &Args, opts: &SceneOptions) -> anyhow::Result<f32> {
    let full_scale = |fill: f32| {
        exposure_for_full_scale(opts, args.calib_sphere, fill)
            .context("choosing the exposure (--black-level, --calib-sphere)")
    };
    match args.exposure.as_str() {
        "auto" => Ok(full_scale(HEADROOM)?.min(1.0)),
        "peak" => full_scale(1.0),
        text => {
            let e: f32 = text.parse().map_err(|_| {
                anyhow::anyhow!("--exposure `{text}`: give `auto`, `peak` or a number > 0")
            })?;
            anyhow::ensure!(e.is_finite() && e > 0.0, "--exposure must be > 0, got {e}");
            Ok(e)
        }
    }
}

/// Write one scene (dataset + ground truth + parameters) into `dir`.
fn write_scene(
    dir: &Path,
    scene: &Scene,
    opts: &SceneOptions,
    shape: &Shape,
    albedo_texture: bool,
) -> anyhow::Result<()> {
    let mut lights = scene.lights.clone();
    for v in &mut lights.intensities {
        *v *= opts.exposure;
    }
    let bits = opts.camera.bits.unwrap_or(16) as u8;
    io::write_dataset(dir, &scene.stack, &lights, Some(&scene.mask), bits)
        .with_context(|| format!("writing the dataset {}", dir.display()))?;
    io::write_normals(&dir.join("normal_gt.npy"), &scene.normals)?;
    io::write_normals_png(
        &dir.join("normal_gt.png"),
        &scene.normals,
        Some(&scene.mask),
    )?;
    io::write_gray_npy(&dir.join("depth_gt.npy"), &scene.depth)?;
    io::write_gray_npy(&dir.join("albedo_gt.npy"), &scene.albedo)?;
    let (w, h) = (scene.stack.width, scene.stack.height);
    let params = serde_json::json!({
        "shape": format!("{shape:?}"),
        "material": format!("{:?}", opts.material),
        "width": w,
        "height": h,
        "lights": opts.lights.len(),
        "cast_shadows": opts.cast_shadows,
        "albedo_texture": albedo_texture,
        "noise_sigma": opts.noise_sigma,
        "exposure": opts.exposure,
        "background": opts.background,
        "seed": opts.seed,
        "bit_depth": bits,
        "blur_sigma": opts.camera.blur_sigma,
        "black_level": opts.camera.black_level,
    });
    io::write_text(
        &dir.join("scene.json"),
        &serde_json::to_string_pretty(&params)?,
    )?;
    Ok(())
}
