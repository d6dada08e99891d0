//! `eval` against known answers: zero error, a known rotation, known mixtures, and
//! depth RMSE after the best offset.

use photostereo::eval::{angular_error_map, angular_errors, depth_rmse};
use photostereo::image::{normalize, Image, Mask, NormalMap};
use photostereo::Error;

/// Normals of a hemisphere of radius 20 over a 48x40 grid; zero outside the disk.
fn sphere(w: usize, h: usize) -> (NormalMap, Mask) {
    let n = Image::from_fn(w, h, |r, c| {
        let (x, y) = photostereo::image::pixel_to_xy(r, c, w, h);
        let (x, y) = (x as f32 / 20.0, y as f32 / 20.0);
        let z2 = 1.0 - x * x - y * y;
        if z2 > 0.0 {
            [x, y, z2.sqrt()]
        } else {
            [0.0; 3]
        }
    });
    let mask = n.map(|v| v[2] > 0.0);
    (n, mask)
}

/// Rodrigues rotation of v about the unit axis a by `deg` degrees.
fn rotate(v: [f32; 3], a: [f32; 3], deg: f64) -> [f32; 3] {
    let (s, c) = deg.to_radians().sin_cos();
    let v = v.map(f64::from);
    let a = a.map(f64::from);
    let dot = v[0] * a[0] + v[1] * a[1] + v[2] * a[2];
    let cross = [
        a[1] * v[2] - a[2] * v[1],
        a[2] * v[0] - a[0] * v[2],
        a[0] * v[1] - a[1] * v[0],
    ];
    std::array::from_fn(|i| (v[i] * c + cross[i] * s + a[i] * dot * (1.0 - c)) as f32)
}

/// A unit vector perpendicular to v.
fn perpendicular(v: [f32; 3]) -> [f32; 3] {
    let t = if v[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    normalize([
        v[1] * t[2] - v[2] * t[1],
        v[2] * t[0] - v[0] * t[2],
        v[0] * t[1] - v[1] * t[0],
    ])
}

#[test]
fn a_map_against_itself_is_zero() {
    let (n, mask) = sphere(48, 40);
    let s = angular_errors(&n, &n, &mask).unwrap();
    assert_eq!((s.mean, s.median, s.max), (0.0, 0.0, 0.0));
    assert_eq!((s.under_5, s.under_10, s.under_20), (100.0, 100.0, 100.0));
    assert_eq!(s.count, mask.count());
    assert_eq!((s.invalid_est, s.skipped_gt), (0, 0));
}

#[test]
fn a_global_rotation_gives_its_angle() {
    let (n, mask) = sphere(48, 40);
    let axis = normalize([1.0, 2.0, 3.0]);
    for deg in [0.5, 7.0, 30.0] {
        // Every normal rotated by `deg` about one axis: the error is not constant
        // (vectors near the axis move less), so rotate each one about its own
        // perpendicular axis instead to get exactly `deg` everywhere ...
        let est = n.map(|&v| {
            if v[2] > 0.0 {
                rotate(v, perpendicular(v), deg)
            } else {
                v
            }
        });
        let s = angular_errors(&est, &n, &mask).unwrap();
        assert!((s.mean - deg).abs() < 1e-3, "{deg}°: mean {}", s.mean);
        assert!((s.median - deg).abs() < 1e-3, "{deg}°: median {}", s.median);
        assert!((s.max - deg).abs() < 1e-3, "{deg}°: max {}", s.max);
        // ... and one global rotation of the whole map gives at most `deg`, exactly
        // `deg` for the normals perpendicular to the axis.
        let est = n.map(|&v| rotate(v, axis, deg));
        let s = angular_errors(&est, &n, &mask).unwrap();
        assert!(
            s.max <= deg + 1e-3 && s.max > 0.9 * deg,
            "{deg}°: max {}",
            s.max
        );
        assert!(s.mean < deg, "{deg}°: mean {}", s.mean);
    }
}

#[test]
fn a_global_rotation_about_the_view_axis_of_tilted_normals() {
    // Normals all perpendicular to the rotation axis: every error equals the angle.
    let n: NormalMap = Image::from_fn(10, 10, |r, c| {
        let t = (r * 10 + c) as f32 * 0.0628;
        [t.cos(), t.sin(), 0.0]
    });
    let mask = Mask::full(10, 10);
    let est = n.map(|&v| rotate(v, [0.0, 0.0, 1.0], 7.0));
    let s = angular_errors(&est, &n, &mask).unwrap();
    assert!(
        (s.mean - 7.0).abs() < 1e-3 && (s.median - 7.0).abs() < 1e-3,
        "{s:?}"
    );
    assert_eq!((s.under_5, s.under_10), (0.0, 100.0));
}

#[test]
fn a_known_mixture_of_errors() {
    // 50 pixels off by 3°, 50 by 12°: mean 7.5, median 7.5 (even count), 50% < 5°.
    let n: NormalMap = Image::filled(10, 10, normalize([0.2, -0.1, 1.0]));
    let axis = perpendicular(n.data[0]);
    let mut est = n.clone();
    for (i, v) in est.data.iter_mut().enumerate() {
        *v = rotate(*v, axis, if i < 50 { 3.0 } else { 12.0 });
    }
    let s = angular_errors(&est, &n, &Mask::full(10, 10)).unwrap();
    assert!(
        (s.mean - 7.5).abs() < 1e-3 && (s.median - 7.5).abs() < 1e-3,
        "{s:?}"
    );
    let rms = ((9.0 + 144.0) / 2.0f64).sqrt();
    assert!((s.rms - rms).abs() < 1e-3, "{s:?}");
    assert_eq!((s.under_5, s.under_10, s.under_20), (50.0, 50.0, 100.0));
}

#[test]
fn invalid_estimates_count_as_180_and_gt_holes_are_skipped() {
    let n: NormalMap = Image::filled(4, 1, [0.0, 0.0, 1.0]);
    let mut est = n.clone();
    est.data[1] = [f32::NAN, 0.0, 1.0];
    est.data[2] = [0.0; 3];
    let mut gt = n.clone();
    gt.data[3] = [0.0; 3];
    let s = angular_errors(&est, &gt, &Mask::full(4, 1)).unwrap();
    assert_eq!((s.count, s.invalid_est, s.skipped_gt), (3, 2, 1));
    assert!((s.mean - 120.0).abs() < 1e-9 && s.median == 180.0, "{s:?}");
    let map = angular_error_map(&est, &gt, &Mask::full(4, 1)).unwrap();
    assert_eq!(&map.data[..3], &[0.0, 180.0, 180.0]);
    assert!(map.data[3].is_nan());
}

#[test]
fn eval_errors() {
    let a: NormalMap = Image::filled(4, 3, [0.0, 0.0, 1.0]);
    let b: NormalMap = Image::filled(3, 4, [0.0, 0.0, 1.0]);
    let err = angular_errors(&a, &b, &Mask::full(3, 4)).unwrap_err();
    assert!(matches!(err, Error::SizeMismatch { .. }), "{err}");
    let err = angular_errors(&a, &a, &Mask::full(3, 4)).unwrap_err();
    assert!(matches!(err, Error::SizeMismatch { .. }), "{err}");
    let err = angular_errors(&a, &a, &Image::filled(4, 3, false)).unwrap_err();
    assert!(matches!(err, Error::EmptyMask { .. }), "{err}");
    let holes: NormalMap = Image::filled(4, 3, [f32::NAN; 3]);
    let err = angular_errors(&a, &holes, &Mask::full(4, 3)).unwrap_err();
    assert!(matches!(err, Error::EmptyMask { .. }), "{err}");
    let d = Image::filled(4, 3, f32::NAN);
    assert!(matches!(
        depth_rmse(&d, &d, &Mask::full(4, 3)),
        Err(Error::EmptyMask { .. })
    ));
    let e = Image::filled(3, 4, 0.0f32);
    assert!(matches!(
        depth_rmse(&d, &e, &Mask::full(4, 3)),
        Err(Error::SizeMismatch { .. })
    ));
}

#[test]
fn depth_of_a_shifted_copy_has_zero_rmse() {
    let gt = Image::from_fn(30, 20, |r, c| {
        if c < 2 {
            f32::NAN
        } else {
            ((r as f32 - 10.0).powi(2) + (c as f32 - 15.0).powi(2)) * -0.05 + 40.0
        }
    });
    let est = gt.map(|v| v - 3.25);
    let mask = Image::from_fn(30, 20, |r, _| r > 0);
    let s = depth_rmse(&est, &gt, &mask).unwrap();
    assert!(s.rmse < 1e-5 && (s.offset - 3.25).abs() < 1e-5, "{s:?}");
    assert_eq!(s.count, 28 * 19);
    // Range over the counted pixels (rows 1..20, columns 2..30): max 40 at (10, 15),
    // min at (1 or 19, 29), 9 rows and 14 columns away: 40 - 0.05 * (81 + 196).
    assert!((s.range - 0.05 * 277.0).abs() < 1e-4, "{s:?}");
}

#[test]
fn depth_rmse_of_known_zero_mean_noise() {
    let gt = Image::from_fn(10, 10, |r, c| (r * 10 + c) as f32 * 0.5);
    // ±0.5 alternating (zero mean) plus a shift of 7: RMSE and MAE are exactly 0.5.
    let est = Image::from_fn(10, 10, |r, c| {
        gt.get(r, c) + 7.0 + if (r + c) % 2 == 0 { 0.5 } else { -0.5 }
    });
    let s = depth_rmse(&est, &gt, &Mask::full(10, 10)).unwrap();
    assert!(
        (s.rmse - 0.5).abs() < 1e-5 && (s.mae - 0.5).abs() < 1e-5,
        "{s:?}"
    );
    assert!((s.offset + 7.0).abs() < 1e-5, "{s:?}");
}
