//! `photostereo calibrate` and `photostereo normals` end to end: a synthetic dataset with
//! its calibration sphere is written by `photostereo synth` (DiLiGenT layout, ground truth
//! beside the images), the sphere is calibrated, the target solved by lookup and by
//! Lambertian least squares, and the normals read back and compared with the ground truth.
//! Bad input (no sphere, a circle outside the image, K = 2, a table of other lights) must
//! fail with a message naming the thing and the fix, and leave no output file behind.

use std::path::{Path, PathBuf};

use photostereo::image::ImageStack;
use photostereo::io;
use photostereo::lut::Table;
use photostereo::synth::default_lights;
use photostereo::{GrayImage, Mask, NormalMap};

mod common;
use common::{photostereo, s};

fn tmp(name: &str) -> PathBuf {
    common::scratch("lut-cli", name)
}

/// `photostereo synth` into `dir`: a `size`² blob of `material` under `k` lights and, with
/// `sphere`, a calibration sphere of that radius in `dir/sphere` (image side ⌈2R⌉+4).
fn synth(dir: &Path, material: &str, k: usize, size: usize, sphere: Option<f64>) {
    let (k, size) = (k.to_string(), size.to_string());
    let mut args = vec!["-q", "synth", "--material", material, "-k", &k];
    args.extend(["--size", &size, "-o", s(dir)]);
    let r = sphere.map(|r| r.to_string());
    if let Some(r) = &r {
        args.extend(["--calib-sphere", r]);
    }
    let (ok, _, err) = photostereo(&args);
    assert!(ok, "synth failed: {err}");
}

/// Angular error (degrees) of every mask pixel; asserts each estimate is a unit vector.
fn errors(est: &NormalMap, gt: &NormalMap, mask: &Mask) -> Vec<(f64, usize)> {
    assert_eq!((est.width, est.height), (gt.width, gt.height));
    let mut out = Vec::new();
    for (i, (e, g)) in est.data.iter().zip(&gt.data).enumerate() {
        if !mask.data[i] {
            continue;
        }
        let len = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        assert!(
            (len - 1.0).abs() < 1e-3,
            "pixel {i}: normal {e:?} is not a unit vector"
        );
        out.push((common::angle_deg(*e, *g), i));
    }
    out
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    sum / n.max(1) as f64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Parse "cx A, cy B, r C" from the calibrate output.
fn printed_circle(stdout: &str) -> [f64; 3] {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("sphere circle"))
        .expect("the circle is printed");
    let num = |key: &str| -> f64 {
        let rest = &line[line.find(key).unwrap() + key.len()..];
        let end = rest.find([',', ' ']).unwrap_or(rest.len());
        rest[..end].parse().unwrap()
    };
    [num("cx "), num("cy "), num(" r ")]
}

#[test]
fn calibrate_then_lookup_and_lambertian_normals_match_the_ground_truth() {
    let data = tmp("plastic");
    // GGX shiny plastic blob 80², 12 lights; sphere of radius 40 in an 84² image, centre (42, 42)
    synth(&data, "plastic", 12, 80, Some(40.0));
    let lut = calibrate_plastic_sphere(&data);
    let gt = io::read_normals_npy(&data.join("normal_gt.npy")).unwrap();
    let mask = io::read_mask(&data.join("mask.png")).unwrap();
    lookup_matches_the_ground_truth(&data, &lut, &gt, &mask);
    lambertian_robust_beats_plain(&data, &gt, &mask);
}

/// `calibrate` on the sphere of `data`: the circle printed, the overlay and the table.
fn calibrate_plastic_sphere(data: &Path) -> PathBuf {
    let lut = data.join("calib/plastic.lut");
    let (ok, stdout, err) = photostereo(&[
        "calibrate",
        s(&data.join("sphere")),
        "--material",
        "shiny plastic",
        "-o",
        s(&lut),
    ]);
    assert!(ok, "{err}");
    assert!(stdout.contains("sphere circle (detected)"), "{stdout}");
    let [cx, cy, r] = printed_circle(&stdout);
    println!("circle found: cx {cx}, cy {cy}, r {r} (true 42, 42, 40)");
    // noise-free render: within 0.1 px (the printout rounds to 0.01 px)
    assert!((cx - 42.0).abs() < 0.1 && (cy - 42.0).abs() < 0.1 && (r - 40.0).abs() < 0.1);
    assert!(
        data.join("calib/plastic_overlay.png").is_file(),
        "overlay written"
    );
    let overlay = io::read_gray_image(&data.join("calib/plastic_overlay.png"), None);
    assert!(overlay.is_ok(), "overlay is a readable image");
    let table = Table::from_bytes(&std::fs::read(&lut).unwrap()).unwrap();
    assert_eq!(table.k, 12);
    assert_eq!(table.material, "shiny plastic");
    assert_eq!(table.names.first().map(String::as_str), Some("001.png"));
    assert!((table.circle.radius - r).abs() < 0.01);

    lut
}

/// `normals --lut` on the shiny blob: products, confidence range and accuracy.
fn lookup_matches_the_ground_truth(data: &Path, lut: &Path, gt: &NormalMap, mask: &Mask) {
    let out = data.join("lut-out");
    let (ok, _, err) = photostereo(&["normals", s(data), "--lut", s(lut), "-o", s(&out)]);
    assert!(ok, "{err}");
    for f in [
        "normals.npy",
        "normals.png",
        "confidence.npy",
        "residual.npy",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let normals = io::read_normals_npy(&out.join("normals.npy")).unwrap();
    let conf: GrayImage = io::read_gray_npy(&out.join("confidence.npy")).unwrap();
    let err = errors(&normals, gt, mask);
    let all = mean(err.iter().map(|e| e.0));
    let med = median(err.iter().map(|e| e.0).collect());
    let confident: Vec<f64> = err
        .iter()
        .filter(|(_, i)| conf.data[*i] >= 0.5)
        .map(|e| e.0)
        .collect();
    let trusted = mean(confident.iter().copied());
    println!(
        "lookup: mean {all:.3}°, median {med:.3}° over {} pixels; {:.3}° over the {} with confidence ≥ 0.5",
        err.len(),
        trusted,
        confident.len()
    );
    for &(_, i) in &err {
        let c = conf.data[i];
        assert!((0.0..=1.0).contains(&c), "confidence {c} at pixel {i}");
    }
    // A radius-40 table of a 16-bit render: sub-pixel-spacing accuracy inside the table's
    // range; the whole-mask mean is held up by the blob's grazing rim (normals within a few
    // degrees of 90°, beyond the table's 2 px rim), which gets low confidence.
    // measured: median 0.020°, mean 0.472°, confident 0.051° (2393 of 2528 pixels)
    assert!(med < 0.06, "median {med}°");
    assert!(all < 0.75, "whole-mask mean {all}°");
    assert!(confident.len() * 10 >= err.len() * 9, "≥ 90% confident");
    assert!(trusted < 0.15, "mean over confident pixels {trusted}°");
}

/// Lambertian least squares on the same shiny target: with the rejection of shadowed and
/// highlight samples (default) far better than plain least squares.
fn lambertian_robust_beats_plain(data: &Path, gt: &NormalMap, mask: &Mask) {
    let lam = data.join("lambertian-out");
    let plain = data.join("plain-out");
    let (ok, _, err) = photostereo(&["normals", s(data), "--lambertian", "-o", s(&lam)]);
    assert!(ok, "{err}");
    let (ok, _, err) = photostereo(&[
        "normals",
        s(data),
        "--lambertian",
        "--plain",
        "-o",
        s(&plain),
    ]);
    assert!(ok, "{err}");
    for f in ["normals.npy", "normals.png", "albedo.npy"] {
        assert!(lam.join(f).is_file(), "{f} missing");
    }
    let robust = mean(
        errors(
            &io::read_normals_npy(&lam.join("normals.npy")).unwrap(),
            gt,
            mask,
        )
        .into_iter()
        .map(|e| e.0),
    );
    let plain = mean(
        errors(
            &io::read_normals_npy(&plain.join("normals.npy")).unwrap(),
            gt,
            mask,
        )
        .into_iter()
        .map(|e| e.0),
    );
    println!("Lambertian on the shiny target: robust {robust:.3}°, plain {plain:.3}°");
    assert!(robust < 0.5 && plain > 2.0 && plain > 5.0 * robust);
}

#[test]
fn lambertian_normals_and_albedo_of_a_matte_target() {
    let data = tmp("matte");
    synth(&data, "lambertian", 8, 48, None);
    let out = data.join("out");
    let (ok, _, err) = photostereo(&["normals", s(&data), "--lambertian", "-o", s(&out)]);
    assert!(ok, "{err}");
    let gt = io::read_normals_npy(&data.join("normal_gt.npy")).unwrap();
    let mask = io::read_mask(&data.join("mask.png")).unwrap();
    let est = io::read_normals_npy(&out.join("normals.npy")).unwrap();
    let e = errors(&est, &gt, &mask);
    let worst = e.iter().map(|e| e.0).fold(0.0, f64::max);
    let albedo = io::read_gray_npy(&out.join("albedo.npy")).unwrap();
    let albedo_gt = io::read_gray_npy(&data.join("albedo_gt.npy")).unwrap();
    let albedo_err = e
        .iter()
        .map(|&(_, i)| (albedo.data[i] - albedo_gt.data[i]).abs())
        .fold(0.0f32, f32::max);
    println!("matte blob: worst normal error {worst:.4}°, worst albedo error {albedo_err:.2e}");
    // a noise-free 16-bit Lambertian render: only quantisation remains
    assert!(worst < 0.05, "worst error {worst}°");
    // measured 0.028° and 2.6e-5
    assert!(albedo_err < 1e-4, "albedo error {albedo_err}");
}

/// Error, message containing every one of `needles`, and none of `absent` written.
fn assert_refused(args: &[&str], needles: &[&str], absent: &[&Path]) {
    let (ok, _, err) = photostereo(args);
    assert!(!ok, "photostereo {} should fail", args.join(" "));
    for n in needles {
        assert!(err.contains(n), "message lacks `{n}`: {err}");
    }
    for p in absent {
        assert!(!p.exists(), "{} written despite the error", p.display());
    }
}

#[test]
fn calibrate_refuses_no_sphere_a_circle_outside_and_two_lights() {
    let root = tmp("calibrate-bad");
    let lut = root.join("out/s.lut");
    let overlay = root.join("out/s_overlay.png");

    // black images: nothing to find
    let black = root.join("black");
    io::write_dataset(
        &black,
        &ImageStack::zeros(40, 30, 4),
        &default_lights(4),
        None,
        8,
    )
    .unwrap();
    assert_refused(
        &["calibrate", s(&black), "-o", s(&lut)],
        &[
            "no sphere found",
            "uniform",
            "--circle cx,cy,r",
            "--sphere-region",
        ],
        &[&lut, &overlay],
    );

    // a circle that leaves the 34x34 sphere image
    let sphere = root.join("k4");
    synth(&sphere, "plastic", 4, 32, Some(15.0));
    let sphere = sphere.join("sphere");
    assert_refused(
        &[
            "calibrate",
            s(&sphere),
            "--circle",
            "30,17,15",
            "-o",
            s(&lut),
        ],
        &["--circle", "does not lie inside the 34x34 image", "cx,cy,r"],
        &[&lut, &overlay],
    );
    // the same images with a circle inside do calibrate
    let (ok, stdout, err) = photostereo(&[
        "calibrate",
        s(&sphere),
        "--circle",
        "17,17,15",
        "-o",
        s(&lut),
    ]);
    assert!(ok && stdout.contains("sphere circle (given)"), "{err}");
    assert!(lut.is_file() && overlay.is_file());
    std::fs::remove_dir_all(root.join("out")).unwrap();

    // two lights: the sphere is found but no table can be built
    let two = root.join("k2");
    synth(&two, "plastic", 2, 32, Some(15.0));
    assert_refused(
        &["calibrate", s(&two.join("sphere")), "-o", s(&lut)],
        &["expected 3 lights, found 2", "at least 3 images"],
        &[&lut, &overlay],
    );
}

#[test]
fn normals_refuses_a_table_of_other_lights() {
    let root = tmp("normals-bad");
    let data = root.join("k6");
    synth(&data, "plastic", 6, 32, Some(15.0));
    let lut = root.join("s.lut");
    let (ok, _, err) = photostereo(&["calibrate", s(&data.join("sphere")), "-o", s(&lut)]);
    assert!(ok, "{err}");
    let out = root.join("out");
    let products = [
        out.join("normals.npy"),
        out.join("normals.png"),
        out.join("confidence.npy"),
    ];
    let absent: Vec<&Path> = products.iter().map(PathBuf::as_path).collect();

    // another number of lights
    let k5 = root.join("k5");
    synth(&k5, "plastic", 5, 32, None);
    assert_refused(
        &["normals", s(&k5), "--lut", s(&lut), "-o", s(&out)],
        &[
            s(&lut),
            "the table has 6 lights, the target 5",
            "same lights",
        ],
        &absent,
    );

    // the same K but other image names: other lights, or another order
    let renamed = root.join("renamed");
    synth(&renamed, "plastic", 6, 32, None);
    let mut names = String::new();
    for i in 1..=6 {
        let (from, to) = (format!("{i:03}.png"), format!("img_{i:03}.png"));
        std::fs::rename(renamed.join(&from), renamed.join(&to)).unwrap();
        names += &format!("{to}\n");
    }
    std::fs::write(renamed.join("filenames.txt"), names).unwrap();
    assert_refused(
        &["normals", s(&renamed), "--lut", s(&lut), "-o", s(&out)],
        &[
            s(&lut),
            "'001.png' in the table but 'img_001.png'",
            "same order",
        ],
        &absent,
    );

    // two lights: refused by the Lambertian solver too
    let k2 = root.join("k2");
    synth(&k2, "lambertian", 2, 32, None);
    assert_refused(
        &["normals", s(&k2), "--lambertian", "-o", s(&out)],
        &["expected 3 lights, found 2"],
        &absent,
    );
    assert!(!out.exists(), "no output directory after errors");
}

/// Scale a stack by `e` (the exposure a camera would apply).
fn exposed(stack: &ImageStack, e: f32) -> ImageStack {
    let mut s = stack.clone();
    s.data.iter_mut().for_each(|v| *v *= e);
    s
}

#[test]
fn two_tables_give_the_mix_of_two_materials() {
    let root = tmp("mixture");
    let size = 64;
    let (sa, target, spheres) = mixed_scene(size);
    let weights = |i: usize| mix_weights(i, size);
    let luts = write_mixture(&root, &sa, &target, &spheres);
    let out = root.join("out");
    let target_dir = root.join("target");
    let (ok, stdout, err) = photostereo(&[
        "normals",
        s(&target_dir),
        "--lut",
        s(&luts[0]),
        "--lut",
        s(&luts[1]),
        "-o",
        s(&out),
    ]);
    assert!(ok, "{err}");
    assert!(stdout.contains("weights_2.npy: weight of") && stdout.contains("metal.lut"));
    let normals = io::read_normals_npy(&out.join("normals.npy")).unwrap();
    let err = errors(&normals, &sa.normals, &sa.mask);
    let mean_err = mean(err.iter().map(|e| e.0));
    let read = |f: &str| io::read_gray_npy(&out.join(f)).unwrap();
    let (wa, wb) = (read("weights_1.npy"), read("weights_2.npy"));
    let (sigma, conf) = (read("weights_sigma.npy"), read("confidence.npy"));
    let (mut within, mut confident, mut confident_within, mut covered) = (0, 0, 0, 0);
    for &(_, i) in &err {
        let (a, b) = weights(i);
        let e = (wa.data[i] - a).abs().max((wb.data[i] - b).abs());
        within += (e <= 0.05) as usize;
        covered += (e <= (3.0 * sigma.data[i]).max(0.01)) as usize;
        if conf.data[i] >= 0.5 {
            confident += 1;
            confident_within += (e <= 0.05) as usize;
        }
    }
    let n = err.len();
    let pct = |x: usize, of: usize| 100.0 * x as f64 / of as f64;
    println!(
        "mixture through the CLI: normals {mean_err:.3}°; weights within 0.05: {:.2}% of {n} px, \
         {:.2}% of the {:.1}% confident; error within 3σ_w: {:.2}%",
        pct(within, n),
        pct(confident_within, confident),
        pct(confident, n),
        pct(covered, n)
    );
    // a small 16-bit blob whose rim is beyond the tables' 1 px rim: the issue's figures
    // are in the library test (lut_synth two_material_mixture); here the whole chain
    assert!(mean_err < 0.5, "normals {mean_err}°");
    assert!(pct(within, n) > 93.0 && pct(confident, n) > 85.0);
    assert!(pct(confident_within, confident) >= 99.0);
}

/// Weights (matte, metal) of the mixture target at pixel i: varying along the columns.
fn mix_weights(i: usize, size: usize) -> (f32, f32) {
    let u = (i % size) as f32 / (size - 1) as f32;
    (1.0 - 0.5 * u, 0.1 + 0.3 * u)
}

/// The matte blob, the mixture target a·matte + b·metal and the two calibration spheres.
fn mixed_scene(
    size: usize,
) -> (
    photostereo::synth::Scene,
    ImageStack,
    [photostereo::synth::Scene; 2],
) {
    use photostereo::synth::{self, Material, SceneOptions, Shape, ShapeKind};
    let scene = |material| SceneOptions {
        width: size,
        height: size,
        shape: Shape::preset(ShapeKind::Blob, size, size),
        material,
        lights: default_lights(12),
        ..SceneOptions::default()
    };
    let (ma, mb) = (Material::lambertian(0.8), Material::metal());
    let (sa, sb) = (
        synth::render(&scene(ma)).unwrap(),
        synth::render(&scene(mb)).unwrap(),
    );
    let spheres = [ma, mb].map(|m| synth::render_calibration_sphere(&scene(m), 40.0).unwrap());
    let mut target = sa.stack.clone();
    for i in 0..target.pixels() {
        let (a, b) = mix_weights(i, size);
        for (t, v) in target
            .pixel_flat_mut(i)
            .iter_mut()
            .zip(sb.stack.pixel_flat(i))
        {
            *t = a * *t + b * v;
        }
    }
    (sa, target, spheres)
}

/// Write the target and both spheres under one exposure, and `calibrate` both tables.
fn write_mixture(
    root: &Path,
    sa: &photostereo::synth::Scene,
    target: &ImageStack,
    spheres: &[photostereo::synth::Scene; 2],
) -> [PathBuf; 2] {
    // one exposure keeps every image below full scale; the intensities file undoes it
    let peak = [target, &spheres[0].stack, &spheres[1].stack]
        .iter()
        .flat_map(|s| s.data.iter().copied())
        .fold(0.0f32, f32::max);
    let e = 0.98 / peak;
    let mut lights = sa.lights.clone();
    lights.intensities = vec![e; lights.directions.len()];
    io::write_dataset(
        &root.join("target"),
        &exposed(target, e),
        &lights,
        Some(&sa.mask),
        16,
    )
    .unwrap();
    let luts = [root.join("matte.lut"), root.join("metal.lut")];
    for ((sphere, name), lut) in spheres.iter().zip(["matte", "metal"]).zip(&luts) {
        let dir = root.join(name);
        io::write_dataset(&dir, &exposed(&sphere.stack, e), &lights, None, 16).unwrap();
        let mut args = vec!["calibrate", s(&dir), "--material", name, "--rim", "1"];
        // the dark metal sphere shows only its highlights: give its circle (84² image)
        if name == "metal" {
            args.extend(["--circle", "42,42,40"]);
        }
        args.extend(["-o", s(lut)]);
        let (ok, _, err) = photostereo(&args);
        assert!(ok, "{err}");
    }
    luts
}
