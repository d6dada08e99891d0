//! `run --normal-map opengl|directx --tiff` writes files other tools read: a 16-bit
//! normal map whose green follows the convention asked for, and float32 TIFFs equal to
//! the `.npy` maps.

mod common;

use common::{photostereo, photostereo_ok, s, scratch};
use photostereo::io;

#[test]
fn normal_maps_and_float_tiffs_match_the_npy_maps() {
    let dir = scratch("exports", "blob");
    let data = dir.join("data");
    photostereo_ok(&[
        "-q",
        "synth",
        "--material",
        "lambertian",
        "--size",
        "64",
        "-o",
        s(&data),
    ]);
    let normals = |out: &std::path::Path| io::read_normals_npy(&out.join("normals.npy")).unwrap();
    let mut greens = Vec::new();
    for style in ["opengl", "directx"] {
        let out = dir.join(style);
        photostereo_ok(&[
            "-q",
            "run",
            s(&data),
            "--lambertian",
            "--normal-map",
            style,
            "--tiff",
            "-o",
            s(&out),
        ]);
        let n = normals(&out);
        let map = image::open(out.join("normal_map.png")).unwrap();
        assert_eq!(
            map.color(),
            image::ColorType::Rgb16,
            "{style}: not 16-bit RGB"
        );
        let map = map.to_rgb16();
        let mut worst = 0.0f32;
        for (i, v) in n.data.iter().enumerate() {
            if *v == [0.0; 3] {
                continue;
            }
            let px = map.get_pixel((i % n.width) as u32, (i / n.width) as u32).0;
            let decoded = px.map(|c| c as f32 / 65535.0 * 2.0 - 1.0);
            let ny = if style == "directx" {
                -decoded[1]
            } else {
                decoded[1]
            };
            worst = worst.max((decoded[0] - v[0]).abs()).max((ny - v[1]).abs());
            greens.push((style, px[1]));
        }
        assert!(worst < 1e-4, "{style}: normal map off by {worst}");
        let tif = image::open(out.join("normals.tif")).unwrap().to_rgb32f();
        let flat: Vec<f32> = tif.into_raw();
        let npy: Vec<f32> = n.data.iter().flatten().copied().collect();
        assert_eq!(flat, npy, "normals.tif differs from normals.npy");
        let json = std::fs::read_to_string(out.join("run.json")).unwrap();
        assert!(json.contains("normal_map.png") && json.contains("depth.tif"));
    }
    // the same pixel is green-up in one and green-down in the other
    let half = greens.len() / 2;
    let (gl, dx) = (&greens[..half], &greens[half..]);
    assert!(gl
        .iter()
        .zip(dx)
        .all(|(a, b)| (a.1 as i32 + b.1 as i32 - 65535).abs() <= 1));
    let (ok, _, err) = photostereo(&[
        "-q",
        "run",
        s(&data),
        "--lambertian",
        "--normal-map",
        "vulkan",
        "-o",
        s(&dir.join("bad")),
    ]);
    assert!(!ok && err.contains("directx"), "{err}");
}
