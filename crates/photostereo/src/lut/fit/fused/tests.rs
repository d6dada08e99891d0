//! Tests of the fused pass against the generic model.

use super::*;
use crate::image::{dot3, normalize};
use crate::lut::fit::generic::{Model, Scratch};
use crate::lut::table::test_sphere_table;
use crate::sphere::Circle;

/// [`Single::eval`] on 8 AVX lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn eval_avx(
    cpu: Avx,
    single: &Single,
    t: &[f32],
    w: Option<&[f32]>,
    gx: f64,
    gy: f64,
    b: &mut Buf,
) -> Point {
    single.eval::<lanes::V8>(cpu, t, w, gx, gy, b)
}

/// [`Single::eval`] on 8 AVX lanes with FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
fn eval_fma(
    cpu: AvxFma,
    single: &Single,
    t: &[f32],
    w: Option<&[f32]>,
    gx: f64,
    gy: f64,
    b: &mut Buf,
) -> Point {
    single.eval::<lanes::V8F>(cpu, t, w, gx, gy, b)
}

/// The 8-lane builds agree with the 4-lane one to rounding.
#[cfg(target_arch = "x86_64")]
fn check_wide(single: &Single, t: &[f32], w: Option<&[f32]>, g: (f64, f64), p: &Point) {
    let mut b = Buf::new(t.len());
    let mut wide = Vec::new();
    if let Some(cpu) = Avx::detect() {
        // SAFETY: the token exists only where the processor has AVX
        wide.push(unsafe { eval_avx(cpu, single, t, w, g.0, g.1, &mut b) });
    }
    if let Some(cpu) = AvxFma::detect() {
        // SAFETY: the token exists only where the processor has AVX and FMA
        wide.push(unsafe { eval_fma(cpu, single, t, w, g.0, g.1, &mut b) });
    }
    for p8 in wide {
        assert!((p8.cost - p.cost).abs() <= 1e-5 * (1.0 + p.cost));
        assert!((p8.c - p.c).abs() < 1e-5);
        let (h, h8) = (p.h[0] + p.h[2], p8.h[0] + p8.h[2]);
        assert!((h8 - h).abs() <= 1e-4 * h.abs(), "8 lanes {h8} vs {h}");
        let (g, g8) = (p.g[0].hypot(p.g[1]), p8.g[0].hypot(p8.g[1]));
        assert!((g8 - g).abs() <= 1e-4 * (g + 1e-3), "8 lanes {g8} vs {g}");
    }
}

/// A 64² sphere (radius 28 px) under `k` lights, diffuse + a Blinn–Phong lobe.
fn table(k: usize) -> Table {
    let circle = Circle {
        cx: 32.3,
        cy: 31.8,
        radius: 28.0,
    };
    test_sphere_table(64, circle, k, |n, i| {
        let a = i as f32 * 2.4;
        let l = normalize([0.5 * a.cos(), 0.5 * a.sin(), 0.8]);
        let h = normalize([l[0], l[1], l[2] + 1.0]);
        0.7 * dot3(n, l).max(0.0) + 0.4 * dot3(n, h).max(0.0).powi(20)
    })
}

#[test]
fn fused_pass_matches_the_generic_model_and_converges() {
    // K = 5 needs padding (a copy of the window), K = 8 does not
    for k in [5, 8] {
        for scale in [false, true] {
            let tables = [table(k)];
            let model = Model::new(&tables, scale);
            let single = Single::new(&tables[0], scale);
            let (kp, truth) = (padded(k), (20.3, 25.7));
            let mut s = Scratch::new(k);
            model.sample(truth.0, truth.1, &mut s, false);
            let albedo = if scale { 0.8 } else { 1.0 };
            let mut t = vec![0.0f32; kp];
            t[..k]
                .iter_mut()
                .zip(&s.basis[0])
                .for_each(|(t, v)| *t = albedo * v);
            let mut w = vec![0.0f32; kp];
            w[..k].fill(1.0);
            w[2] = 0.0;
            let mut b = Buf::new(k);
            let ones = {
                let mut o = vec![0.0f32; kp];
                o[..k].fill(1.0);
                o
            };
            for (gx, gy) in [(18.2, 24.9), (21.0, 26.5), (30.4, 12.1)] {
                for (ws, wf) in [(Some(&w[..]), &w), (None, &ones)] {
                    let p = single.eval::<lanes::V4>(Baseline, &t, ws, gx, gy, &mut b);
                    #[cfg(target_arch = "x86_64")]
                    check_wide(&single, &t, ws, (gx, gy), &p);
                    let f = model.eval(&t[..k], Some(&wf[..k]), gx, gy, &mut s);
                    assert!(
                        (p.cost - f.cost).abs() <= 1e-5 * (1.0 + f.cost),
                        "K {k} scale {scale}: cost {} vs {}",
                        p.cost,
                        f.cost
                    );
                    assert!((p.c - f.coef[0]).abs() < 1e-5);
                }
            }
            let start = Start {
                gx: 19.0,
                gy: 24.6,
                pattern: 0.0,
            };
            let (p, _) = single.refine(&t, Some(&w), start, 8, &mut b);
            let err = ((p.gx - truth.0).powi(2) + (p.gy - truth.1).powi(2)).sqrt();
            assert!(err < 0.01, "K {k} scale {scale}: {err} px off");
            assert!((p.c - albedo).abs() < 1e-3, "K {k}: c = {}", p.c);
        }
    }
}

#[test]
fn pattern_search_walks_as_the_generic_descent_then_converges() {
    let k = 8;
    let tables = [table(k)];
    let model = Model::new(&tables, false);
    let single = Single::new(&tables[0], false);
    let truth = (22.6, 27.3);
    let mut s = Scratch::new(k);
    model.sample(truth.0, truth.1, &mut s, false);
    let t = s.basis[0].clone();
    let mut w = vec![1.0f32; k];
    w[5] = 0.0;
    let mut b = Buf::new(k);
    // a start 4–5 px away, where Gauss–Newton alone may stall in another cell
    for (gx, gy) in [(18.4, 24.1), (26.0, 31.2), (22.1, 22.0)] {
        let at = model.eval(&t, Some(&w), gx, gy, &mut s);
        let generic = model.descend(&t, Some(&w), at, 4.0, &mut s);
        let from = Start {
            gx,
            gy,
            pattern: 4.0,
        };
        // no Gauss–Newton iteration: the pattern search's own result
        let (p, _) = single.refine(&t, Some(&w), from, 0, &mut b);
        assert_eq!((p.gx, p.gy), (generic.gx, generic.gy), "start ({gx}, {gy})");
        assert!((p.cost - generic.cost).abs() <= 1e-5 * (1.0 + generic.cost));
        let (p, _) = single.refine(&t, Some(&w), from, 8, &mut b);
        let err = ((p.gx - truth.0).powi(2) + (p.gy - truth.1).powi(2)).sqrt();
        assert!(err < 0.01, "start ({gx}, {gy}): {err} px off");
    }
}
