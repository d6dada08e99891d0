//! Images as cameras make them (issue 24) on renders the project did not make: Mitsuba 3's
//! rough aluminium (`tests/data/mitsuba_conductor`, the material of the hidden
//! metal) and the shared Lambertian and rough plastic (`../shared/data`), sphere r = 100
//! → bumpy blob, 20 lights. Both folders are exposed for the brightest highlight of the
//! two and put through the camera model of `synth::camera` (8-bit, blur, black level,
//! noise); each case is scored by `common::camera_case::check` (the default never worse
//! than the lookup alone by more than 2%, better than the nearest neighbour, within a
//! bound, circle found within 0.1 / 0.15 px). The shared cases skip when `../shared` is
//! absent.

mod common;
use common::camera_case::{camera, check, check_within, export_if_asked, mean_error, Case};
use common::resample::rescale;
use photostereo::io::{self, LoadOptions};
use photostereo::lut::{self, BuildOptions, Table};
use photostereo::progress::NoProgress;
use photostereo::spatial;
use photostereo::sphere::Circle;
use photostereo::synth::{camera::develop, Camera};
use photostereo::ImageStack;
use std::path::{Path, PathBuf};

const CIRCLE: Circle = Circle {
    cx: 128.0,
    cy: 128.0,
    radius: 100.0,
};

fn conductor_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba_conductor")
}

/// Sphere and target folders as a case, scaled so that the brightest sample of both is 1
/// (full scale): the exposure for the peak.
fn load(sphere_dir: &Path, target_dir: &Path) -> Case {
    let load = |d: &Path| io::load_dataset(d, &LoadOptions::default()).unwrap();
    let (sphere, target) = (load(sphere_dir), load(target_dir));
    let truth = io::read_normals_npy(&target_dir.join("normal_gt.npy")).unwrap();
    let mut case = Case {
        sphere: sphere.stack,
        truth_circle: CIRCLE,
        target: target.stack,
        mask: target.mask.unwrap(),
        truth,
    };
    expose_for_peak(&mut case);
    case
}

/// Scale sphere and target together so that the brightest sample of the two is 1.
fn expose_for_peak(case: &mut Case) {
    let peak = |s: &ImageStack| s.data.iter().fold(0.0f32, |m, &v| m.max(v));
    let gain = 1.0 / peak(&case.sphere).max(peak(&case.target));
    for s in [&mut case.sphere, &mut case.target] {
        s.data.iter_mut().for_each(|v| *v *= gain);
    }
}

/// Keep issue 24's 16 lights: these renders have 20 (rings of 4, 8, 8 at 20°, 40°,
/// 60°), the 20° ring is dropped.
fn drop_the_20_degree_ring(case: &mut Case) {
    let outer: Vec<usize> = (4..20).collect();
    case.sphere = keep_lights(&case.sphere, &outer);
    case.target = keep_lights(&case.target, &outer);
}

fn conductor() -> Case {
    let d = conductor_dir();
    load(&d.join("sphere"), &d.join("target"))
}

/// The shared render of `material` (`diffuse`, `roughplastic`); `None` (a recorded skip)
/// without `../shared`.
fn shared(test: &str, material: &str) -> Option<Case> {
    let sphere = common::shared::path(test, &format!("data/calib_{material}"))?;
    let target = common::shared::path(test, &format!("data/target_{material}"))?;
    Some(load(&sphere, &target))
}

/// The shared render of `material` through `camera` with Gaussian noise of `noise`;
/// `None` (a recorded skip) without `../shared`.
fn shared_through(test: &str, material: &str, camera: Camera, noise: f32) -> Option<Case> {
    Some(develop_case(shared(test, material)?, camera, noise))
}

/// `case` through `camera` with Gaussian noise of `noise` (fraction of full scale);
/// sphere and target get independent noise.
fn develop_case(mut case: Case, camera: Camera, noise: f32) -> Case {
    develop(&mut case.sphere, &camera, noise, 11);
    develop(&mut case.target, &camera, noise, 12);
    case
}

// Measured 2026-12-06 (true circle / circle found); the aluminium's defaults again on
// 2026-12-07, after the contour prior's tilt went from 0.98 ± 0.03 to 0.995 ± 0.01. Issue 24's targets for its hidden
// rough aluminium: clean 16-bit < 0.15°, 8-bit < 1.0°, 8-bit blurred with a black level
// < 1.2°, 1% noise < 2.0°, sphere at half size < 0.30°.

#[test]
fn conductor_16bit() {
    // measured: nearest 0.752 / 0.751°, lookup 0.0238 / 0.0239°, default 0.0231 / 0.0231°
    check("Mitsuba aluminium 16-bit", &conductor(), 0.05);
}

#[test]
fn conductor_8bit_exposed_for_its_peak() {
    // measured: nearest 1.167 / 1.168°, lookup 0.751 / 0.752°, default 0.314 / 0.313°
    // (0.341 / 0.337° with the contour's tilt at 0.98 ± 0.03)
    let case = develop_case(conductor(), camera(8, 0.0, 0.0), 0.0);
    export_if_asked("aluminium_8bit", &case);
    check("Mitsuba aluminium 8-bit", &case, 0.45);
}

#[test]
fn conductor_8bit_blurred_with_black_level() {
    // measured: nearest 1.082 / 1.056°, lookup 0.894 / 0.875°, default 0.292 / 0.286°
    // (0.343 / 0.340° with the contour's tilt at 0.98 ± 0.03; 0.468 / 0.473° before the outline's evidence was weighted by the sphere's measured
    // blur, 2026-12-07); circle found 0.002 px off centre, radius −0.102 px
    let case = develop_case(conductor(), camera(8, 0.8, 0.03), 0.0);
    export_if_asked("aluminium_8bit_blurred", &case);
    check("Mitsuba aluminium 8-bit blur 0.8 black 3%", &case, 0.42);
}

/// The two 8-bit aluminium cases with issue 24's 16 lights (the 20° ring dropped, as
/// for the plastic below), exposed for the peak of the 16. The build of 2026-12-03 (when
/// the issue was filed) gave, on these images and the circle found, 12.88° / 13.68°
/// (default) and 1.13° / 1.06° (`--no-spatial`); the hidden metal 10.7° / 17.04°
/// and 1.90° / 1.74° (docs/accuracy.md, "The camera cases against the build of
/// 2026-12-03").
#[test]
fn conductor_16_lights_8bit() {
    // measured (true / found circle): peak default 0.307 / 0.304°, lookup 0.812 /
    // 0.812°; blurred + black level default 0.303 / 0.286°, lookup 0.903 / 0.911°
    // (0.341 / 0.338° and 0.382 / 0.331° with the contour's tilt at 0.98 ± 0.03;
    // 0.346 / 0.342° and 0.392 / 0.361° with the prior's largest scale at 0.01 too)
    let case = conductor_16_lights();
    let sharp = develop_case(case.clone(), camera(8, 0.0, 0.0), 0.0);
    export_if_asked("aluminium_16_lights_8bit", &sharp);
    check("Mitsuba aluminium 16 lights 8-bit", &sharp, 0.40);
    let blurred = develop_case(case, camera(8, 0.8, 0.03), 0.0);
    export_if_asked("aluminium_16_lights_8bit_blurred", &blurred);
    check(
        "Mitsuba aluminium 16 lights 8-bit blur 0.8 black 3%",
        &blurred,
        0.42,
    );
}

/// The aluminium with the 20° ring of lights dropped (issue 24's 16 lights), exposed for
/// the peak of the 16.
fn conductor_16_lights() -> Case {
    let mut case = conductor();
    drop_the_20_degree_ring(&mut case);
    expose_for_peak(&mut case);
    case
}

/// 1% Gaussian noise, 16-bit, with the 16 lights. The build of 2026-12-03 gave 1.846°
/// (default, circle found) on these images where issue 24 measured 2.79° on its hidden
/// metal: that metal is 1.5× harder than ours at this noise (the Lambertian and plastic
/// analogues: 1.03× and 1.10×), so main's 1.51° here stood for about 2.3° there, above
/// the 2.0°, and 1.32° since the prior's largest scale went from 0.01 to 0.005
/// for about 2.0°, and 0.95° since the contour's tilt went to 0.995 ± 0.01 for about
/// 1.4° (docs/accuracy.md, "The camera cases against the build of 2026-12-03", "The
/// contour's tilt").
#[test]
fn conductor_16_lights_with_one_percent_noise() {
    // measured (true / found circle): default 0.932 / 0.951° (1.285 / 1.322° with the
    // contour's tilt at 0.98 ± 0.03, 1.485 / 1.513° with the prior's largest scale at
    // 0.01 too), lookup 8.76 / 8.75°
    let case = develop_case(conductor_16_lights(), camera(16, 0.0, 0.0), 0.01);
    export_if_asked("aluminium_16_lights_1pct_noise", &case);
    check_within(
        "Mitsuba aluminium 16 lights 1% noise",
        &case,
        1.2,
        [0.1, 0.2],
    );
}

#[test]
fn conductor_with_one_percent_noise() {
    // Gaussian noise of 1% of full scale on sphere and target, 16-bit. measured:
    // nearest 9.32 / 9.31°, lookup 8.63 / 8.64°, default 0.907 / 0.902° (1.548 /
    // 1.509° with the contour's tilt at 0.98 ± 0.03 and the prior's largest scale at
    // 0.01).
    // The circle is checked within 0.2 px, not the 0.15 px issue 24 asks on its blurred
    // 8-bit spheres: on this noisy rim the radius found is −0.166 px with this seed
    // (+0.062 and +0.031 px with two others; at 2% noise no circle is found), a gap of
    // the detector's maximum image under noise, left open (docs/accuracy.md).
    let case = develop_case(conductor(), camera(16, 0.0, 0.0), 0.01);
    export_if_asked("aluminium_1pct_noise", &case);
    check_within("Mitsuba aluminium 1% noise", &case, 1.2, [0.1, 0.2]);
    // noise is not blur: the rim model fits only 63 of this rim's 105 sectors (at 1.06
    // px), so no blur is reported and the outline keeps its weight
    // (`spatial::outline_weight`); the same sphere blurred by 0.8 px reads about 0.75 px
    assert_eq!(photostereo::sphere::rim_blur(&case.sphere, &CIRCLE), None);
    let blurred = develop_case(conductor(), camera(8, 0.8, 0.03), 0.0);
    let blur = photostereo::sphere::rim_blur(&blurred.sphere, &CIRCLE).unwrap();
    assert!((blur - 0.8).abs() < 0.1, "blurred rim read {blur:.3} px");
}

#[test]
fn conductor_with_two_percent_noise() {
    // Gaussian noise of 2% of full scale: the maximum over 20 noisy images lifts the
    // background to the metal rim's level; the circle is found in the blurred mean image
    // (step 6c, "faint disk under noise"; before it, no circle was found). measured:
    // nearest 18.31 / 18.31°, lookup 17.39 / 17.41°, default 1.729 / 1.943° (2.613 /
    // 2.818° with the contour's tilt at 0.98 ± 0.03 and the prior's largest scale at
    // 0.01); circle
    // 0.098 px off centre, radius +0.164 px (five seeds: centre 0.07–0.30 px, radius
    // −0.34 to +0.16 px, hence the looser circle bounds; at 3% noise none is found).
    let case = develop_case(conductor(), camera(16, 0.0, 0.0), 0.02);
    check_within("Mitsuba aluminium 2% noise", &case, 2.5, [0.3, 0.4]);
}

#[test]
fn conductor_sphere_at_half_size() {
    // The sphere area-averaged to r = 50 about its centre; the target as rendered.
    // measured: nearest 1.423 / 1.423°, lookup 0.0640 / 0.0620°, default 0.0633 / 0.0613°
    let mut case = conductor();
    case.sphere = rescale(&case.sphere, &CIRCLE, 0.5, 256, 256);
    case.truth_circle = Circle {
        radius: 50.0,
        ..CIRCLE
    };
    export_if_asked("aluminium_sphere_r50", &case);
    check("Mitsuba aluminium, sphere r 50", &case, 0.1);
}

#[test]
fn shared_plastic_8bit_blurred_with_black_level() {
    // measured: nearest 0.530 / 0.545°, lookup 0.183 / 0.192°, default 0.134 / 0.146°
    // since 2026-12-07, the outline weighted by the sphere's measured blur (0.145 /
    // 0.158° before; 0.167 / 0.178° before the spatial stage's lack-of-fit scaling; before the
    // cast-shadow test measured "dark" above the black level: 0.191° with the circle
    // found); issue 24's target < 0.20°
    let test = "shared_plastic_8bit_blurred_with_black_level";
    let Some(case) = shared_through(test, "roughplastic", camera(8, 0.8, 0.03), 0.0) else {
        return;
    };
    export_if_asked("plastic_8bit_blurred", &case);
    check("Mitsuba plastic 8-bit blur 0.8 black 3%", &case, 0.16);
}

#[test]
fn shared_lambertian_8bit_with_black_level() {
    // The black level alone: every unlit sample sits at 8/255, above the dark level
    // 0.03 × peak, so the cast-shadow test must measure "dark" above each light's floor
    // (`lut::Table::floors`), and the outline's coverage divide the light above it
    // (`lut::coverage_refit`). measured: nearest 0.533 / 0.533°, lookup 0.0653 / 0.0653°,
    // default 0.0557 / 0.0557° (with the floor in the cast-shadow test only: lookup
    // 0.0723°, default 0.0629°; before both, circle found: lookup 0.137°, default 0.127°)
    let test = "shared_lambertian_8bit_with_black_level";
    let Some(case) = shared_through(test, "diffuse", camera(8, 0.0, 0.03), 0.0) else {
        return;
    };
    check("Mitsuba Lambertian 8-bit black 3%", &case, 0.07);
}

#[test]
fn shared_lambertian_and_plastic_with_one_percent_noise() {
    // Gaussian noise of 1% of full scale, 16-bit. measured: Lambertian nearest 0.665 /
    // 0.664°, lookup 0.350 / 0.350°, default 0.140 / 0.139°; plastic nearest 0.820 /
    // 0.821°, lookup 0.596 / 0.596°, default 0.218 / 0.217° (issue 24's targets on its
    // hidden renders: < 0.22° and < 0.30°)
    let test = "shared_lambertian_and_plastic_with_one_percent_noise";
    for (material, bound) in [("diffuse", 0.17), ("roughplastic", 0.26)] {
        let Some(case) = shared_through(test, material, camera(16, 0.0, 0.0), 0.01) else {
            return;
        };
        export_if_asked(&format!("{material}_1pct_noise"), &case);
        check(&format!("Mitsuba {material} 1% noise"), &case, bound);
    }
}

/// `stack` with only the lights `lights` (indices), in that order.
fn keep_lights(stack: &ImageStack, lights: &[usize]) -> ImageStack {
    let mut out = ImageStack::zeros(stack.width, stack.height, lights.len());
    out.names = lights.iter().map(|&l| stack.names[l].clone()).collect();
    for p in 0..stack.width * stack.height {
        let src = stack.pixel_flat(p);
        for (d, &l) in out.pixel_flat_mut(p).iter_mut().zip(lights) {
            *d = src[l];
        }
    }
    out
}

#[test]
fn shared_plastic_16_lights_blurred_with_black_level() {
    // Issue 24's hidden cases use 16 lights; these renders have 20 (rings of 4, 8, 8 at
    // 20°, 40°, 60°): the 20° ring dropped. measured: nearest 0.531 / 0.546°, lookup
    // 0.209 / 0.219°, default 0.145 / 0.157° since 2026-12-07, the outline weighted by the
    // sphere's measured blur (0.161 / 0.174° before; before the spatial stage's
    // lack-of-fit scaling, circle found: 0.208°, issue 24's target < 0.20° missed)
    let test = "shared_plastic_16_lights_blurred_with_black_level";
    let Some(mut case) = shared(test, "roughplastic") else {
        return;
    };
    drop_the_20_degree_ring(&mut case);
    let case = develop_case(case, camera(8, 0.8, 0.03), 0.0);
    export_if_asked("plastic_16_lights_8bit_blurred", &case);
    check(
        "Mitsuba plastic 16 lights, 8-bit blur 0.8 black 3%",
        &case,
        0.17,
    );
}

/// Mean errors of the textured plastic looked up with `--normalize` (on this shiny
/// table: the diffuse/specular split) and with brightness-normalised matching followed
/// by the spatial stage (`--normalize --no-split`), table on the true circle.
fn albedo_options(case: &Case) -> (f64, f64) {
    let table = Table::build(&case.sphere, &CIRCLE, &BuildOptions::default()).unwrap();
    let tables = std::slice::from_ref(&table);
    let documented = lut::Options {
        normalize: true,
        split_if_specular: true,
        ..lut::Options::default()
    };
    let split = lut::solve(&case.target, &case.mask, tables, &documented, &NoProgress).unwrap();
    let plain = lut::Options {
        normalize: true,
        ..lut::Options::default()
    };
    let out = lut::solve(&case.target, &case.mask, tables, &plain, &NoProgress).unwrap();
    let noise = spatial::NoiseModel::estimate(&case.target, &case.mask);
    let opts = spatial::Options::default();
    let sp = spatial::solve_table(&case.target, &case.mask, &table, &out, &noise, &opts).unwrap();
    (
        mean_error(&split.normals, case),
        mean_error(&sp.normals, case),
    )
}

#[test]
fn textured_plastic_with_a_black_level() {
    // The textured rough plastic (albedo 0.11–0.85, `tests/data/mitsuba_textured_plastic`)
    // against the shared plastic sphere. A fitted brightness scales only the light above
    // the camera's black level (`lut::black_level`). measured (split / normalised +
    // spatial): 16-bit 0.237 / 0.674°; 16-bit black 3% 0.237 / 0.672° (before: 2.475 /
    // 3.595°); 8-bit blur 0.8 black 3% 0.489 / 0.802° (before: 2.270 / 3.758°)
    let test = "textured_plastic_with_a_black_level";
    let Some(sphere) = common::shared::path(test, "data/calib_roughplastic") else {
        return;
    };
    let textured =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba_textured_plastic");
    let clean = load(&sphere, &textured);
    let (split0, spatial0) = albedo_options(&clean);
    let rows = [
        ("16-bit, black 3%", camera(16, 0.0, 0.03)),
        ("8-bit, blur 0.8 px, black 3%", camera(8, 0.8, 0.03)),
    ];
    let got: Vec<(f64, f64)> = rows
        .iter()
        .map(|(_, cam)| albedo_options(&develop_case(clean.clone(), *cam, 0.0)))
        .collect();
    println!("textured plastic, 16-bit: split {split0:.3}°, normalised + spatial {spatial0:.3}°");
    for ((name, _), (split, sp)) in rows.iter().zip(&got) {
        println!("textured plastic, {name}: split {split:.3}°, normalised + spatial {sp:.3}°");
    }
    // the black level alone costs nothing; the camera's 8 bits and blur some
    assert!(
        got[0].0 < 1.03 * split0 && got[0].1 < 1.03 * spatial0,
        "{got:?}"
    );
    assert!(got[1].0 < 0.55 && got[1].1 < 0.9, "{got:?}");
}
