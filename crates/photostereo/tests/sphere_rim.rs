//! The sphere's circle under the defects of real photographs, one at a time and all
//! together: optical blur of the edges (Gaussian σ 0.5–1 px), 8-bit quantisation, a
//! sphere on a stand, a background that is not black (with a gradient), a dark rim on
//! a shiny ball. Each case compares the rim model (module `sphere::rim`) with the
//! mid-level crossings of edge points alone, against the exact circle.

mod common;
use common::sphere_measure::gaussian_blur;
use common::sphere_scene::spiral_lights;
use common::Rng;
use photostereo::image::{GrayImage, Image, ImageStack};
use photostereo::sphere::{detect, litarc, Circle, DetectOptions, Detection};

/// A scene with the defects switched on or off.
#[derive(Clone)]
struct Defects {
    /// Gaussian blur of the optics (pixels; 0 = none).
    blur: f64,
    /// Quantise to 8 bits.
    eight_bit: bool,
    /// A bright stand under the sphere, touching its rim.
    stand: bool,
    /// Background level at the image centre and its gradient per pixel (along x).
    background: (f32, f32),
    /// Shiny ball whose radiance falls to 0 at the rim (Fresnel-like (1 − (1 − n_z)⁵)).
    dark_rim: bool,
    noise: f32,
}

const CLEAN: Defects = Defects {
    blur: 0.0,
    eight_bit: false,
    stand: false,
    background: (0.0, 0.0),
    dark_rim: false,
    noise: 0.0,
};

fn truth() -> Circle {
    Circle {
        cx: 80.63,
        cy: 71.28,
        radius: 47.37,
    }
}

/// Radiance of the scene at continuous image point (x, y) under light `l`.
fn radiance(d: &Defects, c: &Circle, x: f64, y: f64, l: [f32; 3]) -> f32 {
    let (nx, ny) = ((x - c.cx) / c.radius, -(y - c.cy) / c.radius);
    let r2 = nx * nx + ny * ny;
    if r2 < 1.0 {
        let n = [nx as f32, ny as f32, (1.0 - r2).sqrt() as f32];
        let ndl = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]).max(0.0);
        let mut v = 0.6 * ndl;
        if d.dark_rim {
            let h = photostereo::image::normalize([l[0], l[1], l[2] + 1.0]);
            let ndh = (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]).max(0.0);
            v = (v + 0.8 * ndh.powf(40.0)) * (1.0 - (1.0 - n[2]).powi(5));
        }
        return v;
    }
    let on_stand = d.stand && (x - c.cx).abs() < 7.0 && y > c.cy;
    if on_stand {
        return 0.45;
    }
    d.background.0 + d.background.1 * (x - c.cx) as f32
}

fn render(d: &Defects, seed: u64) -> ImageStack {
    let (w, h) = (164, 150);
    let c = truth();
    let mut rng = Rng(seed);
    let images: Vec<GrayImage> = spiral_lights(12, 55.0)
        .into_iter()
        .map(|l| {
            let img = Image::from_fn(w, h, |r, col| {
                let mut acc = 0.0;
                for i in 0..4 {
                    for j in 0..4 {
                        let x = col as f64 + (j as f64 + 0.5) / 4.0;
                        let y = r as f64 + (i as f64 + 0.5) / 4.0;
                        acc += radiance(d, &c, x, y, l);
                    }
                }
                acc / 16.0
            });
            let mut img = gaussian_blur(&img, d.blur);
            for v in img.data.iter_mut() {
                *v += d.noise * rng.gauss();
                if d.eight_bit {
                    *v = (*v * 255.0).round().clamp(0.0, 255.0) / 255.0;
                }
            }
            img
        })
        .collect();
    ImageStack::from_images(&images).unwrap()
}

/// Centre and radius errors of a detection (pixels).
fn errors(d: &Detection) -> (f64, f64) {
    let t = truth();
    (
        (d.circle.cx - t.cx).hypot(d.circle.cy - t.cy),
        (d.circle.radius - t.radius).abs(),
    )
}

/// Detect with and without the rim model, print both, return the rim model's errors
/// and its reported uncertainty.
fn measure(name: &str, d: &Defects) -> (f64, f64, f64) {
    let stack = render(d, 11);
    let rim = detect(&stack, &DetectOptions::default()).unwrap();
    let plain = detect(
        &stack,
        &DetectOptions {
            rim_model: false,
            ..DetectOptions::default()
        },
    )
    .unwrap();
    let (ec, er) = errors(&rim);
    let (pc, pr) = errors(&plain);
    // the lit arcs (module `sphere::litarc`): the outer tail alone is biased inward by
    // blur (measured −0.03 … −0.48 px, printed only); the rim model on the lit-arc
    // composite is within 0.1 px in every case (measured worst: radius −0.082 px with
    // all defects, −0.063 px with the dark rim, ≤ 0.025 px otherwise)
    let t = truth();
    if let Some(f) = litarc::fit(&stack, &rim.circle) {
        println!(
            "{name}: lit arcs' tails centre {:.3} px, radius {:+.3} px (σ {:.2})",
            (f.circle.cx - t.cx).hypot(f.circle.cy - t.cy),
            f.circle.radius - t.radius,
            f.sigma_px
        );
    }
    let (c, s, u) = litarc::rim_model(&stack, &rim.circle).unwrap();
    let (lc, lr) = ((c.cx - t.cx).hypot(c.cy - t.cy), c.radius - t.radius);
    println!("{name}: rim model on the lit arcs centre {lc:.3} px, radius {lr:+.3} px (σ {s:.2}, ± {u:.3})");
    assert!(
        lc < 0.1 && lr.abs() < 0.1,
        "{name}: lit arcs centre {lc:.3}, radius {lr:+.3}"
    );
    println!(
        "{name}: rim model centre {ec:.3} px, radius {er:.3} px (± {:.3}, blur {:.2} px, {}); edge points alone centre {pc:.3} px, radius {pr:.3} px",
        rim.uncertainty_px,
        rim.rim_blur_px.unwrap_or(f64::NAN),
        rim.fitted_on
    );
    (ec, er, rim.uncertainty_px)
}

#[test]
fn clean_render_within_0_02_px() {
    let (ec, er, _) = measure("clean", &CLEAN);
    assert!(ec < 0.02 && er < 0.02, "centre {ec:.3}, radius {er:.3}");
}

#[test]
fn optical_blur_within_0_05_px() {
    for blur in [0.5, 0.75, 1.0] {
        let d = Defects { blur, ..CLEAN };
        let (ec, er, _) = measure(&format!("blur σ {blur}"), &d);
        assert!(
            ec < 0.05 && er < 0.05,
            "blur {blur}: centre {ec:.3}, radius {er:.3}"
        );
    }
}

#[test]
fn eight_bit_grey_background_within_0_05_px() {
    let d = Defects {
        eight_bit: true,
        background: (0.3, 0.0015),
        blur: 0.7,
        ..CLEAN
    };
    let (ec, er, _) = measure("8-bit, grey background with a gradient, blur 0.7", &d);
    assert!(ec < 0.05 && er < 0.05, "centre {ec:.3}, radius {er:.3}");
}

#[test]
fn sphere_on_a_stand_within_0_05_px() {
    let d = Defects {
        stand: true,
        blur: 0.7,
        ..CLEAN
    };
    let (ec, er, _) = measure("on a stand, blur 0.7", &d);
    assert!(ec < 0.05 && er < 0.05, "centre {ec:.3}, radius {er:.3}");
}

/// The rim's radiance falls to 0 over the last pixel, which the profile model (a₀ +
/// a₁√s + a₂s inside) follows only in part: measured centre 0.003 px, radius 0.132 px
/// (edge points alone: radius 1.16 px).
#[test]
fn dark_rim_of_a_shiny_ball_within_0_3_px() {
    let d = Defects {
        dark_rim: true,
        blur: 0.7,
        ..CLEAN
    };
    let (ec, er, u) = measure("shiny ball with a dark rim, blur 0.7", &d);
    assert!(ec < 0.05 && er < 0.3, "centre {ec:.3}, radius {er:.3}");
    assert!(
        er < 3.0 * u,
        "the uncertainty ({u:.3} px) must cover the error"
    );
}

/// Measured: centre 0.025 px, radius 0.149 px, reported uncertainty 0.33 px (edge
/// points alone: radius 1.23 px). The dark rim dominates (see above).
#[test]
fn all_defects_together_within_0_3_px() {
    let d = Defects {
        blur: 0.8,
        eight_bit: true,
        stand: true,
        background: (0.02, 0.0002),
        dark_rim: true,
        noise: 0.004,
    };
    let (ec, er, u) = measure("all defects", &d);
    assert!(ec < 0.1 && er < 0.3, "centre {ec:.3}, radius {er:.3}");
    assert!(
        er < 3.0 * u,
        "the uncertainty ({u:.3} px) must cover the error"
    );
}

#[test]
fn the_blur_is_measured_at_a_given_circle() {
    // `sphere::rim_blur`, which `lut::Table::build` keeps with the table: the optics'
    // blur is found at the true circle, and a sharp render reads well under the
    // spatial stage's threshold (`spatial::SHARP_OUTLINE_PX`, 0.35 px). Measured
    // 2026-12-07: 0.010, 0.367, 0.793 (8-bit), 0.998 px for σ 0, 0.5, 0.8, 1 (the
    // kernel of `gaussian_blur` sampled at σ 0.5 is narrower than the continuous one)
    for (blur, eight_bit, tol) in [
        (0.0, false, 0.05),
        (0.5, false, 0.15),
        (0.8, true, 0.05),
        (1.0, false, 0.05),
    ] {
        let d = Defects {
            blur,
            eight_bit,
            ..CLEAN
        };
        let found = photostereo::sphere::rim_blur(&render(&d, 3), &truth()).unwrap();
        println!("blur σ {blur} (8-bit {eight_bit}): measured {found:.3} px");
        assert!(
            (found - blur).abs() < tol,
            "blur {blur}: measured {found:.3}"
        );
    }
    let empty = ImageStack::zeros(0, 0, 3);
    assert!(photostereo::sphere::rim_blur(&empty, &truth()).is_none());
}
