//! The classic setup (issue 24, item 4): one folder, one set of images, the calibration
//! sphere in a corner of the target's images, the folder's `mask.png` marking the TARGET.
//! `calibrate DIR --sphere-region`, `normals DIR --lut` and `run --sphere DIR
//! --sphere-region … DIR` work on it: the folder's mask is the target's and is not used to
//! find the sphere (it used to be, and the search failed with "the maximum image is
//! uniform"). The scene: `photostereo synth` renders a plastic blob (128², 16 lights)
//! and, with the same lights and exposure, a sphere of radius 50 (104²) separately; the
//! test pastes the sphere to the right of the blob (232 × 128 images) and writes the
//! blob's mask as the folder's `mask.png`. Normals are scored against the blob's truth.

use std::path::{Path, PathBuf};

use photostereo::image::{Image, ImageStack, Mask};
use photostereo::io;

mod common;
use common::{photostereo as photostereo_any, photostereo_ok as photostereo, s};

/// The target for this setup: mean angular error over the target's mask.
const TARGET_DEG: f64 = 0.20;

/// The old failure's message, which must not come back.
const OLD_ERROR: &str = "maximum image is uniform";

fn tmp(name: &str) -> PathBuf {
    common::scratch("classic-setup", name)
}

/// Images as they are on disk (intensities not applied: the file keeps them).
fn load_raw(dir: &Path) -> io::Dataset {
    let opts = io::LoadOptions {
        apply_intensities: false,
        ..io::LoadOptions::default()
    };
    io::load_dataset(dir, &opts).unwrap()
}

/// The one-folder scene in `dir/classic`; its `mask.png` is the blob's, or with
/// `full_mask` the whole image (sphere included): (folder, the blob's true normals padded to the images, the blob's mask
/// padded, the sphere's search window x,y,w,h).
fn scene(dir: &Path, full_mask: bool) -> (PathBuf, Image<[f32; 3]>, Mask, String) {
    let rendered = dir.join("rendered");
    photostereo(&[
        "-q",
        "synth",
        "--material",
        "plastic",
        "--size",
        "128",
        "--calib-sphere",
        "50",
        "-o",
        s(&rendered),
    ]);
    let target = load_raw(&rendered);
    let sphere = load_raw(&rendered.join("sphere"));
    let (tw, th, k) = (target.stack.width, target.stack.height, target.stack.k);
    let (sw, sh) = (sphere.stack.width, sphere.stack.height);
    assert_eq!(sphere.stack.k, k);
    let (w, h) = (tw + sw, th.max(sh));
    let mut stack = ImageStack {
        width: w,
        height: h,
        k,
        data: vec![0.0; w * h * k],
        names: Vec::new(),
    };
    let mut paste = |src: &ImageStack, x0: usize| {
        for r in 0..src.height {
            for c in 0..src.width {
                let at = (r * w + c + x0) * k;
                stack.data[at..at + k].copy_from_slice(src.pixel(r, c));
            }
        }
    };
    paste(&target.stack, 0);
    paste(&sphere.stack, tw);
    let blob = target.mask.expect("synth writes the blob's mask");
    let inside = |r: usize, c: usize| r < th && c < tw;
    let mask = Mask::from_fn(w, h, |r, c| inside(r, c) && *blob.get(r, c));
    let gt_small = io::read_normals_npy(&rendered.join("normal_gt.npy")).unwrap();
    let gt = Image::from_fn(w, h, |r, c| {
        if inside(r, c) {
            *gt_small.get(r, c)
        } else {
            [0.0; 3]
        }
    });
    let folder = dir.join("classic");
    let written = if full_mask {
        Mask::full(w, h)
    } else {
        mask.clone()
    };
    let lights = target.lights.as_ref().expect("synth writes the lights");
    io::write_dataset(&folder, &stack, lights, Some(&written), 16).unwrap();
    let region = format!("{tw},0,{sw},{sh}");
    (folder, gt, mask, region)
}

/// Mean angular error (degrees) of OUT/normals.npy over `mask`.
fn mean_error(out: &Path, gt: &Image<[f32; 3]>, mask: &Mask) -> f64 {
    let n = io::read_normals_npy(&out.join("normals.npy")).unwrap();
    photostereo::eval::angular_errors(&n, gt, mask)
        .unwrap()
        .mean
}

#[test]
fn calibrate_normals_and_run_on_one_folder_with_the_targets_mask() {
    let dir = tmp("one-folder");
    let (folder, gt, mask, region) = scene(&dir, false);
    let lut = dir.join("sphere.lut");
    let (ok, out, err) = photostereo_any(&[
        "calibrate",
        s(&folder),
        "--sphere-region",
        &region,
        "-o",
        s(&lut),
    ]);
    assert!(ok, "calibrate failed: {err}");
    assert!(!out.contains(OLD_ERROR) && !err.contains(OLD_ERROR));
    let normals = dir.join("normals");
    photostereo(&[
        "-q",
        "normals",
        s(&folder),
        "--lut",
        s(&lut),
        "-o",
        s(&normals),
    ]);
    let e_normals = mean_error(&normals, &gt, &mask);
    let run = dir.join("run");
    let (ok, out, err) = photostereo_any(&[
        "run",
        "--sphere",
        s(&folder),
        "--sphere-region",
        &region,
        s(&folder),
        "-o",
        s(&run),
    ]);
    assert!(ok, "run failed: {err}");
    assert!(!out.contains(OLD_ERROR) && !err.contains(OLD_ERROR));
    // the target's mask holds no sphere pixel: nothing is left out, nothing said
    assert!(!err.contains("left out of the target"), "{err}");
    let e_run = mean_error(&run, &gt, &mask);
    println!("classic setup: normals {e_normals:.3}°, run {e_run:.3}° (target < {TARGET_DEG}°)");
    assert!(e_normals < TARGET_DEG, "normals: {e_normals:.3}°");
    assert!(e_run < TARGET_DEG, "run: {e_run:.3}°");
}

#[test]
fn a_target_mask_over_the_sphere_loses_the_spheres_pixels_and_says_so() {
    let dir = tmp("mask-over-sphere");
    let (folder, _, _, region) = scene(&dir, true);
    let run = dir.join("run");
    let (ok, _, err) = photostereo_any(&[
        "run",
        "--no-spatial",
        "--sphere",
        s(&folder),
        "--sphere-region",
        &region,
        s(&folder),
        "-o",
        s(&run),
    ]);
    assert!(ok, "run failed: {err}");
    // the window is 104 × 104 pixels, all in the (full) target mask
    assert!(
        err.contains("10816 pixels of the target's mask"),
        "no warning about the sphere's pixels: {err}"
    );
    let n = io::read_normals_npy(&run.join("normals.npy")).unwrap();
    let xs: Vec<usize> = region.split(',').map(|v| v.parse().unwrap()).collect();
    for r in xs[1]..xs[1] + xs[3] {
        for c in xs[0]..xs[0] + xs[2] {
            assert_eq!(
                *n.get(r, c),
                [0.0; 3],
                "sphere pixel ({r}, {c}) solved as target"
            );
        }
    }
}

/// Without a window the folder's `mask.png` is searched for the sphere (the rule of a
/// sphere folder): here it is the target's, and the shape check says so and how to fix
/// it, rather than the search failing on an empty window.
#[test]
fn one_folder_without_a_window_warns_that_the_mask_is_not_a_sphere() {
    let dir = tmp("no-region");
    let (folder, _, _, _) = scene(&dir, false);
    let lut = dir.join("sphere.lut");
    let (ok, out, err) = photostereo_any(&["calibrate", s(&folder), "-o", s(&lut)]);
    assert!(ok, "calibrate failed: {err}");
    assert!(err.contains("this is not a sphere"), "{err}");
    assert!(err.contains("in a window around it"), "no fix named: {err}");
    assert!(
        !out.contains(OLD_ERROR) && !err.contains(OLD_ERROR),
        "{err}"
    );
}
