//! Camera JPEGs as light images: DiLiGenT's ball (`../shared`, skipped when absent),
//! its 16-bit linear PNGs saved as sRGB JPEGs of quality 95 (as a camera would), read
//! back with the default response (sRGB for JPEG) and solved by robust Lambertian
//! photometric stereo: within 0.5° of the PNGs. Read as if linear, it is not.

mod common;
use image::codecs::jpeg::JpegEncoder;
use image::ImageEncoder;
use photostereo::eval::angular_errors;
use photostereo::image::{Mask, NormalMap};
use photostereo::io::{self, LoadOptions, Response};
use photostereo::lambertian;
use std::path::{Path, PathBuf};

/// sRGB encoding (IEC 61966-2-1) of a linear value in [0, 1].
fn srgb_encode(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Copy the dataset `src` to `dst` with every light image as an sRGB JPEG (quality 95)
/// of its linear 16-bit RGB values; the text files and the mask as they are.
fn as_jpegs(src: &Path, dst: &Path) {
    let _ = std::fs::remove_dir_all(dst);
    std::fs::create_dir_all(dst).unwrap();
    let names = std::fs::read_to_string(src.join("filenames.txt")).unwrap();
    let mut jpeg_names = String::new();
    for name in names.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let img = image::open(src.join(name)).unwrap().into_rgb16();
        let bytes: Vec<u8> = img
            .as_raw()
            .iter()
            .map(|&v| (srgb_encode(v as f32 / 65535.0) * 255.0).round() as u8)
            .collect();
        let jpg = Path::new(name).with_extension("jpg");
        let file = std::fs::File::create(dst.join(&jpg)).unwrap();
        JpegEncoder::new_with_quality(std::io::BufWriter::new(file), 95)
            .write_image(
                &bytes,
                img.width(),
                img.height(),
                image::ExtendedColorType::Rgb8,
            )
            .unwrap();
        jpeg_names += &format!("{}\n", jpg.display());
    }
    std::fs::write(dst.join("filenames.txt"), jpeg_names).unwrap();
    for f in ["light_directions.txt", "light_intensities.txt", "mask.png"] {
        std::fs::copy(src.join(f), dst.join(f)).unwrap();
    }
}

/// Robust Lambertian normals of `dir` read with `response`, and the mask.
fn normals(dir: &Path, response: Response) -> (NormalMap, Mask) {
    let opts = LoadOptions {
        response,
        require_lights: true,
        require_mask: true,
        ..LoadOptions::default()
    };
    let data = io::load_dataset(dir, &opts).unwrap();
    let mask = data.mask.unwrap();
    let lights = data.lights.unwrap();
    let out =
        lambertian::solve(&data.stack, &mask, &lights, &lambertian::Options::default()).unwrap();
    (out.normals, mask)
}

#[test]
fn diligent_ball_as_srgb_jpegs_gives_the_normals_of_the_pngs() {
    let test = "diligent_ball_as_srgb_jpegs_gives_the_normals_of_the_pngs";
    let Some(ball) = common::shared::path(test, "data/real/diligent_ball") else {
        return;
    };
    let jpegs = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("ball-jpeg95");
    as_jpegs(&ball, &jpegs);
    let truth = io::read_normals_npy(&ball.join("normal_gt.npy")).unwrap();
    let (png, mask) = normals(&ball, Response::Auto);
    let (jpg, _) = normals(&jpegs, Response::Auto);
    let (raw, _) = normals(&jpegs, Response::Linear);
    let e_png = angular_errors(&png, &truth, &mask).unwrap().mean;
    let e_jpg = angular_errors(&jpg, &truth, &mask).unwrap().mean;
    let e_raw = angular_errors(&raw, &truth, &mask).unwrap().mean;
    let between = angular_errors(&jpg, &png, &mask).unwrap();
    println!(
        "DiLiGenT ball, robust Lambertian, mean error vs truth: 16-bit PNG {e_png:.3}°, \
         sRGB JPEG q95 linearised {e_jpg:.3}°, same JPEGs read as linear {e_raw:.3}°; \
         JPEG vs PNG normals: mean {:.3}°, median {:.3}°",
        between.mean, between.median
    );
    assert!(
        (e_jpg - e_png).abs() < 0.5,
        "JPEG {e_jpg:.3}° vs PNG {e_png:.3}°"
    );
    assert!(
        between.mean < 0.5,
        "JPEG vs PNG normals {:.3}°",
        between.mean
    );
    // without the linearisation the JPEGs are wrong by far more: the test measures it
    assert!(e_raw > e_png + 1.0, "read as linear: {e_raw:.3}°");
}
