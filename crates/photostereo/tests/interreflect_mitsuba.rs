//! The iteration on independent Mitsuba 3 renders of a 90° V-groove (Lambert 0.8, 80 px
//! deep, flat rims): `/work/shared/data/vgroove_interreflect` (16 bounces) and
//! `vgroove_direct` (direct light only). Skipped when the data are absent.

use ndarray::Array2;
use photostereo::image::{GrayImage, ImageStack, Lights, Mask};
use photostereo::interreflect::{nik, solve, NikOptions, RadiosityOptions};
use photostereo::progress::NoProgress;
use std::path::Path;

const ROOT: &str = "/work/shared/data";

struct Data {
    stack: ImageStack,
    lights: Lights,
    mask: Mask,
    depth_gt: photostereo::DepthMap,
}

fn load(name: &str) -> Option<Data> {
    let dir = Path::new(ROOT).join(name);
    if !dir.join("light_directions.txt").exists() {
        eprintln!("skipping: {} not found", dir.display());
        return None;
    }
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("meta.json")).ok()?).ok()?;
    let scale = meta["scale"].as_f64()? as f32;
    let dirs: Vec<[f32; 3]> = std::fs::read_to_string(dir.join("light_directions.txt"))
        .ok()?
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect();
    let images: Vec<GrayImage> = (1..=dirs.len())
        .map(|i| {
            let img = image::open(dir.join(format!("{i:03}.png")))
                .unwrap()
                .to_luma16();
            let (w, h) = img.dimensions();
            // 16-bit value = radiance × scale, radiance = ρ·n·l.
            GrayImage::from_vec(
                w as usize,
                h as usize,
                img.pixels().map(|p| p[0] as f32 / scale).collect(),
            )
            .unwrap()
        })
        .collect();
    let stack = ImageStack::from_images(&images).ok()?;
    let m = image::open(dir.join("mask.png")).ok()?.to_luma8();
    let mask = Mask::from_vec(
        stack.width,
        stack.height,
        m.pixels().map(|p| p[0] > 0).collect(),
    )
    .ok()?;
    let gt: Array2<f32> = ndarray_npy::read_npy(dir.join("depth_gt.npy")).ok()?;
    let depth_gt =
        photostereo::DepthMap::from_vec(stack.width, stack.height, gt.iter().copied().collect())
            .ok()?;
    Some(Data {
        stack,
        lights: Lights::from_directions(dirs),
        mask,
        depth_gt,
    })
}

fn run(name: &str, block: usize) -> Option<(f32, f32, String)> {
    let d = load(name)?;
    let truth = nik::depth_range(&d.depth_gt, &d.mask);
    let opts = NikOptions {
        radiosity: RadiosityOptions {
            block,
            ..Default::default()
        },
        ..Default::default()
    };
    let out = solve(&d.stack, &d.mask, &d.lights, &opts, &NoProgress).unwrap();
    for (t, it) in out.iterations.iter().enumerate() {
        println!(
            "{name} block {block} iter {t}: concavity {:.3} of truth, mean albedo {:.4}, change {:.4}, fit residual {:.5}",
            it.depth_range / truth,
            it.mean_albedo,
            it.relative_change,
            it.fit_residual
        );
    }
    let before = out.iterations[0].depth_range / truth;
    let after = out.iterations[out.best].depth_range / truth;
    Some((before, after, out.summary()))
}

#[test]
fn mitsuba_vgroove_with_interreflections_deepens_to_the_truth() {
    let Some((before, after, summary)) = run("vgroove_interreflect", 4) else {
        return;
    };
    println!("vgroove_interreflect: concavity {before:.3} → {after:.3} of truth; {summary}");
    assert!(
        before < 0.75,
        "raw concavity {before} should be clearly shallow"
    );
    assert!(
        (after - 1.0).abs() < 0.05,
        "concavity after the iteration {after}"
    );
}

#[test]
fn mitsuba_vgroove_direct_only_is_left_alone() {
    let Some((before, after, summary)) = run("vgroove_direct", 4) else {
        return;
    };
    println!("vgroove_direct: concavity {before:.3} → {after:.3} of truth; {summary}");
    assert!(
        (before - 1.0).abs() < 0.03,
        "direct-only concavity {before}"
    );
}
