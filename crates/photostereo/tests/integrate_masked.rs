//! An object with a hole and two separate parts on a zero background: masked least
//! squares integrates each part on its own (< 0.5% of the range); Fourier methods
//! integrate through the background and fail.

mod common;
use common::surfaces::*;
use photostereo::image::pixel_to_xy;
use photostereo::integrate::{integrate_gradients, Method};
use photostereo::Mask;

fn scene() -> Surface {
    let (w, h) = (200, 140);
    // Part 1: a ring (disk with a hole) on the left; part 2: a disk on the right.
    let mask = Mask::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        let d1 = ((x + 45.0).powi(2) + y.powi(2)).sqrt();
        let d2 = ((x - 55.0).powi(2) + (y - 5.0).powi(2)).sqrt();
        (d1 < 48.0 && d1 > 18.0) || d2 < 35.0
    });
    // Depth: two sphere caps standing high above the background, with a tilt.
    Surface::sample(w, h, mask, |x, y| {
        let (cx, cy, rad) = if x < 5.0 {
            (-45.0, 0.0, 70.0)
        } else {
            (55.0, 5.0, 50.0)
        };
        let (dx, dy) = (x - cx, y - cy);
        let z = (rad * rad - dx * dx - dy * dy).max(1e-9).sqrt() + 0.3 * x;
        (z, -dx / (z - 0.3 * x) + 0.3, -dy / (z - 0.3 * x))
    })
}

#[test]
fn hole_and_two_parts_lsq_below_0p5_percent_fc_clearly_worse() {
    let s = scene();
    let range = s.range();
    let lsq = integrate_gradients(&s.p, &s.q, &s.mask, &opts(Method::Lsq)).unwrap();
    assert_eq!(lsq.components, 2);
    let e_lsq = s.rmse(&lsq.depth) / range;
    let fc = integrate_gradients(
        &s.p,
        &s.q,
        &s.mask,
        &opts(Method::FrankotChellappa { reflect: false }),
    )
    .unwrap();
    let e_fc = s.rmse(&fc.depth) / range;
    let dct = integrate_gradients(&s.p, &s.q, &s.mask, &opts(Method::Dct)).unwrap();
    let e_dct = s.rmse(&dct.depth) / range;
    println!(
        "range {range:.1}: lsq {:.4}%, fc {:.2}%, dct {:.2}% of range",
        100.0 * e_lsq,
        100.0 * e_fc,
        100.0 * e_dct
    );
    // measured: lsq 0.0013 %, fc 12.65 %, dct 6.77 % of the range
    assert!(e_lsq < 4e-5, "lsq {:.4}%", 100.0 * e_lsq);
    assert!(
        e_fc > 0.05 && e_fc > 10.0 * e_lsq,
        "fc {e_fc} not clearly worse than lsq {e_lsq}"
    );
    assert!(
        e_dct > 0.03 && e_dct > 10.0 * e_lsq,
        "dct {e_dct} not clearly worse than lsq {e_lsq}"
    );
    // NaN outside the mask, finite inside, each part centred on 0.
    for (d, &m) in lsq.depth.data.iter().zip(&s.mask.data) {
        assert_eq!(d.is_finite(), m);
    }
}

#[test]
fn lsq_weights_suppress_corrupted_gradients() {
    let mut s = scene();
    // Corrupt a band of the right disk and mark it with near-zero confidence.
    let mut weights = photostereo::GrayImage::filled(s.w, s.h, 1.0);
    for r in 60..75 {
        for c in 150..175 {
            let i = r * s.w + c;
            s.p.data[i] += 2.0;
            weights.data[i] = 1e-6;
        }
    }
    let plain = integrate_gradients(&s.p, &s.q, &s.mask, &opts(Method::Lsq)).unwrap();
    let mut o = opts(Method::Lsq);
    o.weights = Some(weights);
    let weighted = integrate_gradients(&s.p, &s.q, &s.mask, &o).unwrap();
    let (ep, ew) = (s.rmse(&plain.depth), s.rmse(&weighted.depth));
    println!("corrupted band: unweighted RMSE {ep:.3}, weighted {ew:.3}");
    assert!(ew * 5.0 < ep, "weights did not help: {ew} vs {ep}");
}
