//! Gaussian noise σ = 0.05 on the gradients: the least-squares methods must beat a
//! single path integral by at least 5× in RMSE, and the two path orders must disagree.

mod common;
use common::surfaces::*;
use photostereo::integrate::path::{single_path, Order};
use photostereo::integrate::{integrate_gradients, Method};
use photostereo::Mask;

#[test]
fn noisy_sphere_cap_fc_dct_lsq_at_least_5x_better_than_single_path() {
    // A centred cap: its border slopes are antisymmetric, so even plain fc has no
    // boundary bias here (0.0006% noise-free) and the test isolates the noise.
    let (w, h) = (256, 256);
    let mut s = sphere_cap(w, h, 0.8 * w as f64, (0.0, 0.0), Mask::full(w, h));
    s.add_noise(0.05, 7);
    let single = s.rmse(&single_path(&s.p, &s.q, &s.mask, Order::RowsFirst).unwrap());
    println!("single path (rows first): RMSE {single:.4}");
    let path = integrate_gradients(&s.p, &s.q, &s.mask, &opts(Method::Path)).unwrap();
    let dis = path.path_disagreement.unwrap();
    println!(
        "two-path average: RMSE {:.4}, disagreement {dis:.4}",
        s.rmse(&path.depth)
    );
    assert!(dis > 0.05, "two noisy paths must disagree: {dis}");
    for m in [
        Method::FrankotChellappa { reflect: false },
        Method::FrankotChellappa { reflect: true },
        Method::Dct,
        Method::Lsq,
    ] {
        let out = integrate_gradients(&s.p, &s.q, &s.mask, &opts(m)).unwrap();
        let e = s.rmse(&out.depth);
        println!("{:>10}: RMSE {e:.4} ({:.1}x better)", m.name(), single / e);
        assert!(e * 5.0 <= single, "{}: {e} not 5x below {single}", m.name());
        assert!(out.path_disagreement.is_none());
    }
}
