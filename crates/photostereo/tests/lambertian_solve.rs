//! Lambertian photometric stereo on `synth` scenes with exact normals.

mod common;
use common::angle_deg;
use photostereo::error::Error;
use photostereo::image::{ImageStack, Lights, Mask, NormalMap};
use photostereo::lambertian::{
    decide_black_level, estimate_black_level, solve, solve_with_black_level, BlackLevel,
    BlackLevelChoice, BlackLevelSums, Options, Output,
};
use photostereo::synth::{default_lights, render, Material, Scene, SceneOptions, Shape, ShapeKind};

/// A noise-free `size`×`size` render of the preset `kind` in `material` under `k`
/// default lights.
fn scene_options(kind: ShapeKind, size: usize, material: Material, k: usize) -> SceneOptions {
    SceneOptions {
        width: size,
        height: size,
        shape: Shape::preset(kind, size, size),
        material,
        lights: default_lights(k),
        ..SceneOptions::default()
    }
}

/// Solve a rendered scene with `opts`.
fn solve_scene(scene: &Scene, opts: &Options) -> Output {
    solve(&scene.stack, &scene.mask, &scene.lights, opts).unwrap()
}

/// The robust solve of `scene` with its mean error and that of plain least squares (degrees).
fn robust_and_plain(scene: &Scene) -> (Output, f64, f64) {
    let robust = solve_scene(scene, &Options::default());
    let plain = solve_scene(scene, &Options::plain());
    let er = mean_error(&robust.normals, &scene.normals, &scene.mask);
    let ep = mean_error(&plain.normals, &scene.normals, &scene.mask);
    (robust, er, ep)
}

/// Pixel `i` holds a finite unit normal.
fn assert_unit(i: usize, n: [f32; 3]) {
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    assert!(
        (len - 1.0).abs() < 1e-4 && len.is_finite(),
        "pixel {i}: normal {n:?} is not unit"
    );
}

/// Mean angular error (degrees) over the mask; also checks every normal is unit.
fn mean_error(found: &NormalMap, truth: &NormalMap, mask: &Mask) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for i in (0..mask.len()).filter(|&i| mask.data[i]) {
        assert_unit(i, found.data[i]);
        sum += angle_deg(found.data[i], truth.data[i]);
        n += 1;
    }
    sum / n as f64
}

#[test]
fn lambertian_blob_is_exact_with_shadow_rejection() {
    // lights up to 60° off axis: many attached and cast shadows, which bias plain LS
    let opts = scene_options(ShapeKind::Blob, 128, Material::lambertian(0.8), 12);
    let scene = render(&opts).unwrap();
    let (robust, er, ep) = robust_and_plain(&scene);
    println!("Lambertian blob, K=12: robust {er:.4}°, plain least squares {ep:.4}°");
    assert!(er < 0.05, "robust mean error {er:.4}°");
    // albedo recovered (the synthetic albedo is 0.8 everywhere on the mask)
    let worst = (0..scene.mask.len())
        .filter(|&i| scene.mask.data[i])
        .map(|i| (robust.albedo.data[i] - scene.albedo.data[i]).abs())
        .fold(0.0f32, f32::max);
    println!("largest albedo error: {worst:.2e}");
    assert!(worst < 1e-3);
}

#[test]
fn shiny_target_outlier_rejection_halves_the_error() {
    // GGX shiny plastic, 48 lights, 0.5% noise
    let opts = SceneOptions {
        noise_sigma: 0.005,
        seed: 3,
        ..scene_options(ShapeKind::Blob, 160, Material::shiny_plastic(), 48)
    };
    let scene = render(&opts).unwrap();
    let (robust, er, ep) = robust_and_plain(&scene);
    println!("shiny plastic blob, K=48, 0.5% noise: robust {er:.3}°, plain least squares {ep:.3}° (ratio {:.1}x)", ep / er);
    // measured: robust 0.308°, plain 5.462° (17.7×)
    assert!(er < 0.6, "robust {er:.3}°");
    assert!(6.0 * er < ep, "robust {er:.3}° vs plain {ep:.3}°");
    let used = robust
        .used_lights
        .data
        .iter()
        .zip(&scene.mask.data)
        .filter(|(_, &m)| m);
    let (s, n) = used.fold((0usize, 0usize), |(s, n), (u, _)| (s + *u as usize, n + 1));
    let mean_used = s as f64 / n as f64;
    println!("mean lights used per pixel: {mean_used:.1} of 48");
    // measured 37.6: highlights and shadows rejected, most lights kept
    assert!(
        (30.0..44.0).contains(&mean_used),
        "mean lights used {mean_used:.1}"
    );
}

#[test]
fn every_mask_pixel_gets_a_unit_normal() {
    // a black hole in the middle of the images: fallback normal (0, 0, 1), albedo 0
    let scene = render(&SceneOptions {
        width: 64,
        height: 64,
        lights: default_lights(8),
        ..SceneOptions::default()
    })
    .unwrap();
    let mut stack = scene.stack.clone();
    let k = stack.k;
    let centre = 32 * 64 + 32;
    stack.data[centre * k..(centre + 1) * k].fill(0.0);
    let out = solve(&stack, &scene.mask, &scene.lights, &Options::default()).unwrap();
    for (i, n) in out.normals.data.iter().enumerate() {
        if scene.mask.data[i] {
            assert_unit(i, *n);
        } else {
            assert_eq!(*n, [0.0; 3]);
        }
    }
    assert_eq!(out.normals.data[centre], [0.0, 0.0, 1.0]);
    assert_eq!(out.albedo.data[centre], 0.0);
}

fn small_stack(k: usize) -> (ImageStack, Mask) {
    (ImageStack::zeros(8, 6, k), Mask::full(8, 6))
}

/// `k` zero images under `lights` are refused with `LightCount { expected, found }`.
fn assert_light_count(k: usize, lights: &Lights, expected: usize, found: usize) {
    let (stack, mask) = small_stack(k);
    let err = solve(&stack, &mask, lights, &Options::default()).unwrap_err();
    println!("{err}");
    assert!(
        matches!(err, Error::LightCount { expected: e, found: f, .. } if (e, f) == (expected, found)),
        "{err}"
    );
}

#[test]
fn two_images_are_refused() {
    let lights = Lights::from_directions(vec![[0.0, 0.0, 1.0], [0.5, 0.0, 1.0]]);
    assert_light_count(2, &lights, 3, 2);
}

#[test]
fn light_count_must_match_the_images() {
    assert_light_count(4, &default_lights(5), 4, 5);
}

#[test]
fn coplanar_lights_and_bad_masks_are_refused() {
    let (stack, mask) = small_stack(3);
    let coplanar =
        Lights::from_directions(vec![[1.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [0.0, 0.0, 1.0]]);
    let err = solve(&stack, &mask, &coplanar, &Options::default()).unwrap_err();
    assert!(matches!(err, Error::InvalidInput { .. }), "{err}");
    let lights = default_lights(3);
    let wrong = Mask::full(7, 6);
    assert!(matches!(
        solve(&stack, &wrong, &lights, &Options::default()),
        Err(Error::SizeMismatch { .. })
    ));
    let empty = Mask::filled(8, 6, false);
    assert!(matches!(
        solve(&stack, &empty, &lights, &Options::default()),
        Err(Error::EmptyMask { .. })
    ));
}

#[test]
fn four_lights_with_one_shadow_stay_exact() {
    // K = 4: the highlight trimming would leave too few samples where one light is in
    // attached shadow; the solver must then keep the three lit samples, not use all four.
    let opts = scene_options(ShapeKind::Sphere, 96, Material::lambertian(0.7), 4);
    let scene = render(&opts).unwrap();
    let out = solve_scene(&scene, &Options::default());
    // pixels lit by at least 3 of the 4 lights
    let lit3 = Mask::from_fn(96, 96, |r, c| {
        let n = *scene.normals.get(r, c);
        *scene.mask.get(r, c)
            && scene
                .lights
                .directions
                .iter()
                .filter(|l| n[0] * l[0] + n[1] * l[1] + n[2] * l[2] > 0.02)
                .count()
                >= 3
    });
    let e = mean_error(&out.normals, &scene.normals, &lit3);
    println!("K=4 Lambertian sphere, pixels lit by >= 3 lights: mean error {e:.4}°");
    assert!(e < 0.01);
}

/// The black level measured in `scene` with the default options.
fn black_level_of(scene: &Scene) -> BlackLevel {
    estimate_black_level(
        &scene.stack,
        &scene.mask,
        &scene.lights,
        &Options::default(),
    )
    .unwrap()
}

#[test]
fn a_black_level_is_measured_and_taken_off() {
    // a camera's dark offset β on every sample: β + ρ e max(0, n·l)
    let opts = scene_options(ShapeKind::Blob, 128, Material::lambertian(0.8), 12);
    let scene = render(&opts).unwrap();
    let clean = solve_scene(&scene, &Options::default());
    let e_clean = mean_error(&clean.normals, &scene.normals, &scene.mask);
    let est = black_level_of(&scene);
    assert!(!est.is_significant(), "{est:?}");
    let black = 0.03f32;
    let mut lifted = scene.clone();
    lifted.stack.data.iter_mut().for_each(|v| *v += black);
    let raw = solve_scene(&lifted, &Options::default());
    let e_raw = mean_error(&raw.normals, &scene.normals, &scene.mask);
    let est = black_level_of(&lifted);
    let taken = Options {
        black_level: est.value,
        ..Options::default()
    };
    let fixed = solve_scene(&lifted, &taken);
    let e_fixed = mean_error(&fixed.normals, &scene.normals, &scene.mask);
    println!(
        "black level 0.03: measured {:.5} (± {:.1e}); error {e_clean:.4}° clean, {e_raw:.3}° \
         with the offset, {e_fixed:.4}° with it taken off",
        est.value, est.standard_error
    );
    // measured: 0.03013 (± 1.4e-4), 0.0000° clean, 1.570° with the offset, 0.0066° with
    // it taken off (the fits' selection near the terminator keeps a few samples whose
    // light is below the offset)
    let off = (est.value - black).abs();
    assert!(
        est.is_significant() && off < 3.0 * est.standard_error,
        "{est:?}"
    );
    assert!(e_raw > 1.0 && e_fixed < e_clean + 0.01, "{e_raw} {e_fixed}");
}

#[test]
fn a_black_level_is_measured_again_with_itself_taken_off() {
    // a textured blob with cast shadows: where the albedo is low, a 3% offset lies above
    // the shadow threshold (5% of the pixel's brightest sample), so the first measurement
    // keeps shadowed samples (they read the offset) and comes out high; measured again on
    // the images with it taken off, the shadows drop out
    let opts = SceneOptions {
        albedo_texture: true,
        cast_shadows: true,
        ..scene_options(ShapeKind::Blob, 128, Material::lambertian(0.8), 16)
    };
    let mut scene = render(&opts).unwrap();
    let black = 0.03f32;
    scene.stack.data.iter_mut().for_each(|v| *v += black);
    let data = (&scene.stack, &scene.mask, &scene.lights);
    let once = black_level_of(&scene);
    let (out, d) =
        solve_with_black_level(BlackLevelChoice::Auto, data, &Options::default(), 1.0).unwrap();
    let with_once = Options {
        black_level: once.value,
        ..Options::default()
    };
    let e_once = mean_error(
        &solve_scene(&scene, &with_once).normals,
        &scene.normals,
        &scene.mask,
    );
    let e = mean_error(&out.normals, &scene.normals, &scene.mask);
    let found = d.measured.unwrap();
    println!(
        "textured blob, black level 0.03: measured once {:.5} ({e_once:.4}°), refined {:.6} \
         (± {:.1e}; {e:.4}°)",
        once.value, d.level, found.standard_error
    );
    // measured: once 0.03094 (0.0639°), refined 0.030000 (± 5e-10; 0.0000°)
    assert!((once.value - black).abs() > 5e-4, "{once:?}");
    assert!(
        (d.level - black).abs() < 1e-4 && found.value == d.level,
        "{d:?}"
    );
    assert!(e < 0.01 && e_once > 0.03, "{e} {e_once}");
}

#[test]
fn a_black_level_under_a_ring_of_lights_is_not_identified() {
    // all lights 40° from the axis: l_z is the same for all, so an offset is a tilt of
    // every normal towards the view, and nothing in the data tells the two apart
    let ring: Vec<[f32; 3]> = (0..8)
        .map(|i| {
            let (s, c) = (40f32.to_radians().sin(), 40f32.to_radians().cos());
            let phi = i as f32 * std::f32::consts::TAU / 8.0;
            [s * phi.cos(), s * phi.sin(), c]
        })
        .collect();
    let opts = SceneOptions {
        lights: Lights::from_directions(ring),
        ..scene_options(ShapeKind::Blob, 96, Material::lambertian(0.8), 8)
    };
    let mut scene = render(&opts).unwrap();
    scene.stack.data.iter_mut().for_each(|v| *v += 0.03);
    let est = black_level_of(&scene);
    println!("ring of lights, black level 0.03: {est:?}");
    assert!(!est.is_significant(), "{est:?}");
}

/// Rows `r0..r1` of `stack` and of `mask`.
fn band_of(stack: &ImageStack, mask: &Mask, r0: usize, r1: usize) -> (ImageStack, Mask) {
    let (w, k) = (stack.width, stack.k);
    let band = ImageStack {
        width: w,
        height: r1 - r0,
        k,
        data: stack.data[r0 * w * k..r1 * w * k].to_vec(),
        names: Vec::new(),
    };
    let m = Mask::from_vec(w, r1 - r0, mask.data[r0 * w..r1 * w].to_vec()).unwrap();
    (band, m)
}

#[test]
fn a_black_level_summed_over_bands_is_that_of_the_whole_stack() {
    // what `run` does on a capture read by row bands: the sums band by band, in order
    let opts = scene_options(ShapeKind::Blob, 96, Material::lambertian(0.8), 12);
    let mut scene = render(&opts).unwrap();
    scene.stack.data.iter_mut().for_each(|v| *v += 0.03);
    let whole = black_level_of(&scene);
    assert!(whole.is_significant(), "{whole:?}");
    let h = scene.stack.height;
    // bands of 1 row, of rows with no mask pixel, uneven, and the whole stack as one
    for rows in [1, 7, 40, h] {
        let mut sums = BlackLevelSums::new(&scene.lights, &Options::default()).unwrap();
        for r0 in (0..h).step_by(rows) {
            let (band, m) = band_of(&scene.stack, &scene.mask, r0, (r0 + rows).min(h));
            sums.add(&band, &m).unwrap();
        }
        assert_eq!(sums.finish(), whole, "bands of {rows} rows");
    }
    // a band of other images than the lights is refused, not mixed in
    let mut sums = BlackLevelSums::new(&scene.lights, &Options::default()).unwrap();
    let few = ImageStack::zeros(scene.stack.width, 2, 3);
    let err = sums.add(&few, &Mask::full(few.width, 2)).unwrap_err();
    assert!(matches!(err, Error::LightCount { .. }), "{err}");
}

/// One solve's images, bit for bit.
fn same_output(a: &Output, b: &Output) -> bool {
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let normals = |o: &Output| bits(&o.normals.data.iter().flatten().copied().collect::<Vec<_>>());
    normals(a) == normals(b)
        && bits(&a.albedo.data) == bits(&b.albedo.data)
        && bits(&a.residual.data) == bits(&b.residual.data)
        && a.used_lights.data == b.used_lights.data
}

#[test]
fn solving_with_a_black_level_choice_is_deciding_then_solving() {
    // auto on a clean capture (one pass: the measuring fits are the solve's) and on one
    // with an offset (taken off, solved again); none and a given level; the robust and
    // the plain solver (the plain one measures on other fits)
    let opts = scene_options(ShapeKind::Blob, 96, Material::lambertian(0.8), 12);
    let clean = render(&opts).unwrap();
    let mut lifted = clean.clone();
    lifted.stack.data.iter_mut().for_each(|v| *v += 0.03);
    let choices = [
        BlackLevelChoice::Auto,
        BlackLevelChoice::None,
        BlackLevelChoice::Given(0.02),
    ];
    for (scene, name) in [(&clean, "clean"), (&lifted, "offset 0.03")] {
        let data = (&scene.stack, &scene.mask, &scene.lights);
        for opts in [Options::default(), Options::plain()] {
            for choice in choices {
                let (out, d) = solve_with_black_level(choice, data, &opts, 1.0).unwrap();
                let expected = decide_black_level(choice, data, &opts, 1.0).unwrap();
                assert_eq!(d, expected, "{name} {choice:?}");
                let o = Options {
                    black_level: expected.level,
                    ..opts.clone()
                };
                let solved = solve_scene(scene, &o);
                assert!(same_output(&out, &solved), "{name} {choice:?}");
            }
        }
        let d = solve_with_black_level(BlackLevelChoice::Auto, data, &Options::default(), 1.0);
        let taken = d.unwrap().1.level;
        // the clean capture's level is not taken, the offset's is (to 3%)
        match name {
            "clean" => assert_eq!(taken, 0.0),
            _ => assert!((taken - 0.03).abs() < 0.03 * 0.03, "{taken}"),
        }
    }
    let refused = solve_with_black_level(
        BlackLevelChoice::Given(0.3),
        (&clean.stack, &clean.mask, &clean.lights),
        &Options::default(),
        1.0,
    );
    assert!(refused.is_err());
}
