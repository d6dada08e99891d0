//! `photostereo run --lambertian --interreflections` on the independent Mitsuba render of
//! a 90° V-groove (16 bounces), whose 16-bit images store radiance × `scale` (meta.json).
//! Skips cleanly when `../shared` (or `PHOTOSTEREO_SHARED`) is absent.

use std::path::{Path, PathBuf};
use std::process::Command;

fn shared_dir() -> Option<PathBuf> {
    let p = match std::env::var_os("PHOTOSTEREO_SHARED") {
        Some(p) => PathBuf::from(p),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared"),
    };
    p.join("data/vgroove_interreflect").is_dir().then_some(p)
}

/// Depth range before and after removal, and the mean albedo, from `run.json`.
fn run_vgroove(extra: &[&str], name: &str) -> Option<(f64, f64, f64)> {
    let data = shared_dir()?.join("data/vgroove_interreflect");
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&out);
    let status = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args(["--quiet", "run", "--lambertian", "--interreflections"])
        .args(extra)
        .arg(&data)
        .arg("-o")
        .arg(&out)
        .status()
        .expect("start photostereo");
    assert!(status.success(), "run failed on {}", data.display());
    let text = std::fs::read_to_string(out.join("run.json")).expect("run.json written");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let ir = &v["interreflections"];
    Some((
        ir["depth_before_px"].as_f64().unwrap(),
        ir["depth_after_px"].as_f64().unwrap(),
        ir["mean_albedo_after"].as_f64().unwrap(),
    ))
}

/// With the radiometric scale of meta.json applied by default, the groove deepens to its
/// true 79.5 px (Lambert albedo 0.8); told that the images are already radiance
/// (`--image-scale 1`), the albedo comes out 57270/65535 too low and too little bounced
/// light is removed — which is why the scale matters.
#[test]
fn mitsuba_vgroove_deepens_to_the_truth_with_the_radiometric_scale() {
    const TRUE_DEPTH: f64 = 79.5;
    let Some((before, after, albedo)) = run_vgroove(&[], "vgroove_scaled") else {
        eprintln!("SKIP Mitsuba test: ../shared/data not found (set PHOTOSTEREO_SHARED)");
        return;
    };
    println!("meta.json scale: depth {before:.2} → {after:.2} px (true {TRUE_DEPTH}), albedo {albedo:.4}");
    assert!(
        before / TRUE_DEPTH < 0.75,
        "raw depth {before} should be shallow"
    );
    assert!(
        (after / TRUE_DEPTH - 1.0).abs() < 0.02,
        "depth after removal {after} vs {TRUE_DEPTH}"
    );
    assert!((albedo - 0.8).abs() < 0.01, "albedo {albedo} vs 0.8");

    let (_, unscaled, low) = run_vgroove(&["--image-scale", "1"], "vgroove_unscaled").unwrap();
    println!("--image-scale 1: depth {unscaled:.2} px, albedo {low:.4}");
    assert!(
        (low / albedo - 57270.0 / 65535.0).abs() < 0.01,
        "albedo {low}"
    );
    assert!(
        unscaled < after - 2.0,
        "unscaled depth {unscaled} vs {after}"
    );
}
