//! End-to-end `photostereo integrate`: files in, depth/PNG/mesh out; bad input leaves
//! no output behind.

use photostereo::image::{pixel_to_xy, Image};
use photostereo::{io, Mask, NormalMap};
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_photostereo"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ps-integrate-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A sphere of radius 30 in a 80x64 image, its mask, one NaN normal inside.
fn write_inputs(dir: &Path) -> (PathBuf, PathBuf, Mask) {
    let (w, h, rad) = (80, 64, 30.0f64);
    let mask = Mask::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        x * x + y * y < (rad - 2.0).powi(2)
    });
    let mut normals: NormalMap = Image::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        let z = (rad * rad - x * x - y * y).max(0.0).sqrt();
        [(x / rad) as f32, (y / rad) as f32, (z / rad) as f32]
    });
    normals.data[32 * w + 50] = [f32::NAN, 0.0, 1.0];
    let (n, m) = (dir.join("normals.npy"), dir.join("mask.npy"));
    io::write_normals(&n, &normals).unwrap();
    io::write_mask_npy(&m, &mask).unwrap();
    (n, m, mask)
}

#[test]
fn lsq_with_mask_writes_depth_png_and_ply() {
    let dir = tmp("ok");
    let (n, m, mask) = write_inputs(&dir);
    let out = bin()
        .arg("integrate")
        .arg(&n)
        .arg("--mask")
        .arg(&m)
        .arg("-o")
        .arg(dir.join("depth.npy"))
        .arg("--mesh")
        .arg(dir.join("shape.ply"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: 1 normals"),
        "clamp warning missing: {stderr}"
    );
    let depth = io::read_gray_npy(&dir.join("depth.npy")).unwrap();
    for (d, &inside) in depth.data.iter().zip(&mask.data) {
        assert_eq!(d.is_finite(), inside);
    }
    // Convex: pixel (32, 40) at (0.5, −0.5) lies sqrt(30² − 0.5) − sqrt(30² − 25.5² − 0.5²)
    // = 14.19 pixels above pixel (32, 14) at (−25.5, −0.5).
    let truth = (900.0f32 - 0.5).sqrt() - (900.0f32 - 650.25 - 0.25).sqrt();
    let rise = depth.get(32, 40) - depth.get(32, 14);
    assert!((rise - truth).abs() < 0.1, "centre − rim {rise} vs {truth}");
    assert!(dir.join("depth.png").exists());
    let ply = std::fs::read(dir.join("shape.ply")).unwrap();
    let header = String::from_utf8_lossy(&ply[..300]);
    assert!(
        header.contains(&format!("element vertex {}\n", mask.count())),
        "{header}"
    );
}

#[test]
fn bad_input_fails_without_writing_anything() {
    let dir = tmp("bad");
    let (n, m, _) = write_inputs(&dir);
    let small = dir.join("small.npy");
    io::write_mask_npy(&small, &Mask::full(10, 10)).unwrap();
    let conf = dir.join("conf.npy");
    io::write_gray_npy(&conf, &photostereo::GrayImage::filled(80, 64, 1.0)).unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--mask", small.to_str().unwrap()], "size"),
        (
            vec![
                "--mask",
                m.to_str().unwrap(),
                "--method",
                "dct",
                "--weights",
                conf.to_str().unwrap(),
            ],
            "lsq",
        ),
        (vec!["--method", "poisson"], "path, fc"),
        (vec!["--mesh", "x.stl"], ".ply or .obj"),
    ];
    for (args, expect) in cases {
        let out = bin()
            .arg("integrate")
            .arg(&n)
            .args(&args)
            .arg("-o")
            .arg(dir.join("depth.npy"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(stderr.contains(expect), "{args:?}: {stderr}");
        assert!(
            !dir.join("depth.npy").exists(),
            "{args:?} left a depth file"
        );
    }
}
