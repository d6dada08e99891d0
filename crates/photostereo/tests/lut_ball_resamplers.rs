//! Issue 24's "DiLiGenT ball → itself at 0.75×" (target < 0.08°, default pipeline) with
//! the three ways a user's image library shrinks a photograph: area averaging (as
//! `lut_shared.rs`), plain bilinear interpolation, and the antialiased bilinear of
//! Pillow-like libraries (a tent 1/s source pixels wide). The issue's own resampler is
//! not known: at the time it was filed its figure (0.09°) lay between what the build of
//! then gave with the first or third (0.083°, 0.084°) and with the second (0.099°)
//! (docs/accuracy.md, "The DiLiGenT ball at 0.75× by resampler").
//!
//! Mask: the pixels whose centre lies at least 0.71 px inside the scaled circle (no
//! background in their footprint). The whole disc (every pixel whose centre is inside)
//! is printed too, with its outline ring (see the docs).
//!
//! `PHOTOSTEREO_EXPORT_BALL=DIR` also writes each case as a dataset of float TIFFs
//! (`DIR/original`, `DIR/area`, `DIR/bilinear`, `DIR/tent`, `DIR/area_disc`: images
//! already divided by the light intensities, `mask.png`, `normal_gt.npy`) for running
//! another build's CLI on the same input.

mod common;
use common::resample::{rescale, rescale_tent, sphere_truth};
use photostereo::image::{ImageStack, Mask, NormalMap};
use photostereo::io::{self, LoadOptions};
use photostereo::lut::{self, BuildOptions, Options, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::Circle;
use photostereo::{eval, normals};
use std::path::Path;

/// The circle of the ball's true normals (its README).
const TRUTH: Circle = Circle {
    cx: 112.370,
    cy: 112.368,
    radius: 70.751,
};
const SCALE: f64 = 0.75;

/// Mean angular error of the default pipeline (lookup, then the spatial stage).
fn default_error(stack: &ImageStack, mask: &Mask, truth: &NormalMap, table: &Table) -> f64 {
    let lookup = Options::default();
    let input = normals::Input::Tables(std::slice::from_ref(table), &lookup);
    let opts = normals::Options::default();
    let out = normals::solve(stack, mask, &input, &opts, &NoProgress).unwrap();
    eval::angular_errors(&out.normals, truth, mask)
        .unwrap()
        .mean
}

#[test]
fn diligent_ball_at_three_quarters_by_resampler() {
    let test = "diligent_ball_at_three_quarters_by_resampler";
    let Some(dir) = common::shared::path(test, "data/real/diligent_ball") else {
        return;
    };
    let ball = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    let table = Table::build(&ball.stack, &TRUTH, &BuildOptions::default()).unwrap();
    let size = (ball.stack.width, ball.stack.height);
    let scaled = Circle {
        radius: TRUTH.radius * SCALE,
        ..TRUTH
    };
    let (mask, truth) = sphere_truth(&scaled, size.0, size.1, 0.71);
    let cases = [
        ("area", rescale(&ball.stack, &TRUTH, SCALE, size.0, size.1)),
        (
            "bilinear",
            rescale_tent(&ball.stack, &TRUTH, SCALE, size, 1.0),
        ),
        (
            "tent",
            rescale_tent(&ball.stack, &TRUTH, SCALE, size, 1.0 / SCALE),
        ),
    ];
    // measured 2026-12-07: 0.0688°, 0.0723°, 0.0706° (0.0692°, 0.0740°, 0.0708° with the
    // spatial prior's largest scale at 0.01; the build of 2026-12-03, before issue 24's
    // work: 0.0831°, 0.0991°, 0.0840°)
    for (name, stack) in &cases {
        let e = default_error(stack, &mask, &truth, &table);
        println!("DiLiGenT ball at 0.75x, {name}: default pipeline {e:.4} deg");
        assert!(e < 0.08, "{name}: {e:.4}° (issue 24's target < 0.08°)");
    }
    let (disc, disc_truth) = sphere_truth(&scaled, size.0, size.1, 0.0);
    print_disc_ring(&cases[0].1, (&mask, &disc), &disc_truth, &table);
    if let Some(out) = std::env::var_os("PHOTOSTEREO_EXPORT_BALL") {
        let out = Path::new(&out);
        let (all, all_truth) = sphere_truth(&TRUTH, size.0, size.1, 0.71);
        export(&out.join("original"), &ball.stack, &all, &all_truth);
        for (name, stack) in &cases {
            export(&out.join(name), stack, &mask, &truth);
        }
        export(&out.join("area_disc"), &cases[0].1, &disc, &disc_truth);
    }
}

/// The whole disc's default figure, and the lookup's error on its outline ring (the
/// pixels partly over the background that the inset mask leaves out) with the outline's
/// coverage correction (`lut::Options::outline_coverage`) on and off. The lookup tries
/// the correction on the sphere's own outline first and, on this ball, leaves it off:
/// its silhouette pixels are not c·I(n̄) (docs/accuracy.md), so "on" is the plain match.
fn print_disc_ring(
    stack: &ImageStack,
    (inset, disc): (&Mask, &Mask),
    truth: &NormalMap,
    t: &Table,
) {
    let lookup = lut::Lookup::new(std::slice::from_ref(t), &Options::default()).unwrap();
    let check = lookup
        .outline_check()
        .expect("a fresh table has its outline sample");
    // measured 2026-12-08: 399 pixels, plain 1.023°, corrected 1.054°
    println!("the ball's own outline: {check:?}");
    assert!(!check.helps(), "{check:?}");
    let e = default_error(stack, disc, truth, t);
    println!(
        "whole disc ({} px), area: default pipeline {e:.4} deg",
        disc.count()
    );
    // measured 0.0947° (0.1211° while the correction was applied to this ball)
    assert!(e < 0.1, "{e}");
    for coverage in [true, false] {
        let opts = Options {
            outline_coverage: coverage,
            ..Options::default()
        };
        let out = lut::solve(stack, disc, std::slice::from_ref(t), &opts, &NoProgress).unwrap();
        let ring = Mask {
            width: disc.width,
            height: disc.height,
            data: (disc.data.iter().zip(&inset.data))
                .map(|(&d, &i)| d && !i)
                .collect(),
        };
        let r = eval::angular_errors(&out.normals, truth, &ring).unwrap();
        println!(
            "  outline ring ({} px), lookup, outline_coverage {coverage}: {:.3} deg",
            ring.count(),
            r.mean
        );
    }
}

/// `stack` as a dataset of float TIFFs (R = G = B = the value) with `mask` and `truth`.
fn export(dir: &Path, stack: &ImageStack, mask: &Mask, truth: &NormalMap) {
    std::fs::create_dir_all(dir).unwrap();
    let mut names = String::new();
    for i in 0..stack.k {
        let name = format!("{:03}.tif", i + 1);
        let (w, h) = (stack.width as u32, stack.height as u32);
        let img = image::Rgb32FImage::from_fn(w, h, |c, r| {
            let v = stack.pixel(r as usize, c as usize)[i];
            image::Rgb([v, v, v])
        });
        img.save(dir.join(&name)).unwrap();
        names += &format!("{name}\n");
    }
    std::fs::write(dir.join("filenames.txt"), names).unwrap();
    let lights = common::shared::path("export", "data/real/diligent_ball/light_directions.txt");
    std::fs::copy(lights.unwrap(), dir.join("light_directions.txt")).unwrap();
    io::write_mask_png(&dir.join("mask.png"), mask).unwrap();
    io::write_normals(&dir.join("normal_gt.npy"), truth).unwrap();
}
