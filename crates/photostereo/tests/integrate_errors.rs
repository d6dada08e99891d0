//! Bad input: clamped normals are counted and never give NaN depth; empty masks,
//! size mismatches and misplaced weights are clear errors.

mod common;
use common::surfaces::*;
use photostereo::integrate::{choose_method, fft_floor, gradients, solve, Method, Options};
use photostereo::{Error, GrayImage, Mask};

#[test]
fn nan_and_grazing_normals_are_clamped_counted_and_depth_stays_finite() {
    let (w, h) = (80, 60);
    let s = peaks(w, h, Mask::full(w, h));
    let mut normals = s.normals();
    normals.data[5] = [f32::NAN, 0.0, 1.0];
    normals.data[100] = [1.0, 0.0, 0.0]; // n_z = 0
    normals.data[200] = [0.6, 0.0, -0.8]; // facing away
    normals.data[300] = [0.0, 0.0, 0.0]; // unknown
    let (_, _, clamped) = gradients(&normals, &s.mask, 0.05);
    assert_eq!(clamped, 4);
    for m in all_methods() {
        let out = solve(&normals, &s.mask, &opts(m)).unwrap();
        assert_eq!(out.clamped, 4, "{}", m.name());
        assert!(out.depth.data.iter().all(|v| v.is_finite()), "{}", m.name());
        let clean = solve(&s.normals(), &s.mask, &opts(m)).unwrap();
        let change = (out.depth.data.iter().zip(&clean.depth.data))
            .map(|(a, b)| ((a - b) as f64).powi(2))
            .sum::<f64>()
            / (w * h) as f64;
        let rel = change.sqrt() / s.range();
        println!(
            "{:>10}: 4 clamped normals change the depth by {:.3}% of the range",
            m.name(),
            100.0 * rel
        );
        // Four bad normals barely change a 4800-pixel surface for the least-squares
        // methods; a path carries a clamped slope (up to 1/min_nz) along a whole line.
        // measured: path 1.75 %, fc 0.37 %, the others 0.63 %
        let bound = if m == Method::Path { 0.05 } else { 0.01 };
        assert!(rel < bound, "{}: {rel}", m.name());
    }
}

#[test]
fn empty_mask_is_an_error() {
    let s = sphere_cap(10, 10, 20.0, (0.0, 0.0), Mask::full(10, 10));
    let err = solve(
        &s.normals(),
        &Mask::filled(10, 10, false),
        &Options::default(),
    )
    .unwrap_err();
    assert!(matches!(err, Error::EmptyMask { .. }), "{err}");
}

#[test]
fn mask_of_another_size_is_an_error() {
    let s = sphere_cap(10, 10, 20.0, (0.0, 0.0), Mask::full(10, 10));
    let err = solve(&s.normals(), &Mask::full(12, 10), &Options::default()).unwrap_err();
    assert!(
        matches!(err, Error::SizeMismatch { found_w: 12, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("mask"), "{err}");
}

#[test]
fn weights_need_lsq_and_the_right_size() {
    let s = sphere_cap(10, 10, 20.0, (0.0, 0.0), Mask::full(10, 10));
    let mut o = opts(Method::Dct);
    o.weights = Some(GrayImage::filled(10, 10, 1.0));
    let err = solve(&s.normals(), &s.mask, &o).unwrap_err();
    assert!(err.to_string().contains("lsq"), "{err}");
    o.method = Method::Lsq;
    o.weights = Some(GrayImage::filled(9, 10, 1.0));
    let err = solve(&s.normals(), &s.mask, &o).unwrap_err();
    assert!(matches!(err, Error::SizeMismatch { .. }), "{err}");
}

#[test]
fn method_names_round_trip_and_default_choice() {
    for m in all_methods() {
        assert_eq!(Method::from_name(m.name()).unwrap(), m);
    }
    assert!(Method::from_name("poisson").is_err());
    assert_eq!(choose_method(&Mask::full(4, 4)), Method::Dct);
    let mut m = Mask::full(4, 4);
    m.data[0] = false;
    assert_eq!(choose_method(&m), Method::Lsq);
}

#[test]
fn fft_floor_round_trip_is_the_identity() {
    let img = GrayImage::from_fn(48, 36, |r, c| ((r * 7 + c * 3) % 11) as f32 - 5.0);
    let back = fft_floor(&img);
    let err = img
        .data
        .iter()
        .zip(&back.data)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f32::max);
    assert!(err < 1e-4, "{err}");
}
