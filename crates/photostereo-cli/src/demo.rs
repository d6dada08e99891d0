//! `photostereo demo`: the whole pipeline on built-in synthetic scenes, no files needed.
//!
//! 1. A shiny (GGX plastic) calibration sphere and a shiny vase with convex and concave
//!    parts under the same 16 lights: lookup table → normals → integration → mesh.
//! 2. A Lambertian bowl rendered with interreflections: Lambertian photometric stereo
//!    with and without the Nayar–Ikeuchi–Kanade iteration.
//!
//! Prints the accuracy against the ground truth and writes one report per scene.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use photostereo::synth::{self, Material, SceneOptions, Shape, ShapeKind};

use photostereo::pipeline::{self, Job, Normals, Titles, Truth};

use crate::progress::Bar;
use crate::Global;

/// Arguments of `photostereo demo`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  photostereo demo -o out/demo   # then open out/demo/vase/report.html"
)]
pub struct Args {
    /// Output directory (created): one sub-directory per scene with its report.
    #[arg(
        short,
        long = "output",
        visible_alias = "out",
        default_value = "demo-out"
    )]
    pub out: PathBuf,
    /// Side of the target images in pixels (the sphere has radius 0.4 × size).
    #[arg(long, default_value_t = 256)]
    pub size: usize,
}

/// Run the subcommand.
pub fn run(args: Args, global: Global) -> Result<()> {
    crate::check_output_dir(&args.out)?;
    anyhow::ensure!(
        (32..=2048).contains(&args.size),
        "--size {} is out of range: use 32 to 2048 pixels",
        args.size
    );
    let t0 = Instant::now();
    let vase = shiny_vase(&args.out.join("vase"), args.size, global)?;
    let bowl = lambertian_bowl(&args.out.join("bowl"), args.size / 2, global)?;
    if !global.quiet {
        println!("\nphotostereo demo ({:.1} s)", t0.elapsed().as_secs_f64());
        for line in vase.iter().chain(&bowl) {
            println!("  {line}");
        }
        println!("reports:");
        println!("  {}", args.out.join("vase").join("report.html").display());
        println!("  {}", args.out.join("bowl").join("report.html").display());
    }
    Ok(())
}

/// Shiny plastic sphere + vase, calibration-based; returns the summary lines.
fn shiny_vase(out: &Path, size: usize, global: Global) -> Result<Vec<String>> {
    say(
        global,
        "rendering a shiny calibration sphere and a shiny vase",
    );
    let opts = SceneOptions {
        width: size,
        height: size,
        shape: Shape::preset(ShapeKind::Vase, size, size),
        material: Material::shiny_plastic(),
        lights: synth::default_lights(16),
        ..Default::default()
    };
    let t = Instant::now();
    let target = synth::render(&opts)?;
    let sphere = synth::render_calibration_sphere(&opts, 0.4 * size as f64)?;
    let render_s = t.elapsed().as_secs_f64();
    let job = Job {
        target: target.stack,
        mask: target.mask,
        normals: Normals::Lookup {
            sphere: sphere.stack,
            sphere_mask: None,
        },
        truth: Truth {
            normals: Some(target.normals),
            depth: Some(target.depth),
        },
    };
    let p = pipeline::solve(&job, &Default::default(), &Bar::new(global.quiet))?;
    let extra = [("render".to_string(), render_s)];
    let titles = Titles {
        title: "demo: shiny vase".into(),
        subtitle: "calibration-based photometric stereo (GGX plastic sphere, 16 lights)".into(),
    };
    pipeline::write_outputs(out, &titles, &job, &p, &extra)?;
    let mut lines = vec![format!(
        "shiny vase {size}×{size}, 16 lights, lookup table from a sphere of radius {:.0} px:",
        0.4 * size as f64
    )];
    if let Some((st, _)) = &p.accuracy.angular {
        lines.push(format!(
            "  normals: mean angular error {:.3}°, median {:.3}°",
            st.mean, st.median
        ));
    }
    if let Some((st, _)) = &p.accuracy.depth {
        lines.push(format!(
            "  depth ({}): RMSE {:.3} px after offset = {:.2}% of the depth range {:.1} px",
            p.method.name(),
            st.rmse,
            100.0 * st.rmse / st.range.max(1e-9),
            st.range
        ));
    }
    Ok(lines)
}

/// Lambertian bowl with interreflections, NIK iteration; returns the summary lines.
fn lambertian_bowl(out: &Path, size: usize, global: Global) -> Result<Vec<String>> {
    say(global, "rendering a Lambertian bowl with interreflections");
    let t = Instant::now();
    let opts = SceneOptions {
        width: size,
        height: size,
        shape: Shape::preset(ShapeKind::Bowl, size, size),
        material: Material::lambertian(0.8),
        lights: synth::default_lights(12),
        cast_shadows: true,
        ..Default::default()
    };
    let scene =
        photostereo::interreflect::render_with_interreflections(&opts, &Default::default())?;
    let render_s = t.elapsed().as_secs_f64();
    let truth_depth = pipeline::depth_range(&scene.depth, &scene.mask);
    let job = Job {
        target: scene.stack,
        mask: scene.mask,
        normals: Normals::Lambertian {
            lights: scene.lights,
        },
        truth: Truth {
            normals: Some(scene.normals),
            depth: Some(scene.depth),
        },
    };
    let mut opts = pipeline::Options {
        interreflections: true,
        ..Default::default()
    };
    // Rendered in radiance units (exposure 1, no gain): the scale is known.
    opts.nik.scale_known = true;
    let p = pipeline::solve(&job, &opts, &Bar::new(global.quiet))?;
    let extra = [("render".to_string(), render_s)];
    let titles = Titles {
        title: "demo: Lambertian bowl".into(),
        subtitle: "Lambertian photometric stereo with interreflection removal (Nayar, Ikeuchi & Kanade 1991)".into(),
    };
    pipeline::write_outputs(out, &titles, &job, &p, &extra)?;
    let mut lines = vec![format!(
        "Lambertian bowl {size}×{size} (albedo 0.8) with interreflections:"
    )];
    if let Some(ir) = &p.interreflections {
        let pct = |d: f32| 100.0 * (d - truth_depth) / truth_depth;
        lines.push(format!(
            "  concavity depth: true {truth_depth:.2} px; plain photometric stereo {:.2} px ({:+.1}%); after interreflection removal {:.2} px ({:+.1}%)",
            ir.depth_before,
            pct(ir.depth_before),
            ir.depth_after,
            pct(ir.depth_after)
        ));
        lines.push(format!(
            "  mean albedo: true 0.800; plain {:.3}; after {:.3}",
            ir.albedo_before, ir.albedo_after
        ));
        lines.push(format!("  {}", ir.summary));
    }
    Ok(lines)
}

fn say(global: Global, msg: &str) {
    if !global.quiet {
        eprintln!("{msg}");
    }
}
