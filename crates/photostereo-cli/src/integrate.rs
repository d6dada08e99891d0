//! `photostereo integrate`: normal map → depth map (and mesh).

use crate::progress::Bar;
use crate::Global;
use anyhow::Context;
use photostereo::integrate::{
    choose_method, solve_with_progress, Camera, Method, Options, Output, Parts,
};
use photostereo::{io, mesh, Mask, NormalMap};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `photostereo integrate`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  photostereo integrate out/normals/normals.npy --mask data/vase/mask.png -o out/depth.npy --mesh out/shape.ply
  photostereo integrate out/normals/normals.npy --integrator dct -o out/depth_dct.npy
  photostereo integrate out/normals/normals.npy --mask data/vase/mask.png --weights out/normals/confidence.npy -o out/depth_w.npy --mesh out/shape.obj
  photostereo integrate out/normals/normals.npy --mask data/vase/mask.png --integrator bini --focal 600 -o out/depth_bini.npy --mesh out/bini.ply

Writes DEPTH.npy (float32, H x W, pixel units, larger = closer, NaN outside the mask) and a
false-colour DEPTH.png next to it. Methods: path (two cumulative paths, reports their
disagreement), fc (Frankot-Chellappa, periodic), fc-reflect (FC on the mirrored field), dct
(Poisson with Neumann boundary), lsq (masked least squares by multigrid; holes, several
parts), bini (bilateral normal integration: keeps depth discontinuities, the mesh is cut there).
With --camera K.txt or --focal F the integration is perspective (lsq or bini) and DEPTH.npy is the
distance along the optical axis (positive, larger = farther, up to scale: the geometric mean
over the mask is the focal length in pixels). Separate parts of the mask are placed by --parts
(default contour: their occluding contours at one depth, as a goblet's cup and foot).")]
pub struct Args {
    /// Normal map: float32 .npy of shape (H, W, 3), camera frame (x right, y up, z to camera),
    /// or an 8/16-bit RGB PNG/TIFF encoding c = (n + 1)/2 (black = unknown), as DiLiGenT's
    /// normal_map.png and our normals.png.
    pub normals: PathBuf,
    /// Object mask (PNG or .npy); default: the whole image.
    #[arg(long)]
    pub mask: Option<PathBuf>,
    /// Integrator: path, fc, fc-reflect, dct, lsq or bini (default: lsq with a mask, dct
    /// without).
    #[arg(long = "integrator", visible_alias = "method", value_name = "METHOD")]
    pub method: Option<String>,
    /// Output depth map (.npy); a .png preview is written next to it.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write a triangle mesh (.ply binary or .obj), pixel units.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// At most this many triangles in the --mesh: a bigger mesh is made on every 2nd
    /// (3rd…) pixel, its vertices on the full-resolution depth. Default: full resolution.
    #[arg(long, value_name = "N", requires = "mesh")]
    pub mesh_max_faces: Option<usize>,
    /// Per-pixel confidence (float32 .npy, H x W, ≥ 0) weighting lsq.
    #[arg(long)]
    pub weights: Option<PathBuf>,
    /// Albedo map (float32 .npy, H x W) used as grey vertex colour of the mesh.
    #[arg(long)]
    pub albedo: Option<PathBuf>,
    /// Smallest accepted n_z; normals below it (or NaN) are clamped and counted.
    #[arg(long, default_value_t = 0.05)]
    pub min_nz: f32,
    /// Pinhole intrinsics: a text file with the 3x3 matrix [[fx 0 cx] [0 fy cy] [0 0 1]]
    /// (pixels; pixel centres at integers, as DiLiGenT's K.txt). Perspective integration.
    #[arg(long, conflicts_with = "focal")]
    pub camera: Option<PathBuf>,
    /// Focal length in pixels with the principal point at the image centre (perspective).
    #[arg(long)]
    pub focal: Option<f64>,
    /// bini: sharpness k of the sigmoid weights (larger breaks the surface more easily).
    #[arg(long, default_value_t = 2.0)]
    pub bini_k: f32,
    /// How separate parts of the mask are placed relative to each other: contour (their
    /// occluding contours at one depth: bodies of revolution such as a goblet's cup and
    /// foot), gap (equal depth across the narrowest gap), median (equal median depth) or
    /// separate (each part centred on its own, as before).
    #[arg(long, default_value = "contour")]
    pub parts: String,
}

fn camera(args: &Args, width: usize, height: usize) -> anyhow::Result<Option<Camera>> {
    if let Some(path) = &args.camera {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("reading the camera matrix {}", path.display()))?;
        return Ok(Some(Camera::from_text(&text, &path.display().to_string())?));
    }
    match args.focal {
        Some(f) => Ok(Some(Camera::centred(f, width, height).with_context(
            || format!("--focal {f}: give the focal length in pixels (a positive number)"),
        )?)),
        None => Ok(None),
    }
}

fn mesh_kind(path: &Path) -> anyhow::Result<&'static str> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("ply") => Ok("ply"),
        Some("obj") => Ok("obj"),
        _ => anyhow::bail!("{}: the mesh must end in .ply or .obj", path.display()),
    }
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> anyhow::Result<()> {
    // Check every argument before reading or computing anything.
    if let Some(m) = &args.mesh {
        mesh_kind(m)?;
    }
    anyhow::ensure!(
        args.min_nz.is_finite() && (0.0..1.0).contains(&args.min_nz),
        "--min-nz must be in [0, 1), got {}",
        args.min_nz
    );
    let parts = Parts::from_name(&args.parts)?;
    let normals = io::read_normals_any(&args.normals)?;
    let mask = read_mask(&args, &normals)?;
    let method = method(&args, &mask)?;
    let camera = camera(&args, normals.width, normals.height)?;
    let weights = args.weights.as_deref().map(io::read_gray_npy).transpose()?;
    let opts = Options {
        method,
        weights,
        min_nz: args.min_nz,
        camera,
        parts,
    };
    let albedo = args.albedo.as_deref().map(io::read_gray_npy).transpose()?;
    let start = Instant::now();
    let out = solve_with_progress(&normals, &mask, &opts, &Bar::new(global.quiet))
        .with_context(|| format!("integrating {}", args.normals.display()))?;
    let seconds = start.elapsed().as_secs_f64();
    warn_clamped(&args, out.clamped);
    // Build everything before writing anything.
    let built_mesh = match &args.mesh {
        Some(_) => Some(mesh::from_depth_with(
            &out.depth,
            &mask,
            Some(&normals),
            albedo.as_ref(),
            &mesh::MeshOptions {
                camera: out.camera.as_ref(),
                cuts: out.discontinuities.as_ref(),
                max_faces: args.mesh_max_faces,
            },
        )?),
        None => None,
    };
    let png = write_outputs(&args, &out, &mask, built_mesh.as_ref())?;
    if !global.quiet {
        let what = Summary {
            normals: &normals,
            mask: &mask,
            method: &opts.method,
            seconds,
        };
        print_summary(&args, &what, &out, &png, built_mesh.as_ref());
    }
    Ok(())
}

/// The mask given with `--mask` (checked against the normal map's size), or the whole
/// image.
fn read_mask(args: &Args, normals: &NormalMap) -> anyhow::Result<Mask> {
    let mask = match &args.mask {
        Some(p) => io::read_mask_any(p)?,
        None => Mask::full(normals.width, normals.height),
    };
    mask.check_size(
        normals.width,
        normals.height,
        &format!(
            "mask {}",
            args.mask.as_deref().unwrap_or(Path::new("")).display()
        ),
    )?;
    Ok(mask)
}

/// The integrator named with `--integrator` (or chosen from the mask), with `--bini-k`.
fn method(args: &Args, mask: &Mask) -> anyhow::Result<Method> {
    let mut method = match &args.method {
        Some(name) => Method::from_name(name)?,
        None => choose_method(mask),
    };
    if let Method::Bilateral { k, .. } = &mut method {
        anyhow::ensure!(
            args.bini_k.is_finite() && args.bini_k > 0.0,
            "--bini-k must be a positive number, got {}",
            args.bini_k
        );
        *k = args.bini_k;
    }
    Ok(method)
}

/// Warn when normals inside the mask were clamped to `--min-nz`.
fn warn_clamped(args: &Args, clamped: usize) {
    if clamped == 0 {
        return;
    }
    eprintln!(
        "warning: {} normals inside the mask had n_z <= {} or NaN; they were clamped (slope limited to {:.0}, NaN counted as flat){}",
        clamped,
        args.min_nz,
        1.0 / args.min_nz.max(f32::MIN_POSITIVE),
        if args.mask.is_none() {
            "; without --mask the background counts too: pass the object mask"
        } else {
            ""
        }
    );
}

/// Write the depth map, its preview and the mesh; returns the preview's path.
fn write_outputs(
    args: &Args,
    out: &Output,
    mask: &Mask,
    built_mesh: Option<&mesh::Mesh>,
) -> anyhow::Result<PathBuf> {
    io::write_gray_npy(&args.output, &out.depth)?;
    let png = args.output.with_extension("png");
    io::write_depth_png(&png, &out.depth, Some(mask))?;
    if let (Some(path), Some(m)) = (&args.mesh, built_mesh) {
        let kind = mesh_kind(path)?;
        io::write_atomic(path, |w| match kind {
            "ply" => mesh::write_ply_binary(m, w),
            _ => mesh::write_obj(m, w),
        })?;
    }
    Ok(png)
}

/// What the summary reports besides the solver's output.
struct Summary<'a> {
    normals: &'a NormalMap,
    mask: &'a Mask,
    method: &'a Method,
    seconds: f64,
}

/// The summary on stdout: sizes, method, residual, the method's own figures, files.
fn print_summary(
    args: &Args,
    what: &Summary<'_>,
    out: &Output,
    png: &Path,
    built_mesh: Option<&mesh::Mesh>,
) {
    println!(
        "{}: {}x{}, {} pixels in {} part(s), method {}, {:.3} s",
        args.normals.display(),
        what.normals.width,
        what.normals.height,
        what.mask.count(),
        out.components,
        what.method.name(),
        what.seconds
    );
    println!(
        "gradient residual (RMS per pixel step): {:.4}",
        out.info.residual
    );
    if let Method::Lsq = what.method {
        println!(
            "lsq: {} conjugate-gradient iterations (0: solved by sparse Cholesky)",
            out.info.iterations
        );
    }
    if let Method::Bilateral { .. } = what.method {
        println!(
            "bini: {} reweighting iterations ({} CG), {} discontinuity edges",
            out.info.iterations,
            out.info.inner_iterations,
            out.discontinuities.as_ref().map_or(0, |d| d.count())
        );
    }
    if let Some(cam) = &out.camera {
        println!(
            "perspective: fx {:.1}, fy {:.1}, cx {:.1}, cy {:.1}; depth = distance along the optical axis",
            cam.fx, cam.fy, cam.cx, cam.cy
        );
    }
    if let Some(d) = out.path_disagreement {
        println!("path disagreement (RMS, pixels): {d:.4}");
    }
    println!("wrote {} and {}", args.output.display(), png.display());
    if let (Some(path), Some(m)) = (&args.mesh, built_mesh) {
        println!(
            "wrote {} ({} vertices, {} triangles)",
            path.display(),
            m.vertices.len(),
            m.faces.len()
        );
    }
}
