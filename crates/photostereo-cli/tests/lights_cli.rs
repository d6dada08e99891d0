//! `photostereo lights` end to end on a written synthetic matte sphere, and its
//! refusal of a directory without a sphere.

mod common;
use photostereo::image::{ImageStack, Lights};
use photostereo::io;
use photostereo::synth::{default_lights, render_calibration_sphere, Material, SceneOptions};
use std::path::PathBuf;
use std::process::Command;

fn temp_dir(name: &str) -> PathBuf {
    common::scratch("lights-cli", name)
}

#[test]
fn matte_sphere_directory_gives_the_lights() {
    let opts = SceneOptions {
        material: Material::lambertian(0.8),
        lights: default_lights(8),
        noise_sigma: 0.005,
        ..SceneOptions::default()
    };
    let scene = render_calibration_sphere(&opts, 60.0).unwrap();
    let dir = temp_dir("matte");
    // the directory holds only the images (no lights, no mask)
    let none = Lights {
        directions: vec![[0.0, 0.0, 1.0]; 8],
        intensities: vec![1.0; 8],
    };
    io::write_dataset(&dir, &scene.stack, &none, None, 16).unwrap();
    std::fs::remove_file(dir.join("light_directions.txt")).unwrap();
    let _ = std::fs::remove_file(dir.join("light_intensities.txt"));
    let out = dir.join("calib/light_directions.txt");
    let run = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args([
            "lights",
            dir.to_str().unwrap(),
            "--matte",
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success());
    assert!(stdout.contains("sphere circle (detected in the images)"));
    let found = io::read_lights(&out).unwrap();
    let worst = found
        .directions
        .iter()
        .zip(&opts.lights.directions)
        .map(|(a, b)| common::angle_deg(*a, *b))
        .fold(0.0, f64::max);
    println!("worst light error through the CLI: {worst:.3}°");
    assert!(worst < 0.06, "worst light {worst}°"); // measured 0.020°
    assert!(dir.join("calib/light_directions_overlay.png").is_file());
    assert!(dir.join("calib/light_intensities.txt").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn directory_without_a_sphere_is_an_error_and_writes_nothing() {
    let dir = temp_dir("black");
    let stack = ImageStack::zeros(40, 30, 3);
    let lights = default_lights(3);
    io::write_dataset(&dir, &stack, &lights, None, 8).unwrap();
    let out = dir.join("out/light_directions.txt");
    let run = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args(["lights", dir.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    println!("{stderr}");
    assert!(!run.status.success());
    assert!(stderr.contains("no sphere found") && stderr.contains("--circle cx,cy,r"));
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
