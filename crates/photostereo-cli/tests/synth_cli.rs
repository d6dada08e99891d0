//! `photostereo synth` writes a dataset that loads back to the rendered radiance.

use photostereo::io::{load_dataset, read_gray_npy, read_normals_npy, LoadOptions};
use photostereo::synth::{default_lights, render, Material, SceneOptions, Shape, ShapeKind};
use std::path::PathBuf;
use std::process::Command;

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "photostereo-synth-cli-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn synth_writes_a_dataset_that_loads_back_to_the_radiance() {
    let dir = out_dir("vase");
    let status = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args([
            "-q",
            "synth",
            "--shape",
            "vase",
            "--material",
            "plastic",
            "-k",
            "8",
        ])
        .args(["--size", "40", "--calib-sphere", "12", "-o"])
        .arg(&dir)
        .status()
        .unwrap();
    assert!(status.success());
    // The same scene in memory (float radiance, exposure 1).
    let opts = SceneOptions {
        width: 40,
        height: 40,
        shape: Shape::preset(ShapeKind::Vase, 40, 40),
        material: Material::shiny_plastic(),
        lights: default_lights(8),
        ..Default::default()
    };
    let scene = render(&opts).unwrap();
    let data = load_dataset(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(data.stack.k, 8);
    assert_eq!(data.mask.as_ref().unwrap(), &scene.mask);
    assert_eq!(data.saturated, 0, "auto exposure must avoid clipping");
    let e = std::fs::read_to_string(dir.join("light_intensities.txt")).unwrap();
    let e: f32 = e.split_whitespace().next().unwrap().parse().unwrap();
    assert!(e > 0.0 && e <= 1.0);
    // Loaded = quantised(e·radiance)/e: error at most half a 16-bit level over e.
    let tol = 0.5 / 65535.0 / e + 1e-6;
    let max_err = scene
        .stack
        .data
        .iter()
        .zip(&data.stack.data)
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(max_err <= tol, "max error {max_err} > {tol}");
    let lights = data.lights.unwrap();
    for (a, b) in lights.directions.iter().zip(&scene.lights.directions) {
        assert!((0..3).all(|j| (a[j] - b[j]).abs() < 1e-6));
    }
    // Ground truth files.
    assert_eq!(
        read_normals_npy(&dir.join("normal_gt.npy")).unwrap(),
        scene.normals
    );
    let depth = read_gray_npy(&dir.join("depth_gt.npy")).unwrap();
    for (a, b) in depth.data.iter().zip(&scene.depth.data) {
        assert!(a == b || (a.is_nan() && b.is_nan()));
    }
    assert_eq!(
        read_gray_npy(&dir.join("albedo_gt.npy")).unwrap(),
        scene.albedo
    );
    // The calibration sphere: 28x28, disc mask of radius 12.
    let sphere = load_dataset(&dir.join("sphere"), &LoadOptions::default()).unwrap();
    assert_eq!((sphere.stack.width, sphere.stack.height), (28, 28));
    let area = sphere.mask.unwrap().count() as f64;
    assert!(
        (area / (std::f64::consts::PI * 144.0) - 1.0).abs() < 0.03,
        "{area}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn synth_rejects_bad_arguments_without_writing() {
    for (args, needle) in [
        (vec!["--shape", "cube"], "shape `cube`"),
        (vec!["--material", "wood"], "unknown material"),
        (vec!["--size", "0"], "at least 1 pixel"),
        (vec!["--exposure=-2"], "exposure"),
        (vec!["--shape", "sphere", "--calib-sphere=-3"], "radius"),
        (vec!["--bits", "12"], "--bits 12"),
        (vec!["--black-level", "1.5"], "black level"),
        (vec!["--blur=-1"], "blur"),
        (vec!["--exposure", "bright"], "`peak`"),
        (vec!["--roughness", "0"], "GGX width"),
        (
            vec!["--material", "lambertian", "--roughness", "0.3"],
            "GGX materials",
        ),
    ] {
        let dir = out_dir("bad");
        let out = Command::new(env!("CARGO_BIN_EXE_photostereo"))
            .args(["-q", "synth"])
            .args(&args)
            .arg("-o")
            .arg(&dir)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: `{err}`");
        assert!(!dir.exists(), "{args:?} left {}", dir.display());
    }
}

/// Run `synth` with `args` on a 48² metal sphere with a calibration sphere of radius 16
/// and load the target (intensities not applied: the stored samples).
fn camera_dataset(name: &str, args: &[&str]) -> (photostereo::io::Dataset, PathBuf) {
    let dir = out_dir(name);
    let status = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args(["-q", "synth", "--shape", "sphere", "--material", "metal"])
        .args(["--size", "48", "--calib-sphere", "16", "-k", "8"])
        .args(args)
        .arg("-o")
        .arg(&dir)
        .status()
        .unwrap();
    assert!(status.success(), "{args:?}");
    let raw = LoadOptions {
        apply_intensities: false,
        ..LoadOptions::default()
    };
    (load_dataset(&dir, &raw).unwrap(), dir)
}

#[test]
fn synth_roughness_makes_a_shinier_metal_leave_more_of_an_8bit_target_dark() {
    let dark_fraction = |alpha: &str| {
        let args = ["--bits", "8", "--exposure", "peak", "--roughness", alpha];
        let (ds, dir) = camera_dataset(&format!("rough{alpha}"), &args);
        let mask = ds.mask.as_ref().unwrap();
        let inside: Vec<usize> = (0..ds.stack.pixels()).filter(|&i| mask.data[i]).collect();
        let dark = inside
            .iter()
            .filter(|&&i| ds.stack.pixel_flat(i).iter().all(|&v| v * 255.0 <= 5.5))
            .count();
        let _ = std::fs::remove_dir_all(&dir);
        dark as f64 / inside.len() as f64
    };
    let (shiny, rough) = (dark_fraction("0.15"), dark_fraction("0.4"));
    assert!(
        shiny > rough + 0.05,
        "dark pixels α 0.15 {shiny:.3}, α 0.4 {rough:.3}"
    );
}

#[test]
fn synth_makes_8bit_blurred_clipped_images_with_a_black_level() {
    // exposed for the peak: the brightest highlight at (nearly) full scale, 8-bit levels
    let (peak, dir) = camera_dataset("peak", &["--bits", "8", "--exposure", "peak"]);
    assert_eq!(peak.bit_depth, 8);
    let max = peak.stack.data.iter().fold(0f32, |a, &b| a.max(b));
    assert!(max >= 240.0 / 255.0, "brightest sample {max}");
    for v in &peak.stack.data {
        assert!(
            ((v * 255.0).round() - v * 255.0).abs() < 1e-3,
            "{v} off the 8-bit levels"
        );
    }
    let e_peak: f32 = std::fs::read_to_string(dir.join("light_intensities.txt"))
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    // an exposure 3× the peak's clips the highlights at full scale
    let e3 = format!("{}", 3.0 * e_peak);
    let (over, dir) = camera_dataset("over", &["--bits", "8", "--exposure", &e3]);
    assert!(over.saturated > 20, "{} clipped samples", over.saturated);
    let _ = std::fs::remove_dir_all(&dir);
    // black level 3% everywhere outside the object, blur spreads the highlight
    let args = [
        "--bits",
        "8",
        "--exposure",
        "peak",
        "--black-level",
        "0.03",
        "--blur",
        "1.5",
    ];
    let (cam, dir) = camera_dataset("black", &args);
    let mask = cam.mask.as_ref().unwrap();
    let black = (0.03f32 * 255.0).round() / 255.0;
    let corner = cam.stack.pixel(0, 0);
    assert!(
        corner.iter().all(|v| (v - black).abs() < 1e-6),
        "{corner:?}"
    );
    let inside = |s: &photostereo::ImageStack| {
        (0..s.pixels())
            .filter(|&i| mask.data[i])
            .map(|i| s.pixel_flat(i)[0])
            .fold(0f32, f32::max)
    };
    assert!(
        inside(&cam.stack) < inside(&peak.stack),
        "the blur lowers the highlight"
    );
    let sphere = load_dataset(&dir.join("sphere"), &LoadOptions::default()).unwrap();
    assert_eq!(
        sphere.bit_depth, 8,
        "the calibration sphere is made by the same camera"
    );
    let json = std::fs::read_to_string(dir.join("scene.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(json["bit_depth"], 8);
    assert!((json["black_level"].as_f64().unwrap() - 0.03).abs() < 1e-6);
    assert!((json["blur_sigma"].as_f64().unwrap() - 1.5).abs() < 1e-6);
    let _ = std::fs::remove_dir_all(&dir);
}
