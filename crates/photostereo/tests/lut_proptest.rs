//! Property tests of the lookup on random targets and masks (down to 0 × 0 and
//! all-false): never a panic; the output has the target's shape; every normal in the
//! mask is a unit vector facing the camera half-space, every one outside is zero; the
//! confidence lies in [0, 1]; and the order of the lights does not matter: the same
//! permutation of the table's and the target's lights gives the same normals.

mod common;
use common::lut_scene::{lights, shade, sphere, Brdf};
use photostereo::image::{ImageStack, Mask};
use photostereo::lut::{self, BuildOptions, Method, Options, Table};
use photostereo::progress::NoProgress;
use photostereo::Image;
use proptest::prelude::*;
use std::sync::OnceLock;

const K: usize = 8;
const SHINY: Brdf = Brdf {
    kd: 0.6,
    ks: 0.4,
    shininess: 30.0,
};

/// The sphere (radius 24 px) under `K` lights, its lights in the order `perm`.
fn sphere_stack(perm: &[usize]) -> (ImageStack, photostereo::sphere::Circle) {
    let (stack, circle) = sphere(56, 24.0, &lights(K), SHINY);
    (permuted(&stack, perm), circle)
}

/// `stack` with light i taken from light perm[i].
fn permuted(stack: &ImageStack, perm: &[usize]) -> ImageStack {
    let mut out = ImageStack::zeros(stack.width, stack.height, stack.k);
    for i in 0..stack.pixels() {
        let (src, dst) = (stack.pixel_flat(i), out.pixel_flat_mut(i));
        for (d, &p) in dst.iter_mut().zip(perm) {
            *d = src[p];
        }
    }
    out
}

fn table_for(perm: &[usize]) -> Table {
    let (stack, circle) = sphere_stack(perm);
    Table::build(&stack, &circle, &BuildOptions::default()).unwrap()
}

fn identity_table() -> &'static Table {
    static T: OnceLock<Table> = OnceLock::new();
    T.get_or_init(|| table_for(&(0..K).collect::<Vec<_>>()))
}

fn methods() -> [Method; 3] {
    [
        Method::Refined,
        Method::Nearest,
        Method::InverseDistance { neighbours: 6 },
    ]
}

/// The material's tuple for a random normal (tilt up to 77°).
fn shaded() -> impl Strategy<Value = Vec<f32>> {
    (0.0f64..1.0, 0.0f64..std::f64::consts::TAU).prop_map(|(s, ph)| {
        let th = (s * 0.95).sqrt().asin();
        let n = [
            (th.sin() * ph.cos()) as f32,
            (th.sin() * ph.sin()) as f32,
            th.cos() as f32,
        ];
        let mut out = vec![0.0f32; K];
        shade(n, &lights(K), SHINY, 1.0, &mut out);
        out
    })
}

/// A target of w × h pixels and a random mask; with `any_tuple` each pixel is either a
/// random tuple (any values in [0, 1.5], zeros included) or the material's shading of a
/// random normal, else always the latter.
fn target_of(any_tuple: bool) -> impl Strategy<Value = (ImageStack, Mask)> {
    (0usize..=7, 0usize..=7).prop_flat_map(move |(w, h)| {
        let n = w * h;
        let random = proptest::collection::vec(prop_oneof![3 => 0.0f32..1.5, 1 => Just(0.0f32)], K);
        let pixel = if any_tuple {
            prop_oneof![random, shaded()].boxed()
        } else {
            shaded().boxed()
        };
        (
            proptest::collection::vec(pixel, n),
            proptest::collection::vec(any::<bool>(), n),
        )
            .prop_map(move |(px, m)| {
                let mut stack = ImageStack::zeros(w, h, K);
                stack.data = px.concat();
                (stack, Image::from_vec(w, h, m).unwrap())
            })
    })
}

/// A permutation of 0..K.
fn permutation() -> impl Strategy<Value = Vec<usize>> {
    Just((0..K).collect::<Vec<_>>()).prop_shuffle()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn normals_are_unit_on_the_mask_and_zero_off_it((stack, mask) in target_of(true), normalize in any::<bool>()) {
        for method in methods() {
            let opts = Options { method, normalize, ..Options::default() };
            let out = lut::solve(&stack, &mask, std::slice::from_ref(identity_table()), &opts, &NoProgress);
            let Ok(out) = out else { continue };
            prop_assert_eq!((out.normals.width, out.normals.height), (stack.width, stack.height));
            prop_assert_eq!((out.confidence.width, out.confidence.height), (stack.width, stack.height));
            for ((n, &m), &c) in out.normals.data.iter().zip(&mask.data).zip(&out.confidence.data) {
                if m {
                    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                    prop_assert!((len - 1.0).abs() < 1e-4, "{:?}: |n| = {} ({:?})", method, len, n);
                    prop_assert!(n[2] >= -1e-6, "{:?}: normal {:?} faces away", method, n);
                    prop_assert!((0.0..=1.0).contains(&c), "{:?}: confidence {}", method, c);
                } else {
                    prop_assert_eq!(*n, [0.0f32; 3]);
                }
            }
        }
    }
}

proptest! {
    // each case builds a table: fewer cases
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// The same permutation of the lights in the table and in the target leaves every
    /// normal of the material's tuples where it was: to float rounding (sums in another
    /// order), 1e-3°. (A tuple far from every table entry has a flat cost, and the
    /// rounding may stop the refinement elsewhere in it: measured 0.023° on one.)
    #[test]
    fn the_order_of_the_lights_does_not_matter((stack, mask) in target_of(false), perm in permutation()) {
        let table = table_for(&perm);
        let moved = permuted(&stack, &perm);
        for method in methods() {
            let opts = Options { method, ..Options::default() };
            let a = lut::solve(&stack, &mask, std::slice::from_ref(identity_table()), &opts, &NoProgress);
            let b = lut::solve(&moved, &mask, std::slice::from_ref(&table), &opts, &NoProgress);
            prop_assert_eq!(a.is_ok(), b.is_ok());
            let (Ok(a), Ok(b)) = (a, b) else { continue };
            for (i, (na, nb)) in a.normals.data.iter().zip(&b.normals.data).enumerate() {
                if mask.data[i] {
                    let e = common::angle_deg(*na, *nb);
                    prop_assert!(e < 1e-3, "{:?}: pixel {} moved {}° ({:?} vs {:?})", method, i, e, na, nb);
                }
            }
        }
    }
}
