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
    // a budget of 2 MiB cannot hold a run: refused, nothing written
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
    // 131.8 MiB at one row per band (128 MiB of it the run's size-independent part,
    // plan::RUN_BYTES), 13.75 KiB per row: 132.5 MiB gives bands of some 50 rows
    let banded = dir.join("banded");
    let (ok, _, err) = photostereo(&[
        "run",
        s(&data),
        "--sphere",
        s(&sphere),
        "-o",
        s(&banded),
        "--memory",
        "132.5M",
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

/// (vertices, faces) from a binary PLY's header.
fn ply_counts(path: &std::path::Path) -> (usize, usize) {
    let bytes = std::fs::read(path).unwrap();
    let end = bytes.windows(10).position(|w| w == b"end_header").unwrap();
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    let count = |name: &str| -> usize {
        let line = header.lines().find(|l| l.starts_with(name)).unwrap();
        line.split(' ').nth(2).unwrap().parse().unwrap()
    };
    (count("element vertex "), count("element face "))
}

#[test]
fn mesh_max_faces_caps_the_mesh_and_says_so() {
    let dir = tmp("mesh-cap");
    let data = dir.join("vase");
    photostereo_ok(&[
        "-q",
        "synth",
        "--shape",
        "vase",
        "--size",
        "160",
        "-k",
        "8",
        "-o",
        s(&data),
    ]);
    let full = dir.join("full");
    let (ok, _, err) = photostereo(&["run", s(&data), "--lambertian", "-o", s(&full)]);
    assert!(ok, "{err}");
    let (nv, nf) = ply_counts(&full.join("mesh.ply"));
    assert!(nf > 10_000, "{nf} faces at full resolution");
    let capped = dir.join("capped");
    let (ok, out, err) = photostereo(&[
        "run",
        s(&data),
        "--lambertian",
        "-o",
        s(&capped),
        "--mesh-max-faces",
        "10000",
    ]);
    assert!(ok, "{err}");
    let (cv, cf) = ply_counts(&capped.join("mesh.ply"));
    assert!(cf <= 10_000 && cf > 2_500, "{cf} faces for a cap of 10000");
    assert!(cv < nv, "{cv} vertices of {nv}");
    assert!(out.contains("the mesh is capped"), "{out}");
    // the depth keeps every pixel
    let a = std::fs::read(full.join("depth.npy")).unwrap();
    let b = std::fs::read(capped.join("depth.npy")).unwrap();
    assert!(a == b, "the same depth with a capped mesh");
}
