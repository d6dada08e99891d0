//! A run from paths reads the target by row bands (`pipeline::run`, `io::bands`): its
//! normals and depth equal those of the in-memory pipeline (`pipeline::load` +
//! `pipeline::solve`) on a capture small enough for both, with bands that split the
//! mask at many rows, for a lookup with a sphere and for Lambertian photometric stereo.
//! And a capture over the memory budget stops before anything is read or written.

mod common;
use photostereo::error::Setting;
use photostereo::pipeline::{self, Inputs, Options};
use photostereo::progress::NoProgress;
use photostereo::synth::{self, Material, SceneOptions, Shape, ShapeKind};
use photostereo::{io, Error};
use std::path::{Path, PathBuf};

fn tmp_dir(name: &str) -> PathBuf {
    common::temp_dir("banded-run", name)
}

/// A 96×80 vase under 12 lights (16-bit PNGs, with truth) and its sphere of radius 30.
fn write_capture(dir: &Path, material: Material) {
    write_capture_with(dir, material, 0.003, synth::Camera::quantized(16));
}

/// [`write_capture`] with Gaussian noise `noise` through `camera` (8 or 16 bits).
fn write_capture_with(dir: &Path, material: Material, noise: f32, camera: synth::Camera) {
    let bits = camera.bits.unwrap() as u8;
    let (w, h) = (96, 80);
    let opts = SceneOptions {
        width: w,
        height: h,
        shape: Shape::preset(ShapeKind::Vase, w, h),
        material,
        lights: synth::default_lights(12),
        noise_sigma: noise,
        camera,
        seed: 5,
        exposure: 0.6,
        ..Default::default()
    };
    let scene = synth::render(&opts).unwrap();
    io::write_dataset(dir, &scene.stack, &scene.lights, Some(&scene.mask), bits).unwrap();
    io::write_normals(&dir.join("normal_gt.npy"), &scene.normals).unwrap();
    io::write_gray_npy(&dir.join("depth_gt.npy"), &scene.depth).unwrap();
    let sphere = synth::render_calibration_sphere(&opts, 30.0).unwrap();
    let sd = dir.join("sphere");
    io::write_dataset(&sd, &sphere.stack, &sphere.lights, Some(&sphere.mask), bits).unwrap();
}

/// Compares the two paths; returns the banded run's "spatial stage" row.
fn compare(inputs: &Inputs, out: &Path, band_rows: usize) -> String {
    let opts = Options {
        max_band_rows: Some(band_rows),
        ..Default::default()
    };
    let loaded = pipeline::load(inputs, &opts, &NoProgress).unwrap();
    let whole = pipeline::solve(&loaded.job, &opts, &NoProgress).unwrap();
    let banded = pipeline::run(inputs, out, &opts, &NoProgress)
        .unwrap()
        .output;
    let mask = &loaded.job.mask;
    assert!(mask.count() > 1000);
    let mut worst_n = 0.0f32;
    for (a, b) in whole.normals.data.iter().zip(&banded.normals.data) {
        for i in 0..3 {
            worst_n = worst_n.max((a[i] - b[i]).abs());
        }
    }
    let mut worst_d = 0.0f32;
    for ((a, b), &m) in whole
        .depth
        .data
        .iter()
        .zip(&banded.depth.data)
        .zip(&mask.data)
    {
        if m {
            worst_d = worst_d.max((a - b).abs());
        }
    }
    println!("bands of {band_rows} rows: normals {worst_n:e}, depth {worst_d:e} px");
    assert!(worst_n <= 1e-6, "normals differ by {worst_n}");
    assert!(worst_d <= 1e-4, "depth differs by {worst_d} px");
    assert_eq!(whole.method, banded.method);
    let acc = |o: &pipeline::Output| o.accuracy.angular.as_ref().unwrap().0.mean;
    assert!((acc(&whole) - acc(&banded)).abs() < 1e-9);
    let images = banded.figures.iter().find(|r| r.name == "images").unwrap();
    assert_eq!(
        images.value, "12 of 96×80",
        "the images' own size, not the thumbnails'"
    );
    let stage = banded.figures.iter().find(|r| r.name == "spatial stage");
    let whole_stage = whole.figures.iter().find(|r| r.name == "spatial stage");
    assert_eq!(stage, whole_stage);
    stage.map(|r| r.value.clone()).unwrap_or_default()
}

#[test]
fn lookup_by_bands_equals_the_in_memory_run() {
    let dir = tmp_dir("lookup");
    write_capture(&dir, Material::shiny_plastic());
    let inputs = Inputs {
        target: dir.clone(),
        sphere: Some(dir.join("sphere")),
        ..Default::default()
    };
    // 7 rows: bands that cut the vase at many rows (and not at a multiple of 80)
    compare(&inputs, &dir.join("out7"), 7);
    compare(&inputs, &dir.join("out1"), 1);
}

#[test]
fn lookup_by_bands_equals_the_in_memory_run_on_8bit_metal() {
    // 8-bit without noise: quantisation-limited, so the censored samples and the rule
    // that a pixel's own data may refuse its neighbours' normal (issue 24) are at work
    let dir = tmp_dir("lookup8");
    write_capture_with(&dir, Material::metal(), 0.0, synth::Camera::quantized(8));
    let inputs = Inputs {
        target: dir.clone(),
        sphere: Some(dir.join("sphere")),
        ..Default::default()
    };
    let stage = compare(&inputs, &dir.join("out7"), 7);
    println!("{stage}");
    let kept: usize = stage
        .split(" kept their own")
        .next()
        .unwrap()
        .rsplit(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(kept > 0, "{stage}");
}

#[test]
fn lambertian_by_bands_equals_the_in_memory_run() {
    let dir = tmp_dir("lambertian");
    write_capture(&dir, Material::Lambertian { albedo: 0.8 });
    let inputs = Inputs {
        target: dir.clone(),
        lambertian: true,
        ..Default::default()
    };
    compare(&inputs, &dir.join("out"), 9);
}

#[test]
fn a_black_level_measured_by_bands_is_that_of_the_in_memory_run() {
    // the level is measured by a pass of its own over the bands (BlackLevelSums) and
    // taken off by the solve and the noise measurement in both paths
    let dir = tmp_dir("lambertian_black");
    let camera = synth::Camera {
        black_level: 0.03,
        ..synth::Camera::quantized(16)
    };
    write_capture_with(&dir, Material::Lambertian { albedo: 0.8 }, 0.003, camera);
    let inputs = Inputs {
        target: dir.clone(),
        lambertian: true,
        ..Default::default()
    };
    compare(&inputs, &dir.join("out"), 9);
    let opts = Options {
        max_band_rows: Some(9),
        ..Default::default()
    };
    let run = pipeline::run(&inputs, &dir.join("out"), &opts, &NoProgress).unwrap();
    let row = run.output.figures.iter().find(|r| r.name == "black level");
    let value = row.map(|r| r.value.clone()).unwrap_or_default();
    println!("black level 0.03, bands of 9 rows: {value}");
    // measured: 0.0301 (standard error 7.7e-5), taken off; 0.0314 (2.0e-4) before the
    // level was measured again with itself taken off, one more pass over the bands (the
    // paths agree to the bit above)
    let level: f32 = value.split(' ').next().unwrap().parse().unwrap();
    assert!(
        (level - 0.03).abs() < 0.0005 && value.ends_with("; taken off"),
        "{value}"
    );
}

#[test]
fn a_capture_over_the_budget_stops_before_reading_pixels() {
    let dir = tmp_dir("over");
    write_capture(&dir, Material::shiny_plastic());
    // one image that cannot be a PNG past its header: had the run read pixels, it
    // would fail on it instead
    let bytes = std::fs::read(dir.join("001.png")).unwrap();
    std::fs::write(dir.join("001.png"), &bytes[..bytes.len() / 2]).unwrap();
    let inputs = Inputs {
        target: dir.clone(),
        sphere: Some(dir.join("sphere")),
        ..Default::default()
    };
    let out = dir.join("out");
    let opts = Options {
        memory: Some(1 << 20),
        ..Default::default()
    };
    let err = pipeline::run(&inputs, &out, &opts, &NoProgress).unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(
            err,
            Error::Setting {
                setting: Setting::Memory,
                ..
            }
        ),
        "{text}"
    );
    assert!(text.contains("12 images of 96×80 need at least"), "{text}");
    assert!(text.contains("over the memory budget of 1.0 MiB"), "{text}");
    assert!(!out.exists(), "nothing written");
}
