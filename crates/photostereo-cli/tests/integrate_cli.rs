//! End-to-end `photostereo integrate`: files in, depth/PNG/mesh out; bad input leaves
//! no output behind.

mod common;
use photostereo::image::{pixel_to_xy, Image};
use photostereo::{io, Mask, NormalMap};
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_photostereo"))
}

fn tmp(name: &str) -> PathBuf {
    common::scratch("integrate-cli", name)
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

/// Two spheres (radii 24 and 12 px, centres at depth 0) as separate parts: the
/// mean absolute depth error (px) after one median offset, for each `--parts` value.
fn two_spheres_error(dir: &Path, parts: &str) -> f64 {
    let (w, h) = (100, 60);
    let balls = [(-22.0, 0.0, 24.0), (25.0, 3.0, 12.0)];
    let depth_at = |r: usize, c: usize| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        balls.iter().find_map(|&(cx, cy, rad): &(f64, f64, f64)| {
            let d2 = (x - cx).powi(2) + (y - cy).powi(2);
            (d2 < rad * rad).then(|| ((rad * rad - d2).sqrt(), x - cx, y - cy, rad))
        })
    };
    let mask = Mask::from_fn(w, h, |r, c| depth_at(r, c).is_some());
    let normals: NormalMap = Image::from_fn(w, h, |r, c| match depth_at(r, c) {
        Some((z, x, y, rad)) => [(x / rad) as f32, (y / rad) as f32, (z / rad) as f32],
        None => [0.0, 0.0, 1.0],
    });
    let (n, m) = (dir.join("normals.npy"), dir.join("mask.npy"));
    io::write_normals(&n, &normals).unwrap();
    io::write_mask_npy(&m, &mask).unwrap();
    let out_path = dir.join(format!("depth-{parts}.npy"));
    let out = bin()
        .args(["integrate", "--quiet", "--method", "lsq", "--parts", parts])
        .arg(&n)
        .arg("--mask")
        .arg(&m)
        .arg("-o")
        .arg(&out_path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let est = io::read_gray_npy(&out_path).unwrap();
    let idx: Vec<(usize, f64)> = (0..w * h)
        .filter_map(|i| depth_at(i / w, i % w).map(|d| (i, d.0)))
        .collect();
    let mut diff: Vec<f64> = idx.iter().map(|&(i, t)| t - est.data[i] as f64).collect();
    diff.sort_by(f64::total_cmp);
    let off = diff[diff.len() / 2];
    idx.iter()
        .map(|&(i, t)| (est.data[i] as f64 + off - t).abs())
        .sum::<f64>()
        / idx.len() as f64
}

#[test]
fn parts_places_two_spheres_by_their_contours() {
    let dir = tmp("parts");
    let contour = two_spheres_error(&dir, "contour");
    let separate = two_spheres_error(&dir, "separate");
    println!("two spheres: contour {contour:.3} px, separate {separate:.3} px");
    // Measured: contour 0.108 px (0.096 with the linear extrapolation), separate 1.646 px.
    assert!(contour < 0.25 && separate > 1.0, "{contour} {separate}");
    let bad = bin()
        .args(["integrate", "--parts", "nearest"])
        .arg(dir.join("normals.npy"))
        .arg("-o")
        .arg(dir.join("bad.npy"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && stderr.contains("contour, gap, median, separate"),
        "{stderr}"
    );
    assert!(!dir.join("bad.npy").exists());
}

/// `integrate` and `eval` read a normal map stored as a 16-bit PNG (c = (n + 1)/2, as
/// DiLiGenT's and BiNI's `normal_map.png`): the depth is the `.npy` route's to the
/// encoding's step; a gray PNG given as normals is refused with the reason.
#[test]
fn normal_map_png_is_read_as_normals() {
    let dir = tmp("png");
    let (n, m, mask) = write_inputs(&dir);
    let normals = io::read_normals_npy(&n).unwrap();
    let png = dir.join("normal_map.png");
    io::write_normals_png(&png, &normals, Some(&mask)).unwrap();
    let integrate = |input: &Path, out: &str| {
        let o = bin()
            .arg("integrate")
            .arg(input)
            .arg("--mask")
            .arg(&m)
            .arg("-o")
            .arg(dir.join(out))
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (ok, err) = integrate(&n, "from_npy.npy");
    assert!(ok, "{err}");
    let (ok, err) = integrate(&png, "from_png.npy");
    assert!(ok, "{err}");
    let a = io::read_gray_npy(&dir.join("from_npy.npy")).unwrap();
    let b = io::read_gray_npy(&dir.join("from_png.npy")).unwrap();
    let worst = mask
        .data
        .iter()
        .enumerate()
        .filter(|&(_, &inside)| inside)
        .map(|(i, _)| (a.data[i] - b.data[i]).abs())
        .fold(0.0f32, f32::max);
    // 16-bit steps of 3e-5 in (n_x, n_y) over a 56 px wide sphere; the one NaN normal
    // (flat in the .npy route) is written black, unknown, and read back as 0 (also flat)
    assert!(worst < 2e-3, "depth from the PNG differs by {worst} px");

    let eval = bin()
        .args(["eval", "--json", "--normals"])
        .arg(&png)
        .arg("--gt")
        .arg(&n)
        .arg("--mask")
        .arg(&m)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&eval.stdout);
    assert!(
        eval.status.success(),
        "{}",
        String::from_utf8_lossy(&eval.stderr)
    );
    let mean: f64 = stdout
        .split("\"mean\":")
        .nth(1)
        .and_then(|s| s.split([',', '}']).next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("no mean in {stdout}"));
    assert!(
        mean < 0.01,
        "PNG against npy: {mean}° (one NaN pixel excluded?)"
    );

    let gray = dir.join("gray.png");
    io::write_mask_png(&gray, &mask).unwrap();
    let (ok, err) = integrate(&gray, "gray.npy");
    assert!(!ok && err.contains("not a normal map"), "{err}");
    assert!(!dir.join("gray.npy").exists());
}
