//! The shared real photographs and Mitsuba renders load. Each test is skipped (visibly:
//! see `common::shared`) when the shared data folder is absent, and fails when it is there
//! but a dataset in it is missing or unreadable.

mod common;
use photostereo::eval::angular_errors;
use photostereo::io::{self, LoadOptions};
use std::path::PathBuf;

/// `data/<rel>` of the shared folder for the test `test`.
fn dataset(test: &str, rel: &str) -> Option<PathBuf> {
    common::shared::path(test, &format!("data/{rel}"))
}

#[test]
fn real_buddha_loads() {
    let Some(dir) = dataset("real_buddha_loads", "real/buddha") else {
        return;
    };
    let ds = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(
        (ds.stack.width, ds.stack.height, ds.stack.k),
        (512, 340, 12)
    );
    assert_eq!(ds.bit_depth, 8);
    assert_eq!(ds.stack.names.first().map(String::as_str), Some("00.png"));
    let mask = ds.mask.as_ref().unwrap();
    let inside = mask.count();
    assert_eq!(inside, 30528, "mask pixels");
    let lights = ds.lights.as_ref().unwrap();
    assert_eq!(lights.len(), 12);
    // First line of light_directions.txt, normalised (it is already unit).
    let d = lights.directions[0];
    assert!((d[0] - 0.403259).abs() < 1e-5 && (d[2] - 0.778592).abs() < 1e-5);
    assert!(ds.stack.data.iter().all(|v| (0.0..=1.0).contains(v)));
    let max = ds.stack.data.iter().copied().fold(0.0f32, f32::max);
    assert!(max > 0.5, "images look black: max {max}");
    println!(
        "buddha: {inside} mask pixels, {} saturated samples",
        ds.saturated
    );
    assert_eq!(ds.saturated, 3, "saturated samples of the buddha");
}

#[test]
fn real_chrome_loads_without_lights() {
    let Some(dir) = dataset("real_chrome_loads_without_lights", "real/chrome") else {
        return;
    };
    let ds = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(
        (ds.stack.width, ds.stack.height, ds.stack.k),
        (512, 340, 12)
    );
    assert!(ds.lights.is_none());
    assert!(ds.mask.as_ref().unwrap().count() > 1000);
    // Mirror-sphere highlights clip: there are saturated samples inside the mask.
    println!("chrome: {} saturated samples", ds.saturated);
    assert_eq!(ds.saturated, 865, "saturated samples of the chrome sphere");
    let opts = LoadOptions {
        require_lights: true,
        ..LoadOptions::default()
    };
    assert!(io::load_dataset(&dir, &opts).is_err());
}

#[test]
fn mitsuba_render_loads_as_16_bit() {
    let Some(dir) = dataset("mitsuba_render_loads_as_16_bit", "target_roughplastic") else {
        return;
    };
    let ds = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(ds.bit_depth, 16);
    // 001..020.png; lit_mask.png and mask.png are not light images.
    assert_eq!(
        (ds.stack.width, ds.stack.height, ds.stack.k),
        (256, 256, 20)
    );
    assert_eq!(ds.stack.names[19], "020.png");
    let mask = ds.mask.as_ref().unwrap();
    // meta.json: "mask_pixels": 23266.
    assert_eq!(mask.count(), 23266);
    assert_eq!(ds.lights.as_ref().unwrap().len(), 20);
    let gt = io::read_normals_npy(&dir.join("normal_gt.npy")).unwrap();
    assert_eq!((gt.width, gt.height), (256, 256));
    let stats = angular_errors(&gt, &gt, mask).unwrap();
    assert_eq!((stats.mean, stats.count), (0.0, 23266));
    let depth = io::read_gray_npy(&dir.join("depth_gt.npy")).unwrap();
    assert_eq!((depth.width, depth.height), (256, 256));
    let finite_inside = (0..depth.len())
        .filter(|&i| mask.data[i] && depth.data[i].is_finite())
        .count();
    assert_eq!(finite_inside, 23266);
}
