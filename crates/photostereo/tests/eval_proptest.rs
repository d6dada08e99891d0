//! Property tests: evaluation of any maps and masks (empty, all-false, NaN) never
//! panics, and its figures stay in range when it succeeds.

use photostereo::eval::{angular_error_map, angular_errors, depth_rmse};
use photostereo::image::{Image, Mask};
use proptest::prelude::*;

fn component() -> impl Strategy<Value = f32> {
    prop_oneof![4 => -1.0f32..1.0, 1 => Just(0.0f32), 1 => Just(f32::NAN), 1 => any::<f32>()]
}

/// (width, height, estimate, ground truth, mask) as flat buffers.
type Maps = (usize, usize, Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<bool>);

fn maps() -> impl Strategy<Value = Maps> {
    (0usize..=6, 0usize..=6).prop_flat_map(|(w, h)| {
        let n = w * h;
        let v = || proptest::collection::vec([component(), component(), component()], n);
        (
            Just(w),
            Just(h),
            v(),
            v(),
            proptest::collection::vec(any::<bool>(), n),
        )
    })
}

proptest! {
    #[test]
    fn normal_eval_never_panics((w, h, e, g, m) in maps()) {
        let est = Image::from_vec(w, h, e).unwrap();
        let gt = Image::from_vec(w, h, g).unwrap();
        let mask: Mask = Image::from_vec(w, h, m).unwrap();
        match angular_errors(&est, &gt, &mask) {
            Ok(s) => {
                prop_assert!(s.count > 0 && s.count <= mask.count());
                prop_assert!((0.0..=180.0).contains(&s.mean), "{:?}", s);
                prop_assert!((0.0..=180.0).contains(&s.median) && s.median <= s.max);
                prop_assert!(s.under_5 <= s.under_10 && s.under_10 <= s.under_20 && s.under_20 <= 100.0);
                prop_assert_eq!(s.count + s.skipped_gt, mask.count());
            }
            Err(_) => prop_assert!(mask.count() == 0 || gt.data.iter().zip(&mask.data)
                .filter(|(_, &m)| m)
                .all(|(n, _)| n.iter().any(|v| !v.is_finite()) || *n == [0.0; 3])),
        }
        let map = angular_error_map(&est, &gt, &mask).unwrap();
        prop_assert!(map.data.iter().all(|v| v.is_nan() || (0.0..=180.0).contains(v)));
        // A mask of another size is an error, not a panic.
        prop_assert!(angular_errors(&est, &gt, &Image::filled(w + 1, h, true)).is_err());
    }

    #[test]
    fn depth_eval_never_panics((w, h, e, g, m) in maps()) {
        let est = Image::from_vec(w, h, e.iter().map(|v| v[0] * 100.0).collect()).unwrap();
        let gt = Image::from_vec(w, h, g.iter().map(|v| v[1] * 100.0).collect()).unwrap();
        let mask: Mask = Image::from_vec(w, h, m).unwrap();
        if let Ok(s) = depth_rmse(&est, &gt, &mask) {
            // MAE <= RMSE up to rounding, which scales with the magnitude of the depths.
            let scale = est.data.iter().chain(&gt.data)
                .filter(|v| v.is_finite())
                .fold(0.0f64, |m, v| m.max(v.abs() as f64));
            prop_assert!(s.count > 0 && s.rmse >= 0.0 && s.range >= 0.0);
            prop_assert!(s.mae <= s.rmse + 1e-12 * (1.0 + scale), "{:?}", s);
        }
        // Against itself the RMSE is zero wherever it is defined.
        if let Ok(s) = depth_rmse(&gt, &gt, &mask) {
            prop_assert!(s.rmse == 0.0 || s.rmse < 1e-6 * s.range.max(1.0), "{:?}", s);
        }
    }
}
