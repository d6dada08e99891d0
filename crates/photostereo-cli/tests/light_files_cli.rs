//! Light files of other tools: an RTI `.lp` file (in the dataset folder or given with
//! `--lights`) and an AliceVision `lights.json` give the same normals as
//! `light_directions.txt`; bad files are refused with the file named.

mod common;
use std::path::{Path, PathBuf};
use std::process::Command;

use photostereo::io;
use photostereo::synth::{self, Material, SceneOptions, Shape, ShapeKind};

const SIZE: usize = 64;

fn tmp(name: &str) -> PathBuf {
    common::scratch("light-files", name)
}

/// A Lambertian blob under 12 lights, written as a DiLiGenT dataset `tmp(name)`.
fn dataset(name: &str) -> PathBuf {
    let opts = SceneOptions {
        width: SIZE,
        height: SIZE,
        shape: Shape::preset(ShapeKind::Blob, SIZE, SIZE),
        material: Material::lambertian(0.8),
        lights: synth::default_lights(12),
        ..Default::default()
    };
    let s = synth::render(&opts).unwrap();
    let dir = tmp(name);
    io::write_dataset(&dir, &s.stack, &s.lights, Some(&s.mask), 16).unwrap();
    dir
}

fn photostereo(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .arg("--quiet")
        .args(args)
        .output()
        .expect("start photostereo");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn run_lambertian(data: &Path, out: &Path, extra: &[&str]) -> (bool, String) {
    let mut args = vec!["run", "--lambertian"];
    args.extend(extra);
    args.extend([data.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    photostereo(&args)
}

fn normals(out: &Path) -> Vec<f32> {
    io::read_normals_npy(&out.join("normals.npy"))
        .unwrap()
        .data
        .into_iter()
        .flatten()
        .collect()
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// The `.lp` text of `dir`'s lights: names as absolute Windows paths of another
/// machine, lines in reverse order (the file says which image goes with which light).
fn lp_text(dir: &Path) -> String {
    let lights = io::read_lights(&dir.join("light_directions.txt")).unwrap();
    let k = lights.len();
    let mut s = format!("{k}\n");
    for i in (0..k).rev() {
        let d = lights.directions[i];
        s += &format!(
            "C:\\captures\\dome 3\\{:03}.png {:.9} {:.9} {:.9}\n",
            i + 1,
            d[0],
            d[1],
            d[2]
        );
    }
    s
}

#[test]
fn an_lp_file_gives_the_normals_of_light_directions_txt() {
    let data = dataset("lp");
    let reference = tmp("lp-ref-out");
    let (ok, err) = run_lambertian(&data, &reference, &[]);
    assert!(ok, "{err}");
    let want = normals(&reference);

    // a dataset whose lights are only in an .lp file: no filenames.txt either
    let lp = lp_text(&data);
    std::fs::write(data.join("capture.lp"), &lp).unwrap();
    let lights_txt = data.with_extension("lights.txt");
    std::fs::rename(data.join("light_directions.txt"), &lights_txt).unwrap();
    std::fs::remove_file(data.join("filenames.txt")).unwrap();
    let out = tmp("lp-out");
    let (ok, err) = run_lambertian(&data, &out, &[]);
    assert!(ok, "{err}");
    let d = max_diff(&normals(&out), &want);
    println!(".lp in the dataset folder: max normal component difference {d:e}");
    assert!(d < 1e-4, "{d}");

    // the same file given with --lights, from elsewhere
    let given = data.with_extension("given.lp");
    std::fs::rename(data.join("capture.lp"), &given).unwrap();
    let out = tmp("lp-given-out");
    let (ok, err) = run_lambertian(&data, &out, &["--lights", given.to_str().unwrap()]);
    assert!(ok, "{err}");
    let d = max_diff(&normals(&out), &want);
    println!("--lights FILE.lp: max normal component difference {d:e}");
    assert!(d < 1e-4, "{d}");
}

#[test]
fn alicevision_lights_json_gives_the_same_normals() {
    let data = dataset("json");
    let reference = tmp("json-ref-out");
    let (ok, err) = run_lambertian(&data, &reference, &[]);
    assert!(ok, "{err}");
    let lights = io::read_lights(&data.join("light_directions.txt")).unwrap();
    let entries: Vec<String> = lights
        .directions
        .iter()
        .enumerate()
        .map(|(i, d)| {
            format!(
                "{{\"lightId\": {i}, \"intensity\": [1.0, 1.0, 1.0], \"direction\": [{}, {}, {}]}}",
                d[0], d[1], d[2]
            )
        })
        .collect();
    let json = format!("{{\"lights\": [{}]}}", entries.join(",\n"));
    std::fs::remove_file(data.join("light_directions.txt")).unwrap();
    std::fs::write(data.join("lights.json"), json).unwrap();
    let out = tmp("json-out");
    let (ok, err) = run_lambertian(&data, &out, &[]);
    assert!(ok, "{err}");
    let d = max_diff(&normals(&out), &normals(&reference));
    println!("lights.json: max normal component difference {d:e}");
    assert!(d < 1e-4, "{d}");
}

#[test]
fn bad_lp_files_are_refused_naming_the_file_and_the_fix() {
    let data = dataset("lp-bad");
    let good = lp_text(&data);
    std::fs::remove_file(data.join("light_directions.txt")).unwrap();
    std::fs::remove_file(data.join("filenames.txt")).unwrap();
    let lp = data.join("dome.lp");
    let mut lines: Vec<String> = good.lines().map(str::to_string).collect();
    let cases: Vec<(String, &[&str])> = vec![
        // the count disagrees with the lines
        (
            format!("13\n{}", lines[1..].join("\n")),
            &["dome.lp", "13", "12"],
        ),
        // a zero vector
        (
            {
                lines[3] = "C:\\captures\\x\\010.png 0 0 0".into();
                lines.join("\n")
            },
            &["dome.lp", "line 4", "zero-length"],
        ),
        // a named image that is not there
        (
            good.replace("\\007.png", "\\107.png"),
            &["107.png", "not found", "dome.lp"],
        ),
        // not a count
        (
            good.replacen("12\n", "twelve\n", 1),
            &["dome.lp", "line 1", "number of images"],
        ),
    ];
    for (i, (text, words)) in cases.iter().enumerate() {
        std::fs::write(&lp, text).unwrap();
        let out = tmp(&format!("lp-bad-out-{i}"));
        let (ok, err) = run_lambertian(&data, &out, &[]);
        assert!(!ok, "case {i} accepted");
        for w in *words {
            assert!(err.contains(w), "case {i}: no `{w}` in: {err}");
        }
        assert!(!out.join("run.json").exists(), "case {i}: partial output");
    }
    // a --lights file named but missing
    std::fs::write(&lp, &good).unwrap();
    let out = tmp("lp-bad-missing");
    let (ok, err) = run_lambertian(&data, &out, &["--lights", "/nonexistent/x.lp"]);
    assert!(
        !ok && err.contains("/nonexistent/x.lp") && err.contains(".lp"),
        "{err}"
    );
}

/// The light images of `png` (16-bit linear) as sRGB-encoded quality-95 JPEGs in `jpg`,
/// with the same lights and mask.
fn as_srgb_jpegs(png: &Path, jpg: &Path) {
    let ds = io::load_dataset(png, &Default::default()).unwrap();
    let mut names = String::new();
    for light in 0..ds.stack.k {
        let srgb: Vec<u8> = (0..ds.stack.pixels())
            .map(|i| {
                let v = ds.stack.pixel_flat(i)[light].clamp(0.0, 1.0);
                let e = if v <= 0.003_130_8 {
                    12.92 * v
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                };
                (e * 255.0).round() as u8
            })
            .collect();
        let name = format!("{light:03}.jpg");
        let img = image::GrayImage::from_raw(SIZE as u32, SIZE as u32, srgb).unwrap();
        let file = std::fs::File::create(jpg.join(&name)).unwrap();
        let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(file, 95);
        enc.encode_image(&img).unwrap();
        names += &format!("{name}\n");
    }
    std::fs::write(jpg.join("filenames.txt"), names).unwrap();
    for f in ["light_directions.txt", "mask.png"] {
        std::fs::copy(png.join(f), jpg.join(f)).unwrap();
    }
}

/// Mean angle (degrees) between two normal maps over the pixels where both are set.
fn mean_angle_deg(a: &[f32], b: &[f32]) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (p, q) in a.chunks(3).zip(b.chunks(3)) {
        if p.iter().chain(q).all(|v| v.is_finite()) && p[2] != 0.0 && q[2] != 0.0 {
            let cross = [
                p[1] * q[2] - p[2] * q[1],
                p[2] * q[0] - p[0] * q[2],
                p[0] * q[1] - p[1] * q[0],
            ];
            let c = (cross.iter().map(|v| v * v).sum::<f32>()).sqrt() as f64;
            let d = p.iter().zip(q).map(|(x, y)| x * y).sum::<f32>() as f64;
            sum += c.atan2(d).to_degrees();
            n += 1;
        }
    }
    assert!(n > 0, "no pixel with a normal in both maps");
    sum / n as f64
}

#[test]
fn run_reads_camera_jpegs_whole_and_linearises_them() {
    let png = dataset("jpeg-png");
    let jpg = tmp("jpeg-jpg");
    as_srgb_jpegs(&png, &jpg);
    let outs = [
        tmp("jpeg-png-out"),
        tmp("jpeg-jpg-out"),
        tmp("jpeg-lin-out"),
    ];
    for (data, out, extra) in [
        (&png, &outs[0], &[][..]),
        (&jpg, &outs[1], &[][..]),
        (&jpg, &outs[2], &["--response", "linear"][..]),
    ] {
        let (ok, err) = run_lambertian(data, out, extra);
        assert!(ok, "run on {}: {err}", data.display());
    }
    let reference = normals(&outs[0]);
    let srgb = mean_angle_deg(&reference, &normals(&outs[1]));
    let linear = mean_angle_deg(&reference, &normals(&outs[2]));
    assert!(
        srgb < 1.0,
        "JPEG read as sRGB: {srgb:.3} deg from the PNG's normals"
    );
    assert!(
        linear > 3.0 * srgb,
        "read as linear {linear:.3} vs sRGB {srgb:.3} deg"
    );
}
