//! No silent wrong answers (issue 29): each mistake below used to exit 0 without a word.
//! A circle a few pixels off given to `calibrate` or `run`; the target given as the
//! sphere; a matte sphere given as `--chrome`; an output folder reused by a run of another
//! mode; and what `run` accepts of its own advice (`--circle`, `--sphere-region`,
//! `--sphere-mask`, `--lut`, `--normalize`). Each case is checked on the terminal and in
//! `run.json`, beside the same command on correct input, which must stay silent.

use std::path::{Path, PathBuf};

use serde_json::Value;

mod common;
use common::{photostereo, photostereo_ok, s};

fn tmp(name: &str) -> PathBuf {
    common::scratch("warnings-cli", name)
}

/// A shiny vase and its sphere (r 100: circle 102, 102, 100 in its 204² images), and a
/// matte (Lambertian) sphere under the same 16 lights.
fn data(root: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let vase = root.join("vase");
    let matte = root.join("matte");
    photostereo_ok(&[
        "-q",
        "synth",
        "--shape",
        "vase",
        "--material",
        "plastic",
        "--size",
        "128",
        "--calib-sphere",
        "100",
        "-o",
        s(&vase),
    ]);
    photostereo_ok(&[
        "-q",
        "synth",
        "--shape",
        "sphere",
        "--material",
        "lambertian",
        "--size",
        "128",
        "-o",
        s(&matte),
    ]);
    (vase.clone(), vase.join("sphere"), matte)
}

fn run_json(out: &Path) -> Value {
    let text = std::fs::read_to_string(out.join("run.json")).expect("read run.json");
    serde_json::from_str(&text).expect("run.json is JSON")
}

fn warnings(out: &Path) -> Vec<String> {
    run_json(out)["warnings"]
        .as_array()
        .expect("warnings list")
        .iter()
        .map(|w| w.as_str().unwrap().to_string())
        .collect()
}

fn has(ws: &[String], what: &str) -> bool {
    ws.iter().any(|w| w.contains(what))
}

const OFF_RIM: &str = "the given circle does not follow the sphere's rim";

/// `calibrate --circle`: the true circle is silent; 3, 5 and 20 px off (centre moved right
/// and radius shrunk by as much, to stay inside the 204² image) warn, and the normal shift
/// the warning states grows with the offset.
#[test]
fn calibrate_warns_on_a_circle_a_few_pixels_off() {
    let root = tmp("calibrate-circle");
    let (_, sphere, _) = data(&root);
    let calibrate = |off: f64| {
        let lut = root.join(format!("c{off}.lut"));
        let circle = format!("{},102,{}", 102.0 + off, 100.0 - off);
        let (ok, out, err) =
            photostereo(&["calibrate", s(&sphere), "--circle", &circle, "-o", s(&lut)]);
        assert!(ok, "calibrate --circle {circle} failed: {err}");
        assert!(
            out.contains("given circle against the images' rim"),
            "{out}"
        );
        err
    };
    assert!(!calibrate(0.0).contains(OFF_RIM), "the true circle warned");
    let mut shifts = Vec::new();
    for off in [3.0, 5.0, 20.0] {
        let err = calibrate(off);
        let line = err
            .lines()
            .find(|l| l.contains(OFF_RIM))
            .unwrap_or_else(|| panic!("{off} px off: no warning in\n{err}"));
        let at = line.find("° off on average").expect("the normal shift");
        let num: String = line[..at]
            .chars()
            .rev()
            .take_while(|c| c.is_ascii_digit() || *c == '.')
            .collect::<String>()
            .chars()
            .rev()
            .collect();
        shifts.push(num.parse::<f64>().unwrap());
    }
    println!("normal shift at 3 / 5 / 20 px: {shifts:?} deg");
    assert!(shifts[0] < shifts[1] && shifts[1] < shifts[2], "{shifts:?}");
}

/// The case on the shared Mitsuba sphere: 148,128,100 (true 128,128,100).
#[test]
fn calibrate_warns_on_the_shared_sphere_20_px_off() {
    let test = "calibrate_warns_on_the_shared_sphere_20_px_off";
    let Some(sphere) = common::shared::path(test, "data/calib_roughplastic") else {
        return;
    };
    let out = tmp("shared-circle");
    for (circle, warns) in [
        ("128,128,100", false),
        ("131,128,100", true),
        ("148,128,100", true),
    ] {
        let lut = out.join(format!("{}.lut", circle.replace(',', "_")));
        let (ok, _, err) =
            photostereo(&["calibrate", s(&sphere), "--circle", circle, "-o", s(&lut)]);
        assert!(ok, "{err}");
        assert_eq!(err.contains(OFF_RIM), warns, "--circle {circle}: {err}");
    }
}

/// `run` takes what its sphere errors recommend, and a circle 3 px off warns in run.json.
#[test]
fn run_takes_the_sphere_flags_and_warns_in_run_json() {
    let root = tmp("run-flags");
    let (vase, sphere, _) = data(&root);
    let out = |n: &str| root.join(n);
    photostereo_ok(&[
        "-q",
        "run",
        "--sphere",
        s(&sphere),
        "--circle",
        "102,102,100",
        s(&vase),
        "-o",
        s(&out("true")),
    ]);
    assert!(
        !has(&warnings(&out("true")), OFF_RIM),
        "{:?}",
        warnings(&out("true"))
    );
    photostereo_ok(&[
        "-q",
        "run",
        "--sphere",
        s(&sphere),
        "--circle",
        "105,102,97",
        s(&vase),
        "-o",
        s(&out("off")),
    ]);
    assert!(
        has(&warnings(&out("off")), OFF_RIM),
        "{:?}",
        warnings(&out("off"))
    );
    // a window and a mask for the search, a table made before, the albedo option
    photostereo_ok(&[
        "-q",
        "run",
        "--sphere",
        s(&sphere),
        "--sphere-region",
        "0,0,204,204",
        "--sphere-mask",
        s(&sphere.join("mask.png")),
        s(&vase),
        "-o",
        s(&out("region")),
    ]);
    let lut = root.join("sphere.lut");
    photostereo_ok(&["-q", "calibrate", s(&sphere), "-o", s(&lut)]);
    photostereo_ok(&[
        "-q",
        "run",
        "--lut",
        s(&lut),
        "--normalize",
        s(&vase),
        "-o",
        s(&out("lut")),
    ]);
    let mean = |o: &str| {
        run_json(&out(o))["angular_error_deg"]["mean"]
            .as_f64()
            .unwrap()
    };
    println!(
        "mean error: region {:.3}°, --lut --normalize {:.3}°",
        mean("region"),
        mean("lut")
    );
    assert!(mean("region") < 1.0 && mean("lut") < 1.0);
}

/// A sphere that is not found: the advice names `run`'s own flags.
#[test]
fn run_advice_names_flags_run_takes() {
    let root = tmp("run-advice");
    let dark = root.join("dark");
    photostereo_ok(&[
        "-q",
        "synth",
        "--shape",
        "sphere",
        "--material",
        "lambertian",
        "--size",
        "64",
        "-o",
        s(&dark),
    ]);
    // the sphere's images all black: nothing to find
    for e in std::fs::read_dir(&dark).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "png") && !p.ends_with("mask.png") {
            let img = image::GrayImage::new(64, 64);
            img.save(&p).unwrap();
        }
    }
    let (ok, _, err) = photostereo(&[
        "run",
        "--sphere",
        s(&dark),
        s(&dark),
        "-o",
        s(&root.join("out")),
    ]);
    assert!(!ok);
    assert!(
        err.contains(
            "hint: restrict the search with --sphere-region x,y,w,h or --sphere-mask FILE"
        ),
        "{err}"
    );
}

/// The target given as the sphere, and a matte sphere given as chrome: each warns; the
/// real sphere and a shiny sphere stay silent.
#[test]
fn a_target_as_sphere_and_a_matte_chrome_sphere_warn() {
    let root = tmp("not-a-sphere");
    let (vase, sphere, matte) = data(&root);
    let run = |args: &[&str], name: &str| {
        let o = root.join(name);
        let mut a = vec!["-q", "run"];
        a.extend_from_slice(args);
        a.extend_from_slice(&["-o", s(&o)]);
        photostereo_ok(&a);
        warnings(&o)
    };
    let ok = run(&["--sphere", s(&sphere), s(&vase)], "sphere");
    assert!(!has(&ok, "this is not a sphere"), "{ok:?}");
    let bad = run(&["--sphere", s(&vase), s(&vase)], "target-as-sphere");
    assert!(has(&bad, "this is not a sphere"), "{bad:?}");
    let matte_as_chrome = run(&["--chrome", s(&matte), s(&matte)], "matte-as-chrome");
    assert!(
        has(&matte_as_chrome, "no mirror highlights"),
        "{matte_as_chrome:?}"
    );
}

/// A rough metal sphere through an 8-bit camera exposed for its highlights, without a
/// mask: its rim is dark under every light (a few grey levels), so the lit region ends
/// well inside the circle; that rim is still brighter than the background, and the
/// sphere is not called "not a sphere" (it was, in every direction: median gap 30.6 px,
/// 2026-12-07). Blurred with a black level too, and in 16 bits with 1% noise; the vase
/// given as the sphere still warns.
#[test]
fn a_dark_rimmed_metal_sphere_without_a_mask_is_a_sphere() {
    let root = tmp("metal-8bit");
    let peak_8bit = ["--bits", "8", "--exposure", "peak"];
    let blurred = ["--blur", "0.8", "--black-level", "0.03"];
    // 1% noise: the maximum of the noisy images lifts the background to 2.3 deviations
    // below the rim, and the sphere was "not a sphere" in 100% of the directions
    // (median gap 31.6 px) before the smoothing of `sphere::checks` (now 4%)
    let camera: [Vec<&str>; 3] = [
        peak_8bit.to_vec(),
        [&peak_8bit[..], &blurred[..]].concat(),
        vec!["--noise", "0.01"],
    ];
    for (i, extra) in camera.iter().enumerate() {
        let sphere = root.join(format!("sphere{i}"));
        let mut args = vec!["-q", "synth", "--shape", "sphere", "--size", "256"];
        args.extend_from_slice(&["--material", "metal"]);
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", s(&sphere)]);
        photostereo_ok(&args);
        let _ = std::fs::remove_file(sphere.join("mask.png"));
        let table = root.join(format!("metal{i}.lut"));
        let (ok, stdout, stderr) = photostereo(&["calibrate", s(&sphere), "-o", s(&table)]);
        let text = stdout + &stderr;
        assert!(ok, "{text}");
        // measured: 0%, 0% and 4% of the directions
        let off = off_circle_percent(&text);
        assert!(off <= if i < 2 { 0.0 } else { 5.0 }, "{off}%: {text}");
        assert!(!text.contains("this is not a sphere"), "{text}");
    }
    let (vase, _, _) = data(&root.join("vase"));
    let _ = std::fs::remove_file(vase.join("mask.png"));
    let (_, _, stderr) = photostereo(&["calibrate", s(&vase), "-o", s(&root.join("vase.lut"))]);
    assert!(stderr.contains("this is not a sphere"), "{stderr}");
}

/// The percentage in `calibrate`'s "outline of the lit region off the circle in N%".
fn off_circle_percent(text: &str) -> f64 {
    let key = "outline of the lit region off the circle in ";
    let at = text
        .find(key)
        .unwrap_or_else(|| panic!("no shape check in {text}"))
        + key.len();
    let digits: String = text[at..]
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    digits
        .parse()
        .unwrap_or_else(|_| panic!("no percentage in {text}"))
}

/// `run` on a rough metal blob through an 8-bit camera (blur 0.8 px, black level 3%)
/// with its sphere: the spatial stage decides about half the mask (said as such), but the
/// lookup's own matches are sound, so no "low confidence" warning. It used to fire on the
/// confidence after the spatial stage (52% below 0.5), calling "not to be trusted" normals
/// that are 0.35° off (2026-12-07). A sphere of another material still warns
/// (`first_hour.rs`).
#[test]
fn an_8bit_metal_target_decided_by_its_neighbours_is_not_low_confidence() {
    let root = tmp("metal-8bit-run");
    let data = root.join("blob");
    let mut args = vec!["-q", "synth", "--shape", "blob", "--material", "metal"];
    args.extend_from_slice(&["--bits", "8", "--blur", "0.8", "--black-level", "0.03"]);
    args.extend_from_slice(&[
        "--exposure",
        "peak",
        "--calib-sphere",
        "100",
        "--size",
        "256",
    ]);
    args.extend_from_slice(&["--seed", "5", "-o", s(&data)]);
    photostereo_ok(&args);
    let out = root.join("out");
    let sphere = data.join("sphere");
    photostereo_ok(&["-q", "run", "--sphere", s(&sphere), s(&data), "-o", s(&out)]);
    let w = warnings(&out);
    assert!(!has(&w, "low confidence"), "{w:?}");
    assert!(has(&w, "most pixels decided by their neighbours"), "{w:?}");
    // measured 0.346°
    let mean = run_json(&out)["angular_error_deg"]["mean"]
        .as_f64()
        .unwrap();
    assert!(mean < 0.4, "{mean}°");
}

/// A `--chrome` run into the folder of a `--sphere` run: the lookup's files are gone,
/// run.json lists what this run wrote and what it removed; a file of the user's stays.
#[test]
fn a_reused_output_folder_keeps_no_stale_files() {
    let root = tmp("stale");
    let (vase, sphere, matte) = data(&root);
    let out = root.join("out");
    photostereo_ok(&["-q", "run", "--sphere", s(&sphere), s(&vase), "-o", s(&out)]);
    assert!(out.join("confidence.npy").is_file() && out.join("sphere_overlay.png").is_file());
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    photostereo_ok(&["-q", "run", "--lambertian", s(&matte), "-o", s(&out)]);
    for stale in ["confidence.npy", "confidence.png", "sphere_overlay.png"] {
        assert!(!out.join(stale).exists(), "{stale} left behind");
    }
    assert!(
        out.join("notes.txt").is_file(),
        "a file run does not write was removed"
    );
    let json = run_json(&out);
    let list = |k: &str| -> Vec<String> {
        json[k]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string())
            .collect()
    };
    let (files, removed) = (list("files"), list("stale_removed"));
    assert!(
        removed.contains(&"confidence.npy".to_string()),
        "{removed:?}"
    );
    for f in &files {
        assert!(
            out.join(f).is_file(),
            "run.json lists {f}, which is not there"
        );
    }
    for e in std::fs::read_dir(&out).unwrap() {
        let name = e.unwrap().file_name().into_string().unwrap();
        assert!(
            files.contains(&name) || name == "notes.txt",
            "{name} is in the folder but not in run.json's files"
        );
    }
}
