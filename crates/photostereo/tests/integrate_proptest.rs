//! Property tests of the integrators on random masks (down to 0 × 0 and all-false):
//! never a panic; a plane's gradients integrate to that plane (up to one constant per
//! connected part) with every method whose boundary assumption a plane satisfies; the
//! depth error does not change when a constant is added to the estimate or the truth.

mod common;
use common::surfaces::{all_methods, opts, Surface};
use photostereo::eval::depth_rmse;
use photostereo::integrate::{self, Method};
use photostereo::{DepthMap, Image, Mask};
use proptest::prelude::*;

/// A mask of size w × h: the union of up to three rectangles (given as fractions of the
/// image), so that it has holes, several parts or none.
fn mask_from(w: usize, h: usize, rects: &[(f64, f64, f64, f64)]) -> Mask {
    Image::from_fn(w, h, |r, c| {
        let (x, y) = (c as f64 / w as f64, r as f64 / h as f64);
        rects
            .iter()
            .any(|&(x0, y0, dx, dy)| x >= x0 && x < x0 + dx && y >= y0 && y < y0 + dy)
    })
}

fn rects() -> impl Strategy<Value = Vec<(f64, f64, f64, f64)>> {
    proptest::collection::vec((0.0..0.8, 0.0..0.8, 0.1..1.0, 0.1..1.0), 0..=3)
}

/// The methods that reproduce a plane on any mask: least squares on the mask's own
/// differences (Lsq), bilateral normal integration (BiNI) and the DCT Poisson solver
/// with the gradients' Neumann boundary (the latter on full rectangles only, see
/// [`plane_on_full_rectangle`]). Path integration counts pixels outside the mask as
/// flat and Frankot–Chellappa assumes a periodic surface: a plane is neither.
fn masked_methods() -> Vec<Method> {
    vec![Method::Lsq, Method::bini()]
}

/// Largest deviation (px) of `depth` from `truth` after removing one mean offset per
/// connected part of the mask.
fn plane_deviation(s: &Surface, depth: &DepthMap) -> f64 {
    let comps = integrate::label_components(&s.mask);
    let mut sum = vec![0.0; comps.count];
    let mut cnt = vec![0usize; comps.count];
    for (i, &l) in comps.labels.iter().enumerate() {
        if l != u32::MAX {
            sum[l as usize] += depth.data[i] as f64 - s.depth[i];
            cnt[l as usize] += 1;
        }
    }
    let mut worst = 0.0f64;
    for (i, &l) in comps.labels.iter().enumerate() {
        if l != u32::MAX {
            let off = sum[l as usize] / cnt[l as usize] as f64;
            worst = worst.max((depth.data[i] as f64 - s.depth[i] - off).abs());
        }
    }
    worst
}

/// Tolerance (px) of `method`'s reconstruction of a plane of depth range `range` (px):
/// the normals are float32 (1e-4 px); BiNI's iterations stop at a relative change of
/// its energy (1e-4), which leaves an error that scales with the surface's extent
/// (measured up to 2.1e-4 of the range over 1000 cases; the other methods 6.4e-6 px):
/// bounded here by 1e-3 of the range.
fn tolerance(method: Method, range: f64) -> f64 {
    match method {
        Method::Bilateral { .. } => 1e-4 + 1e-3 * range,
        _ => 1e-4,
    }
}

fn plane(w: usize, h: usize, mask: Mask, a: f64, b: f64) -> Surface {
    Surface::sample(w, h, mask, |x, y| (a * x + b * y + 3.0, a, b))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Any size (0 × 0 included), any mask: every method returns, never panics, and
    /// gives a finite depth exactly on the mask (NaN outside) when it succeeds.
    #[test]
    fn any_mask_gives_a_depth_on_the_mask_or_an_error(
        w in 0usize..=12, h in 0usize..=12, r in rects(), a in -1.0f64..1.0, b in -1.0f64..1.0,
    ) {
        let s = plane(w, h, mask_from(w, h, &r), a, b);
        let mut all = all_methods();
        all.push(Method::bini());
        for method in all {
            if let Ok(out) = integrate::solve(&s.normals(), &s.mask, &opts(method)) {
                prop_assert_eq!((out.depth.width, out.depth.height), (w, h));
                for (d, &m) in out.depth.data.iter().zip(&s.mask.data) {
                    prop_assert!(d.is_finite() == m, "{:?}: depth {} where mask is {}", method, d, m);
                }
            }
        }
    }

    /// z = a x + b y + c on a random mask integrates back to itself (per part) with the
    /// masked least-squares methods, to the float32 rounding of the normals.
    #[test]
    fn a_plane_integrates_to_a_plane_on_any_mask(
        w in 2usize..=24, h in 2usize..=24, r in rects(), a in -1.5f64..1.5, b in -1.5f64..1.5,
    ) {
        let s = plane(w, h, mask_from(w, h, &r), a, b);
        prop_assume!(s.mask.count() > 0);
        for method in masked_methods() {
            let out = integrate::solve(&s.normals(), &s.mask, &opts(method)).unwrap();
            let dev = plane_deviation(&s, &out.depth);
            prop_assert!(dev < tolerance(method, s.range()),
                "{:?} on {}x{}: {} px off the plane", method, w, h, dev);
        }
    }

    /// On a full rectangle every method but Frankot–Chellappa (periodic) gives the plane.
    #[test]
    fn plane_on_full_rectangle(w in 2usize..=24, h in 2usize..=24, a in -1.5f64..1.5, b in -1.5f64..1.5) {
        let s = plane(w, h, Mask::full(w, h), a, b);
        for method in [Method::Path, Method::Dct, Method::Lsq, Method::bini()] {
            let out = integrate::solve(&s.normals(), &s.mask, &opts(method)).unwrap();
            let dev = plane_deviation(&s, &out.depth);
            prop_assert!(dev < tolerance(method, s.range()),
                "{:?} on {}x{}: {} px off the plane", method, w, h, dev);
        }
    }

    /// Depth is known up to a constant: adding one to the estimate or to the truth does
    /// not change the depth error (`eval::depth_rmse` fits the offset).
    #[test]
    fn a_constant_added_to_the_depth_changes_nothing(
        w in 2usize..=16, h in 2usize..=16, r in rects(), c in -1e3f32..1e3,
    ) {
        let mask = mask_from(w, h, &r);
        prop_assume!(mask.count() > 0);
        let s = Surface::sample(w, h, mask, |x, y| {
            let z = 0.02 * (x * x - y * y) + 0.1 * x;
            (z, 0.04 * x + 0.1, -0.04 * y)
        });
        let out = integrate::solve(&s.normals(), &s.mask, &opts(Method::Lsq)).unwrap();
        let truth: DepthMap = Image::from_fn(w, h, |r, col| s.depth[r * w + col] as f32);
        let shift = |d: &DepthMap| Image::from_fn(w, h, |r, col| *d.get(r, col) + c);
        let base = depth_rmse(&out.depth, &truth, &s.mask).unwrap();
        for (est, gt) in [(shift(&out.depth), truth.clone()), (out.depth.clone(), shift(&truth))] {
            let moved = depth_rmse(&est, &gt, &s.mask).unwrap();
            // the offset is fitted in f64 from f32 depths of magnitude |c|
            prop_assert!((moved.rmse - base.rmse).abs() < 1e-6 * (1.0 + c.abs() as f64),
                "rmse {} vs {} after adding {}", moved.rmse, base.rmse, c);
        }
    }
}
