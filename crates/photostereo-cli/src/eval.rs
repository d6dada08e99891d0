//! `photostereo eval`: compare a normal map (and optionally a depth map) with ground
//! truth and print the angular error statistics and the depth RMSE.

use crate::Global;
use anyhow::Context;
use photostereo::eval::{angular_error_map, angular_errors, depth_rmse, DepthStats, NormalStats};
use photostereo::io;
use photostereo::Mask;
use std::path::PathBuf;

/// Arguments of `photostereo eval`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  photostereo eval --normals out/normals/normals.npy --gt data/vase/normal_gt.npy \
--mask data/vase/mask.png --depth out/depth.npy --depth-gt data/vase/depth_gt.npy\n\n\
Pixels count inside the mask (all pixels without --mask) where the ground truth is defined; \
an estimate that is NaN or zero there counts as 180°."
)]
pub struct Args {
    /// Estimated normal map, float (H, W, 3) .npy, or an RGB PNG/TIFF with c = (n + 1)/2.
    #[arg(long, value_name = "EST.npy", requires = "gt")]
    normals: Option<PathBuf>,
    /// Ground-truth normal map, float (H, W, 3) .npy, or an RGB PNG/TIFF with c = (n + 1)/2
    /// (DiLiGenT's normal maps).
    #[arg(long, value_name = "GT.npy", requires = "normals")]
    gt: Option<PathBuf>,
    /// Mask (PNG/TIFF, non-zero = inside, or .npy); default: every pixel.
    #[arg(long, value_name = "MASK")]
    mask: Option<PathBuf>,
    /// Estimated depth map, float (H, W) .npy (pixel units).
    #[arg(long, value_name = "EST.npy", requires = "depth_gt")]
    depth: Option<PathBuf>,
    /// Ground-truth depth map, float (H, W) .npy.
    #[arg(long, value_name = "GT.npy", requires = "depth")]
    depth_gt: Option<PathBuf>,
    /// Write a false-colour picture of the angular error (0–30°) to this PNG.
    #[arg(long, value_name = "PNG")]
    error_png: Option<PathBuf>,
    /// Print the figures as JSON (also with --quiet).
    #[arg(long)]
    json: bool,
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> anyhow::Result<()> {
    if args.normals.is_none() && args.depth.is_none() {
        anyhow::bail!(
            "nothing to evaluate: give --normals with --gt, and/or --depth with --depth-gt"
        );
    }
    let mask = match &args.mask {
        Some(p) => Some(io::read_mask_any(p)?),
        None => None,
    };
    let normals = match (&args.normals, &args.gt) {
        (Some(est), Some(gt)) => Some(eval_normals(est, gt, mask.as_ref(), &args)?),
        _ => None,
    };
    let depth = match (&args.depth, &args.depth_gt) {
        (Some(est), Some(gt)) => {
            let est = io::read_gray_npy(est)?;
            let gt = io::read_gray_npy(gt)?;
            let full = Mask::full(gt.width, gt.height);
            Some(depth_rmse(&est, &gt, mask.as_ref().unwrap_or(&full))?)
        }
        _ => None,
    };
    if args.json {
        let value = serde_json::json!({ "normals": normals, "depth": depth });
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else if !global.quiet {
        print!("{}", table(normals.as_ref(), depth.as_ref()));
    }
    Ok(())
}

fn eval_normals(
    est: &std::path::Path,
    gt: &std::path::Path,
    mask: Option<&Mask>,
    args: &Args,
) -> anyhow::Result<NormalStats> {
    let est = io::read_normals_any(est)?;
    let gt = io::read_normals_any(gt)?;
    let full = Mask::full(gt.width, gt.height);
    let mask = mask.unwrap_or(&full);
    let stats = angular_errors(&est, &gt, mask)?;
    if let Some(png) = &args.error_png {
        let map = angular_error_map(&est, &gt, mask)?;
        io::write_colormap_png(png, &map, Some(mask), Some((0.0, 30.0)))
            .with_context(|| format!("writing the error picture {}", png.display()))?;
    }
    Ok(stats)
}

/// The human-readable table.
fn table(normals: Option<&NormalStats>, depth: Option<&DepthStats>) -> String {
    let mut s = String::new();
    if let Some(n) = normals {
        s += "normals\n";
        s += &format!("  mean angular error   {:>9.3}°\n", n.mean);
        s += &format!("  median               {:>9.3}°\n", n.median);
        s += &format!("  rms                  {:>9.3}°\n", n.rms);
        s += &format!("  max                  {:>9.3}°\n", n.max);
        s += &format!(
            "  under 5° / 10° / 20° {:>6.1}% / {:.1}% / {:.1}%\n",
            n.under_5, n.under_10, n.under_20
        );
        s += &format!("  pixels               {:>9}", n.count);
        if n.invalid_est > 0 {
            s += &format!("  ({} without estimate, scored 180°)", n.invalid_est);
        }
        if n.skipped_gt > 0 {
            s += &format!(
                "  ({} masked pixels without ground truth skipped)",
                n.skipped_gt
            );
        }
        s += "\n";
    }
    if let Some(d) = depth {
        s += "depth (after removing the best offset)\n";
        s += &format!("  rmse                 {:>9.4} px\n", d.rmse);
        s += &format!("  mean abs error       {:>9.4} px\n", d.mae);
        s += &format!("  offset removed       {:>9.4} px\n", d.offset);
        s += &format!("  ground-truth range   {:>9.4} px\n", d.range);
        s += &format!("  pixels               {:>9}\n", d.count);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use photostereo::image::{normalize, Image};

    fn args(dir: &std::path::Path) -> Args {
        Args {
            normals: Some(dir.join("est.npy")),
            gt: Some(dir.join("gt.npy")),
            mask: Some(dir.join("mask.png")),
            depth: Some(dir.join("d_est.npy")),
            depth_gt: Some(dir.join("d_gt.npy")),
            error_png: Some(dir.join("err.png")),
            json: false,
        }
    }

    /// Ground truth tilted 7° from the view axis about x; estimate straight on: 7°.
    fn write_inputs(dir: &std::path::Path) {
        let t = 7f32.to_radians();
        let gt = Image::filled(6, 5, normalize([0.0, t.sin(), t.cos()]));
        let est = Image::filled(6, 5, [0.0, 0.0, 1.0]);
        io::write_normals(&dir.join("gt.npy"), &gt).unwrap();
        io::write_normals(&dir.join("est.npy"), &est).unwrap();
        io::write_mask_png(&dir.join("mask.png"), &Image::from_fn(6, 5, |r, _| r > 0)).unwrap();
        let depth = Image::from_fn(6, 5, |r, c| (r * c) as f32);
        io::write_gray_npy(&dir.join("d_gt.npy"), &depth).unwrap();
        io::write_gray_npy(&dir.join("d_est.npy"), &depth.map(|v| v + 2.0)).unwrap();
    }

    #[test]
    fn evaluates_files_and_reports_the_numbers() {
        let dir = std::env::temp_dir().join(format!("ps_cli_eval_{}", std::process::id()));
        write_inputs(&dir);
        let a = args(&dir);
        let mask = io::read_mask_any(a.mask.as_ref().unwrap()).unwrap();
        let n = eval_normals(
            a.normals.as_ref().unwrap(),
            a.gt.as_ref().unwrap(),
            Some(&mask),
            &a,
        )
        .unwrap();
        assert!(
            (n.mean - 7.0).abs() < 1e-3 && (n.median - 7.0).abs() < 1e-3,
            "{n:?}"
        );
        assert_eq!(n.count, 24);
        assert!(dir.join("err.png").exists());
        let text = table(Some(&n), None);
        assert!(text.contains("7.000°"), "{text}");
        run(args(&dir), Global { quiet: true }).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let dir = std::env::temp_dir().join(format!("ps_cli_eval_bad_{}", std::process::id()));
        write_inputs(&dir);
        let mut a = args(&dir);
        a.gt = Some(dir.join("d_gt.npy")); // a depth map is not a normal map
        let err = run(a, Global { quiet: true }).unwrap_err().to_string();
        assert!(err.contains("d_gt.npy"), "{err}");
        let mut a = args(&dir);
        (a.normals, a.gt, a.depth, a.depth_gt) = (None, None, None, None);
        assert!(run(a, Global { quiet: true }).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
