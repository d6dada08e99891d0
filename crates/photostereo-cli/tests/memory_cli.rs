//! `photostereo run --memory`: the plan is printed before the run, the images are read
//! in bands sized to the budget with the same results as one band, and a capture over
//! the budget stops before reading pixels with exit ≠ 0, the size it needs, and no
//! output.

use std::path::PathBuf;

mod common;
use common::{photostereo, photostereo_ok, s};

fn tmp(name: &str) -> PathBuf {
    common::scratch("memory-cli", name)
}

#[test]
fn the_budget_sets_the_bands_and_an_impossible_one_stops_the_run() {
    let dir = tmp("vase");
    let data = dir.join("vase");
    photostereo_ok(&[
        "-q",
        "synth",
        "--shape",
        "vase",
        "--size",
        "160",
        "-k",
        "12",
        "--noise",
        "0.005",
        "--calib-sphere",
        "40",
        "-o",
        s(&data),
    ]);
    let sphere = data.join("sphere");
    // a budget of 2 MiB cannot hold a 160² grid: refused, nothing written
    let out = dir.join("over");
    let (ok, _, err) = photostereo(&[
        "run",
        s(&data),
        "--sphere",
        s(&sphere),
        "-o",
        s(&out),
        "--memory",
        "2M",
    ]);
    assert!(!ok, "over the budget must fail");
    assert!(err.contains("12 images of 160×160 need at least"), "{err}");
    assert!(
        err.contains("--memory SIZE"),
        "the CLI names its flag: {err}"
    );
    assert!(!out.exists(), "no output for a refused run");
    // 6.1 MiB at one row per band: 7 MiB gives bands of some 60 rows
    let banded = dir.join("banded");
    let (ok, _, err) = photostereo(&[
        "run",
        s(&data),
        "--sphere",
        s(&sphere),
        "-o",
        s(&banded),
        "--memory",
        "7M",
    ]);
    assert!(ok, "{err}");
    assert!(err.contains("memory plan: about"), "{err}");
    assert!(err.contains("bands of"), "read in several bands: {err}");
    let one = dir.join("one");
    let (ok, _, err) = photostereo(&["run", s(&data), "--sphere", s(&sphere), "-o", s(&one)]);
    assert!(ok, "{err}");
    assert!(err.contains("read in one band"), "{err}");
    let a = std::fs::read(banded.join("normals.npy")).unwrap();
    let b = std::fs::read(one.join("normals.npy")).unwrap();
    assert!(
        a == b,
        "the same normals, byte for byte, in bands or in one"
    );
    let a = std::fs::read(banded.join("depth.npy")).unwrap();
    let b = std::fs::read(one.join("depth.npy")).unwrap();
    assert!(a == b, "the same depth, byte for byte");
}
