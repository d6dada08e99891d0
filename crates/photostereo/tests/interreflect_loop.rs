//! The iteration's bookkeeping with a stand-in reconstruction: oscillation is detected, the
//! run stops at the maximum and keeps the best iterate; plots are valid PNGs.

mod common;
use common::interreflect_scene::{bowl, direct, sample};
use photostereo::image::{GrayImage, ImageStack, Mask};
#[cfg(feature = "report")]
use photostereo::interreflect::{convergence_plot_png, profile_plot_png};
use photostereo::interreflect::{iterate, Convergence, NikOptions, Reconstruction};
use photostereo::progress::NoProgress;
use std::cell::Cell;

/// A "reconstruction" that ignores the images and returns a bowl whose depth alternates
/// between two values (with a slowly shrinking swing): it never settles.
fn oscillating_run(max_iter: usize) -> (photostereo::interreflect::NikOutput, Mask) {
    oscillating_run_with(max_iter, false)
}

fn oscillating_run_with(
    max_iter: usize,
    scale_known: bool,
) -> (photostereo::interreflect::NikOutput, Mask) {
    let (w, h) = (40, 40);
    let mask = Mask::full(w, h);
    let (_, n) = sample(w, h, bowl(16.0, 6.0));
    let raw: ImageStack = direct(
        &n,
        0.8,
        &[[0.0, 0.0, 1.0], [0.3, 0.0, 0.954], [0.0, 0.3, 0.954]],
    );
    let calls = Cell::new(0usize);
    let reconstruct = |_: &ImageStack| -> photostereo::Result<Reconstruction> {
        let t = calls.get();
        calls.set(t + 1);
        let swing = if t % 2 == 0 { 1.0 } else { -1.0 } * (0.2 - 0.001 * t as f64);
        let (z, n) = sample(w, h, bowl(16.0, 6.0 * (1.0 + swing)));
        Ok(Reconstruction {
            normals: n,
            albedo: GrayImage::filled(w, h, 0.8),
            depth: z,
            residual: f32::NAN,
        })
    };
    let opts = NikOptions {
        max_iter,
        scale_known,
        tol: 0.01,
        ..Default::default()
    };
    (
        iterate(&raw, &mask, &opts, &reconstruct, &NoProgress).unwrap(),
        mask,
    )
}

#[test]
fn an_oscillating_iteration_stops_at_the_maximum_and_keeps_the_best() {
    let (out, _) = oscillating_run(5);
    assert_eq!(out.iterations.len(), 6, "iterate 0 plus 5 steps");
    assert!(
        matches!(out.convergence, Convergence::MaxIterations { .. }),
        "{}",
        out.summary()
    );
    let best_change = out.iterations[out.best].relative_change;
    for it in &out.iterations[1..] {
        assert!(best_change <= it.relative_change);
    }
    assert!(
        out.summary().contains("did not converge in 5 iterations"),
        "{}",
        out.summary()
    );
    let csv = out.convergence_csv();
    assert_eq!(csv.lines().count(), 7, "{csv}");
}

#[test]
fn a_growing_change_is_flagged_as_oscillation() {
    let changes = [f32::NAN, 0.3, 0.1, 0.25, 0.12];
    let (best, c) = photostereo::interreflect::nik::choose_best(&changes, &[]);
    assert_eq!(best, 2);
    assert_eq!(c, Convergence::MaxIterations { oscillating: true });
}

#[cfg(feature = "report")]
#[test]
fn plots_are_png_images_of_the_stated_size() {
    let (out, mask) = oscillating_run(3);
    let png = profile_plot_png(&out, &mask, 20, None).unwrap();
    let img = image::load_from_memory(&png).unwrap();
    assert_eq!((img.width(), img.height()), (800, 500));
    // The curves are drawn: a good share of the pixels is neither white nor grey.
    let rgb = img.to_rgb8();
    let coloured = rgb
        .pixels()
        .filter(|p| p[2] > p[0].saturating_add(40))
        .count();
    assert!(coloured > 500, "only {coloured} coloured pixels");
    let png = convergence_plot_png(&out).unwrap();
    let img = image::load_from_memory(&png).unwrap();
    assert_eq!((img.width(), img.height()), (800, 600));
    // The tolerance is drawn (dashed red line on the log axis of the upper panel).
    let red = img
        .to_rgb8()
        .pixels()
        .filter(|p| p[0] > 150 && p[1] < 80 && p[2] < 80)
        .count();
    assert!(red > 300, "tolerance line: only {red} red pixels");
    assert!(
        profile_plot_png(&out, &mask, 99, None).is_err(),
        "a row outside the image is an error"
    );
}

#[test]
fn interreflections_need_a_lambertian_material() {
    let opts = photostereo::synth::SceneOptions {
        width: 16,
        height: 16,
        shape: photostereo::synth::Shape::Bowl {
            radius: 6.0,
            depth: 2.0,
        },
        ..Default::default()
    };
    let err = photostereo::interreflect::render_with_interreflections(&opts, &Default::default())
        .unwrap_err();
    assert!(err.to_string().contains("Lambertian"), "{err}");
}

/// The library cannot know whether the images are in radiance units; it echoes what the
/// caller says, for front ends to warn (default: not known).
#[test]
fn whether_the_image_scale_is_known_is_echoed() {
    assert!(!NikOptions::default().scale_known);
    assert!(!oscillating_run_with(1, false).0.scale_known);
    assert!(oscillating_run_with(1, true).0.scale_known);
}
