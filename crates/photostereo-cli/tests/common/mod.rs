//! Helpers shared by the CLI's integration tests: a scratch directory per test, the
//! `photostereo` executable run with a transcript (shown by `cargo test -- --nocapture`),
//! the angle between normals and the shared data ([`shared`]).
//! Each test file includes this with `mod common;` and uses only part of it.
#![allow(dead_code)]

/// The project's shared data and the skips CI counts (the library's test helper).
#[path = "../../../photostereo/tests/common/shared.rs"]
pub mod shared;

use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory `group/name` under Cargo's scratch space for integration tests.
pub fn scratch(group: &str, name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(group)
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create the test's scratch directory");
    d
}

/// Run the executable and print the transcript; (success, stdout, stderr).
pub fn photostereo(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args(args)
        .output()
        .expect("start photostereo");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    println!("$ photostereo {}\n{stdout}{stderr}", args.join(" "));
    (out.status.success(), stdout, stderr)
}

/// Run the executable, which must succeed; returns its stdout.
pub fn photostereo_ok(args: &[&str]) -> String {
    let (ok, stdout, stderr) = photostereo(args);
    assert!(ok, "photostereo {args:?} failed: {stderr}");
    stdout
}

/// A path as a command-line argument (the tests' paths are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().expect("test paths are UTF-8")
}

/// Angle between two directions (need not be unit), degrees, by the accurate formula
/// atan2(‖a × b‖, a · b) (`photostereo::eval::angle_deg`).
pub fn angle_deg(a: [f32; 3], b: [f32; 3]) -> f64 {
    photostereo::eval::angle_deg(&a, &b)
}
