//! `photostereo run` on synthetic datasets written in the DiLiGenT layout, with and without
//! `filenames.txt`, `mask.png` and `light_intensities.txt`, Lambertian and lookup-table;
//! accuracy read back from `run.json` against the ground truth written beside the images.

mod common;
use std::path::{Path, PathBuf};
use std::process::Command;

use photostereo::image::{ImageStack, Lights};
use photostereo::io;
use photostereo::synth::{self, Material, SceneOptions, Shape, ShapeKind};

const SIZE: usize = 96;

fn tmp(name: &str) -> PathBuf {
    common::scratch("run-layouts", name)
}

fn scene(material: Material) -> SceneOptions {
    SceneOptions {
        width: SIZE,
        height: SIZE,
        shape: Shape::preset(ShapeKind::Blob, SIZE, SIZE),
        material,
        lights: synth::default_lights(12),
        ..Default::default()
    }
}

/// Render `material` (see [`scene`]) and write it as the dataset `tmp(name)` with its mask
/// and ground truth; lights with intensities `gains` (the images are multiplied by them,
/// as a camera would see). Returns the scene options, the dataset and an empty output
/// directory `tmp(name-out)`.
fn dataset(
    name: &str,
    material: Material,
    gains: Option<&[f32]>,
) -> (SceneOptions, PathBuf, PathBuf) {
    let opts = scene(material);
    let dir = tmp(name);
    let s = synth::render(&opts).unwrap();
    let mut stack: ImageStack = s.stack.clone();
    let mut lights: Lights = s.lights.clone();
    if let Some(g) = gains {
        for px in stack.data.chunks_mut(stack.k) {
            for (v, gi) in px.iter_mut().zip(g) {
                *v *= gi;
            }
        }
        lights.intensities = g.to_vec();
    }
    io::write_dataset(&dir, &stack, &lights, Some(&s.mask), 16).unwrap();
    io::write_normals(&dir.join("normal_gt.npy"), &s.normals).unwrap();
    io::write_gray_npy(&dir.join("depth_gt.npy"), &s.depth).unwrap();
    (opts, dir, tmp(&format!("{name}-out")))
}

fn run(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .arg("--quiet")
        .arg("run")
        .args(args)
        .output()
        .expect("start photostereo");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `photostereo run FLAGS... DATA -o OUT`: success and stderr.
fn run_on(flags: &[&str], data: &Path, out: &Path) -> (bool, String) {
    let mut args = flags.to_vec();
    args.extend([data.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    run(&args)
}

/// [`run_on`], which must succeed.
fn run_ok(flags: &[&str], data: &Path, out: &Path) {
    let (ok, err) = run_on(flags, data, out);
    assert!(ok, "{err}");
}

fn run_json(out: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(out.join("run.json")).expect("run.json written");
    serde_json::from_str(&text).unwrap()
}

fn check_products(out: &Path) {
    for f in [
        "normals.npy",
        "normals.png",
        "depth.npy",
        "depth.png",
        "mesh.ply",
        "run.json",
        "report.html",
    ] {
        assert!(out.join(f).is_file(), "{f} missing in {}", out.display());
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("id=\"ps-mesh\""),
        "the report has no 3-D view"
    );
}

fn mean_error(out: &Path) -> f64 {
    run_json(out)["angular_error_deg"]["mean"].as_f64().unwrap()
}

#[test]
fn lambertian_with_every_optional_file_and_without_each() {
    let gains = [
        0.5, 0.7, 0.9, 1.0, 0.6, 0.8, 1.0, 0.55, 0.75, 0.95, 0.65, 0.85,
    ];
    let (_, data, out) = dataset("lambertian", Material::lambertian(0.9), Some(&gains));
    run_ok(&["--lambertian"], &data, &out);
    check_products(&out);
    let full = mean_error(&out);
    let json = run_json(&out);
    assert_eq!(
        json["integrator"], "lsq",
        "a mask picks the masked integrator"
    );
    assert!(json["stages"].as_array().unwrap().len() >= 4);
    println!("Lambertian blob with intensities, mask, filenames.txt: mean error {full:.3}°");
    // noise-free 16-bit Lambertian render of a convex blob: only quantisation remains
    assert!(full < 0.05, "mean angular error {full}°");

    // without filenames.txt: images found by name, same result
    std::fs::remove_file(data.join("filenames.txt")).unwrap();
    run_ok(&["--lambertian"], &data, &out);
    assert!((mean_error(&out) - full).abs() < 1e-6);

    // without light_intensities.txt the unequal lights bias the normals: clearly worse
    std::fs::remove_file(data.join("light_intensities.txt")).unwrap();
    run_ok(&["--lambertian"], &data, &out);
    let biased = mean_error(&out);
    println!("without light_intensities.txt: {biased:.3}°");
    // measured 7.68° (0.000° with the intensities)
    assert!(
        biased > 3.0 && biased > full + 1.0,
        "ignoring the intensities should hurt: {biased}° vs {full}°"
    );

    // without mask.png: the whole rectangle, DCT integration, still a report
    std::fs::remove_file(data.join("mask.png")).unwrap();
    run_ok(&["--lambertian"], &data, &out);
    check_products(&out);
    assert_eq!(run_json(&out)["integrator"], "dct");
}

#[test]
fn lookup_table_from_a_sphere_of_the_same_material() {
    let (opts, data, out) = dataset("shiny", Material::shiny_plastic(), None);
    let sphere = tmp("shiny-sphere");
    let s = synth::render_calibration_sphere(&opts, 40.0).unwrap();
    io::write_dataset(&sphere, &s.stack, &s.lights, None, 16).unwrap();
    // the lookup needs no light directions
    std::fs::remove_file(data.join("light_directions.txt")).unwrap();
    std::fs::remove_file(sphere.join("light_directions.txt")).unwrap();
    run_ok(&["--sphere", sphere.to_str().unwrap()], &data, &out);
    check_products(&out);
    assert!(out.join("confidence.npy").is_file() && out.join("sphere_overlay.png").is_file());
    let e = mean_error(&out);
    let depth = run_json(&out)["depth_error_px"].clone();
    println!("shiny blob, lookup from a radius-40 sphere: mean error {e:.3}°, depth {depth}");
    // a 16-bit render, sphere of radius 40 px: sub-degree on the whole mask
    assert!(e < 1.0, "mean angular error {e}°");
    let rel = depth["rmse"].as_f64().unwrap() / depth["range"].as_f64().unwrap();
    assert!(rel < 0.02, "depth RMSE {:.2}% of the range", 100.0 * rel);
}

#[test]
fn bad_invocations_say_what_to_do_and_lights_come_from_a_file() {
    let (_, data, out) = dataset("bad", Material::lambertian(0.9), None);
    let (ok, err) = run_on(&[], &data, &out);
    assert!(
        !ok && err.contains("--sphere") && err.contains("--lambertian"),
        "{err}"
    );
    for bad in ["0", "-2", "NaN"] {
        let (ok, err) = run_on(&["--lambertian", "--image-scale", bad], &data, &out);
        assert!(
            !ok && err.contains("--image-scale") && err.contains("> 0"),
            "{err}"
        );
        assert!(
            !out.join("run.json").exists(),
            "no output after --image-scale {bad}"
        );
    }
    let lights = out.with_extension("lights.txt");
    std::fs::rename(data.join("light_directions.txt"), &lights).unwrap();
    let (ok, err) = run_on(&["--lambertian"], &data, &out);
    assert!(!ok && err.contains("--lights"), "{err}");
    assert!(
        !out.join("report.html").exists(),
        "no partial output after an error"
    );
    // the same directions from a file elsewhere
    run_ok(
        &["--lambertian", "--lights", lights.to_str().unwrap()],
        &data,
        &out,
    );
    assert!(mean_error(&out) < 0.05);
    let missing = Path::new("/nonexistent/dir");
    let (ok, err) = run_on(&["--lambertian"], missing, &out);
    assert!(!ok && err.contains("/nonexistent/dir"), "{err}");
}
