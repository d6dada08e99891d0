//! Grazing normals past the table's edge (issue 24, item 3): the project's own clean
//! renders as `photostereo synth --calib-sphere R` writes them (blob target 256², 16
//! lights, 16-bit, exposure `auto`), the circle found as `calibrate` finds it, the default
//! table and the default `normals` (lookup, then the spatial stage). Mean angular error
//! over the whole mask and by band of the true normal's polar angle, for a Lambertian, the
//! GGX plastic and the GGX metal (α 0.2, F₀ 0.9) with a sphere of radius 100 and 50.
//!
//! The same figures: `cargo run --release -p photostereo --example rim_bands -- all`.

mod common;
use common::angle_deg;
use photostereo::lut::{self, BuildOptions, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::{self, DetectOptions};
use photostereo::synth::{self, Camera, Material, SceneOptions, Shape, ShapeKind};
use photostereo::{normals, Mask, NormalMap};

/// Upper edges (degrees) of the bands 0–60, 60–75, 75–80, 80–85, 85–90.
const EDGES: [f64; 5] = [60.0, 75.0, 80.0, 85.0, 90.01];

/// (whole-mask mean, mean by band).
fn score(est: &NormalMap, truth: &NormalMap, mask: &Mask) -> (f64, [f64; 5]) {
    let (mut sums, mut counts, mut all, mut n) = ([0.0; 5], [0usize; 5], 0.0, 0usize);
    for i in (0..mask.data.len()).filter(|&i| mask.data[i]) {
        let t = truth.data[i];
        let e = angle_deg(est.data[i], t);
        let tilt = (t[2] as f64).clamp(-1.0, 1.0).acos().to_degrees();
        let b = EDGES.iter().position(|&hi| tilt < hi).unwrap_or(4);
        sums[b] += e;
        counts[b] += 1;
        all += e;
        n += 1;
    }
    let bands = std::array::from_fn(|b| sums[b] / counts[b].max(1) as f64);
    (all / n as f64, bands)
}

/// `calibrate` + `normals` with their defaults on `material`, sphere of `radius`.
fn case(name: &str, material: Material, radius: f64) -> (f64, [f64; 5]) {
    let mut opts = SceneOptions {
        shape: Shape::preset(ShapeKind::Blob, 256, 256),
        material,
        lights: synth::default_lights(16),
        camera: Camera::quantized(16),
        ..SceneOptions::default()
    };
    // `synth --exposure auto`
    opts.exposure = synth::exposure_for_full_scale(&opts, Some(radius), 0.98)
        .unwrap()
        .min(1.0);
    let target = synth::render(&opts).unwrap();
    let sphere = synth::render_calibration_sphere(&opts, radius).unwrap();
    let detect = DetectOptions {
        mask: Some(sphere.mask.clone()),
        ..DetectOptions::default()
    };
    let circle = sphere::detect(&sphere.stack, &detect).unwrap().circle;
    let table = Table::build(&sphere.stack, &circle, &BuildOptions::default()).unwrap();
    let tables = [table];
    let lookup = lut::Options::default();
    let input = normals::Input::Tables(&tables, &lookup);
    let out = normals::solve(
        &target.stack,
        &target.mask,
        &input,
        &normals::Options::default(),
        &NoProgress,
    )
    .unwrap();
    let (mean, b) = score(&out.normals, &target.normals, &target.mask);
    println!(
        "{name:10} r {radius:3}: {mean:.4}° | 0–60 {:.4}° 60–75 {:.4}° 75–80 {:.4}° \
         80–85 {:.3}° 85–90 {:.3}°",
        b[0], b[1], b[2], b[3], b[4]
    );
    (mean, b)
}

#[test]
fn rough_metal_at_grazing_angles_sphere_r100() {
    let (metal, b) = case("metal", Material::metal(), 100.0);
    // measured 2026-12-03: 0.0531° (80–85° 0.048°, 85–90° 0.109°) with the parametric
    // lobe (`lut/fit/lobe.rs`); 0.0841° (0.594°, 2.48°) with the linear model and its
    // masking factor alone; before that 0.289° (5.5°, 20.4°). Issue 24's target on the
    // hidden render: < 0.15°
    assert!(metal < 0.06, "metal r 100: {metal}°");
    assert!(b[3] < 0.07 && b[4] < 0.13, "metal r 100 bands {b:?}");
    let (lambert, _) = case("lambertian", Material::lambertian(0.8), 100.0);
    let (plastic, _) = case("plastic", Material::shiny_plastic(), 100.0);
    // measured: 0.0179° / 0.0201°, as before the rim change (0.0177° / 0.0201°): inside
    // the table's edge only fits worse than 0.3% are refitted, which keeps the lookup's
    // speed (scikit-learn ratio 15.9x -> 18.5x); refitting every fit beyond θ_c − 24° gave
    // 0.0168° / 0.0194°
    assert!(lambert < 0.0185, "Lambertian r 100: {lambert}°");
    assert!(plastic < 0.0205, "plastic r 100: {plastic}°");
}

#[test]
fn small_sphere_r50() {
    let (metal, b) = case("metal", Material::metal(), 50.0);
    let (lambert, _) = case("lambertian", Material::lambertian(0.8), 50.0);
    let (plastic, _) = case("plastic", Material::shiny_plastic(), 50.0);
    // measured 2026-12-03: metal 0.114° (80–85° 0.753°, 85–90° 1.12°) with the parametric
    // lobe; 0.402° (5.73°, 23.2°) with the linear model alone, 0.547° before it; issue
    // 24's target < 0.30°. Lambertian 0.0321°, plastic 0.0418° (they keep the linear
    // model; before it 0.0320° / 0.0420°; 0.0298° / 0.0395° when every fit beyond
    // θ_c − 24° was refitted, see above)
    assert!(metal < 0.13, "metal r 50: {metal}°");
    assert!(b[3] < 0.85 && b[4] < 1.3, "metal r 50 bands {b:?}");
    assert!(lambert < 0.033, "Lambertian r 50: {lambert}°");
    assert!(plastic < 0.043, "plastic r 50: {plastic}°");
}
