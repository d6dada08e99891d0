//! The radiosity renderer on a long V-groove against an independent 2-D reference: an
//! infinite V-groove whose faces are cut into thin strips, with exact strip-to-strip form
//! factors from Hottel's crossed-strings rule, solved by iteration.

use photostereo::image::{gradient_to_normal, pixel_to_xy, DepthMap, GrayImage, ImageStack, Mask};
use photostereo::interreflect::{Model, RadiosityOptions, Visibility};
use photostereo::progress::NoProgress;

/// A V-groove along y: half-width `a` px, faces at `slope_deg` from horizontal, flat rims.
struct Groove {
    w: usize,
    h: usize,
    a: f64,
    t: f64,
}

impl Groove {
    fn depth_normals(&self) -> (DepthMap, photostereo::NormalMap) {
        let (w, h) = (self.w, self.h);
        let z = DepthMap::from_fn(w, h, |r, c| {
            let (x, _) = pixel_to_xy(r, c, w, h);
            (-(self.a - x.abs()).max(0.0) * self.t) as f32
        });
        let n = photostereo::NormalMap::from_fn(w, h, |r, c| {
            let (x, _) = pixel_to_xy(r, c, w, h);
            let p = if x.abs() >= self.a {
                0.0
            } else {
                self.t * x.signum()
            };
            gradient_to_normal(p as f32, 0.0)
        });
        (z, n)
    }
}

/// 2-D reference: radiosity along the left face (s = distance from the apex, 0..L) and the
/// right face, for light direction (lx, lz) with albedo rho.
fn strip_reference(groove: &Groove, rho: f64, l: [f64; 2], m: usize) -> (Vec<f64>, Vec<f64>) {
    let beta = groove.t.atan();
    let len = groove.a / beta.cos();
    // Apex at the origin; left face goes up-left, right face up-right (x, z).
    let ul = [-beta.cos(), beta.sin()];
    let ur = [beta.cos(), beta.sin()];
    let nl = [beta.sin(), beta.cos()];
    let nr = [-beta.sin(), beta.cos()];
    let ds = len / m as f64;
    let pt = |u: [f64; 2], s: f64| [u[0] * s, u[1] * s];
    let dist = |p: [f64; 2], q: [f64; 2]| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
    // f[i][j]: strip i of one face to strip j of the other face (same by symmetry both ways).
    let mut f = vec![0.0f64; m * m];
    for i in 0..m {
        let (a1, a2) = (pt(ul, i as f64 * ds), pt(ul, (i + 1) as f64 * ds));
        for j in 0..m {
            let (b1, b2) = (pt(ur, j as f64 * ds), pt(ur, (j + 1) as f64 * ds));
            let crossed = dist(a1, b2) + dist(a2, b1);
            let uncrossed = dist(a1, b1) + dist(a2, b2);
            f[i * m + j] = (crossed - uncrossed) / (2.0 * ds);
        }
    }
    let el: Vec<f64> = vec![(nl[0] * l[0] + nl[1] * l[1]).max(0.0); m];
    let er: Vec<f64> = vec![(nr[0] * l[0] + nr[1] * l[1]).max(0.0); m];
    let (mut bl, mut br) = (
        el.iter().map(|e| rho * e).collect::<Vec<_>>(),
        er.iter().map(|e| rho * e).collect::<Vec<_>>(),
    );
    for _ in 0..200 {
        let nbl: Vec<f64> = (0..m)
            .map(|i| rho * (el[i] + (0..m).map(|j| f[i * m + j] * br[j]).sum::<f64>()))
            .collect();
        let nbr: Vec<f64> = (0..m)
            .map(|i| rho * (er[i] + (0..m).map(|j| f[i * m + j] * bl[j]).sum::<f64>()))
            .collect();
        bl = nbl;
        br = nbr;
    }
    (bl, br)
}

fn interp(v: &[f64], s: f64, ds: f64) -> f64 {
    let u = (s / ds - 0.5).clamp(0.0, (v.len() - 1) as f64);
    let i = (u.floor() as usize).min(v.len() - 2);
    let t = u - i as f64;
    v[i] * (1.0 - t) + v[i + 1] * t
}

/// Max and mean relative error of the rendered centre row against the strip reference.
fn compare(groove: &Groove, opts: &RadiosityOptions, rho: f32) -> (f64, f64) {
    let (depth, normals) = groove.depth_normals();
    let mask = Mask::full(groove.w, groove.h);
    let lights = [[0.5f32, 0.0, 0.866], [-0.3, 0.2, 0.933]];
    let mut direct = ImageStack::zeros(groove.w, groove.h, lights.len());
    for p in 0..groove.w * groove.h {
        let n = normals.data[p];
        for (k, l) in lights.iter().enumerate() {
            direct.data[p * lights.len() + k] = rho * photostereo::image::dot3(n, *l).max(0.0);
        }
    }
    let albedo = GrayImage::filled(groove.w, groove.h, rho);
    let model = Model::new(&depth, &normals, &mask, opts, &NoProgress).unwrap();
    let out = model.render(&direct, &albedo, 200, 1e-7).unwrap();
    assert!(
        out.converged,
        "bounces did not converge: {}",
        out.last_change
    );
    let m = 1000;
    let beta = groove.t.atan();
    let ds = groove.a / beta.cos() / m as f64;
    let (mut max_err, mut sum, mut cnt) = (0.0f64, 0.0, 0);
    let mut worst = (0.0, 0);
    for (k, l) in lights.iter().enumerate() {
        let (bl, br) = strip_reference(groove, rho as f64, [l[0] as f64, l[2] as f64], m);
        let r = groove.h / 2;
        for c in 0..groove.w {
            let (x, _) = pixel_to_xy(r, c, groove.w, groove.h);
            if x.abs() >= groove.a {
                continue;
            }
            let s = x.abs() / beta.cos();
            let reference = if x < 0.0 {
                interp(&bl, s, ds)
            } else {
                interp(&br, s, ds)
            };
            let got = out.stack.pixel(r, c)[k] as f64;
            let err = (got - reference).abs() / reference;
            if err > max_err {
                max_err = err;
                worst = (x, k);
            }
            sum += err;
            cnt += 1;
        }
    }
    println!("worst pixel at x = {} (light {})", worst.0, worst.1);
    (max_err, sum / cnt as f64)
}

#[test]
fn vgroove_matches_crossed_strings_reference_per_pixel_facets() {
    // 90° groove, half-width 12 px (depth 12), 224 px long: the ends are far enough away
    // (≈ 4.7 groove widths) to miss < 0.5 % of the bounced light of the infinite groove.
    let groove = Groove {
        w: 32,
        h: 224,
        a: 12.0,
        t: 1.0,
    };
    let opts = RadiosityOptions {
        block: 1,
        visibility: Visibility::Horizon { azimuths: 64 },
        ..Default::default()
    };
    let (max_err, mean_err) = compare(&groove, &opts, 0.8);
    println!("V-groove 90°, block 1: max rel err {max_err:.4}, mean {mean_err:.4}");
    // measured 0.0059 (mean 0.0012)
    assert!(max_err < 0.015, "max relative error {max_err}");
    assert!(mean_err < 0.004, "mean relative error {mean_err}");
}

#[test]
fn vgroove_matches_reference_with_coarse_facets() {
    // 60° opening (faces at 60°), block 2: bounced light spread back bilinearly.
    let groove = Groove {
        w: 48,
        h: 320,
        a: 16.0,
        t: 3f64.sqrt(),
    };
    let opts = RadiosityOptions {
        block: 2,
        visibility: Visibility::Horizon { azimuths: 64 },
        ..Default::default()
    };
    let (max_err, mean_err) = compare(&groove, &opts, 0.8);
    println!("V-groove 60°, block 2: max rel err {max_err:.4}, mean {mean_err:.4}");
    // measured 0.0196 (mean 0.0048)
    assert!(max_err < 0.03, "max relative error {max_err}");
    assert!(mean_err < 0.012, "mean relative error {mean_err}");
}
