//! `run` writes curvature maps computed from the normals: on a synthetic sphere of
//! radius R the mean curvature is 1/R (positive: it bulges toward the camera) and the
//! Gaussian curvature 1/R²; a bowl is negative; `--no-curvature` writes none.

mod common;

use common::{photostereo, photostereo_ok, s, scratch};
use photostereo::io;
use std::path::Path;

/// Median of `f(H)` over the pixels within `radius` px of the image centre.
fn median_near_centre(map: &Path, radius: f32, f: impl Fn(f32) -> f32) -> f32 {
    let h = io::read_gray_npy(map).unwrap();
    let (w2, h2) = (h.width as f32 / 2.0, h.height as f32 / 2.0);
    let mut v: Vec<f32> = (0..h.height)
        .flat_map(|r| (0..h.width).map(move |c| (r, c)))
        .filter(|&(r, c)| {
            let (x, y) = (c as f32 + 0.5 - w2, h2 - r as f32 - 0.5);
            (x * x + y * y).sqrt() < radius
        })
        .map(|(r, c)| *h.get(r, c))
        .filter(|v| v.is_finite())
        .map(f)
        .collect();
    assert!(v.len() > 100, "{} finite values near the centre", v.len());
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

#[test]
fn a_synthetic_sphere_has_curvature_one_over_its_radius() {
    let dir = scratch("curvature", "sphere");
    let (data, out) = (dir.join("data"), dir.join("out"));
    // synth's sphere fills 0.45 of the image side: radius 72 px at size 160
    let radius = 72.0;
    photostereo_ok(&[
        "-q",
        "synth",
        "--shape",
        "sphere",
        "--material",
        "plastic",
        "--size",
        "160",
        "--calib-sphere",
        "60",
        "-o",
        s(&data),
    ]);
    photostereo_ok(&[
        "-q",
        "run",
        s(&data),
        "--sphere",
        s(&data.join("sphere")),
        "-o",
        s(&out),
    ]);
    // the centre: the inner half of the disc
    let h_r = median_near_centre(&out.join("curvature.npy"), radius / 2.0, |h| h * radius);
    assert!((h_r - 1.0).abs() < 0.03, "median H R = {h_r:.4}");
    let k_r2 = median_near_centre(&out.join("gaussian_curvature.npy"), radius / 2.0, |k| {
        k * radius * radius
    });
    assert!((k_r2 - 1.0).abs() < 0.06, "median K R^2 = {k_r2:.4}");
    let png = image::open(out.join("curvature.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (160, 160));
    // bulging toward the camera is red (warm) at the centre
    let [r, _, b] = png.get_pixel(80, 80).0;
    assert!(r > b + 50, "centre colour {r}, {b}");
    let json = std::fs::read_to_string(out.join("run.json")).unwrap();
    assert!(json.contains("curvature.npy") && json.contains("mean curvature"));
    let report = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(report.contains("mean curvature from the normals"));

    // without curvature: no maps, the earlier ones removed
    photostereo_ok(&[
        "-q",
        "run",
        s(&data),
        "--sphere",
        s(&data.join("sphere")),
        "-o",
        s(&out),
        "--no-curvature",
    ]);
    assert!(!out.join("curvature.npy").exists() && !out.join("curvature.png").exists());
}

#[test]
fn a_bowl_is_concave_and_a_bad_scale_is_refused_naming_the_flag() {
    let dir = scratch("curvature", "bowl");
    let (data, out) = (dir.join("data"), dir.join("out"));
    photostereo_ok(&[
        "-q",
        "synth",
        "--shape",
        "bowl",
        "--material",
        "lambertian",
        "--size",
        "96",
        "-o",
        s(&data),
    ]);
    photostereo_ok(&[
        "-q",
        "run",
        s(&data),
        "--lambertian",
        "--curvature-sigma",
        "2",
        "-o",
        s(&out),
    ]);
    let h = median_near_centre(&out.join("curvature.npy"), 10.0, |h| h);
    assert!(h < 0.0, "the bowl's centre has H = {h}");
    let (ok, _, err) = photostereo(&[
        "-q",
        "run",
        s(&data),
        "--lambertian",
        "--curvature-sigma",
        "-1",
        "-o",
        s(&dir.join("bad")),
    ]);
    assert!(!ok, "a negative smoothing scale was accepted");
    assert!(err.contains("--curvature-sigma"), "{err}");
    assert!(
        !dir.join("bad").join("normals.npy").exists(),
        "partial output"
    );
}
