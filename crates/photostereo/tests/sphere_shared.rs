//! The sphere's circle on data the project did not make (`../shared`, skipped with a
//! message when absent): DiLiGenT's ball (a real photograph: optical blur, a dark rim)
//! and the Mitsuba renders of a sphere of radius 100 px. Truth: the circle of the true
//! normals, fitted by least squares (pixel (r, c) centred at (c + 0.5, r + 0.5)).

mod common;
use photostereo::io;
use photostereo::sphere::{check_circle, detect, Circle, DetectOptions};
use std::path::Path;

/// Least-squares circle of the true normals (all of them): u = cx + R n_x, v = cy − R n_y.
fn truth_circle(dir: &Path) -> Circle {
    common::sphere_measure::normals_circle(dir, -1.0).0
}

/// The rim model's residual with the rim held on `truth` over that with the rim free,
/// and the same for the circle found (printed).
fn rim_ratios(dir: &Path, truth: &Circle) -> (f64, f64) {
    let data = io::load_dataset(dir, &io::LoadOptions::default()).unwrap();
    let found = detect(&data.stack, &DetectOptions::default())
        .unwrap()
        .circle;
    let t = check_circle(&data.stack, truth).unwrap();
    let f = check_circle(&data.stack, &found).unwrap();
    println!(
        "{}: rim residual on the true circle {:.3e} vs free {:.3e} (ratio {:.2}); on the circle found {:.2}",
        dir.display(),
        t.rms_on_circle,
        t.rms_fitted,
        t.ratio(),
        f.ratio()
    );
    (t.ratio(), f.ratio())
}

/// Detect with and without the folder's mask; return (centre error, radius error) of
/// the detection without it, after checking that both give the same circle.
fn measure(dir: &Path, truth: &Circle) -> (f64, f64, f64) {
    let data = io::load_dataset(dir, &io::LoadOptions::default()).unwrap();
    let t = std::time::Instant::now();
    let plain = detect(&data.stack, &DetectOptions::default()).unwrap();
    let secs = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let old = detect(
        &data.stack,
        &DetectOptions {
            rim_model: false,
            ..DetectOptions::default()
        },
    )
    .unwrap();
    println!(
        "detection {secs:.2} s; without the rim model {:.2} s",
        t.elapsed().as_secs_f64()
    );
    let c = plain.circle;
    let ec = (c.cx - truth.cx).hypot(c.cy - truth.cy);
    let er = c.radius - truth.radius;
    let o = old.circle;
    println!(
        "{}: truth ({:.3}, {:.3}, r {:.3}); found {}; centre error {ec:.3} px, radius error {er:+.3} px \
         (edge points only: centre {:.3}, radius {:+.3})",
        dir.display(),
        truth.cx,
        truth.cy,
        truth.radius,
        plain.describe(),
        (o.cx - truth.cx).hypot(o.cy - truth.cy),
        o.radius - truth.radius
    );
    if let Some(mask) = &data.mask {
        let masked = detect(
            &data.stack,
            &DetectOptions {
                mask: Some(mask.clone()),
                ..DetectOptions::default()
            },
        )
        .unwrap();
        let m = masked.circle;
        let diff = (m.cx - c.cx)
            .abs()
            .max((m.cy - c.cy).abs())
            .max((m.radius - c.radius).abs());
        println!(
            "  with the folder's mask.png: {} (differs by {diff:.4} px)",
            masked.describe()
        );
        assert!(diff < 0.02, "the mask must only restrict the search");
    }
    (ec, er.abs(), plain.uncertainty_px)
}

/// Target (issue 10): centre within 0.15 px and radius within 0.2 px of the true
/// normals' circle. NOT met (why: `sphere_truth.rs`, the truth is a rounded model, not
/// the photographed silhouette): measured centre 0.23 px, radius +0.74 px (edge points
/// alone: 0.27 px, +0.49 px). The folder's mask.png agrees with the true normals' circle
/// (its boundary crosses at +0.15 px), but the images' own edge lies 0.35–0.75 px
/// outside it (half-level crossing of the maximum image, by quadrant: right +0.45,
/// bottom +0.35, left +0.55, top +0.75 px), so a circle fitted to the images cannot
/// land on it (see `diligent_ball_rim_is_not_on_the_true_circle`). The colour channels
/// disagree too: fitted on red, green or blue alone (each divided by its light
/// intensity) the circle's centre is 0.47 / 0.18 / 0.34 px from the truth (red 0.46 px
/// up, blue 0.28 px left and 0.19 px up, green 0.17 px up: the camera's colour
/// processing shifts red and blue); luminance is 72% green. The bounds hold the measured figures; the reported uncertainty (model
/// spread, 0.19 px) says the rim is ambiguous.
#[test]
fn diligent_ball_circle_measured() {
    let Some(dir) =
        common::shared::path("diligent_ball_circle_measured", "data/real/diligent_ball")
    else {
        return;
    };
    let truth = truth_circle(&dir);
    let (ec, er, u) = measure(&dir, &truth);
    assert!(
        ec < 0.35 && er < 1.0,
        "centre {ec:.3} px, radius {er:.3} px, ±{u:.3}"
    );
    assert!(
        u > 0.1,
        "the uncertainty ({u:.3} px) must show the ambiguity"
    );
}

#[test]
fn mitsuba_spheres_within_0_1_px() {
    for case in ["calib_diffuse", "calib_roughplastic"] {
        let Some(dir) =
            common::shared::path("mitsuba_spheres_within_0_1_px", &format!("data/{case}"))
        else {
            return;
        };
        let truth = truth_circle(&dir);
        let (ec, er, u) = measure(&dir, &truth);
        assert!(
            ec < 0.1 && er < 0.1,
            "{case}: centre {ec:.3} px, radius {er:.3} px, ±{u:.3}"
        );
        // the true circle lies on the rendered rim: measured ratios 1.06 / 1.30 (true
        // circle), 1.07 / 1.02 (found); a perfect fit has 1, noise-free renders show
        // the model's small misfit
        let (t, f) = rim_ratios(&dir, &truth);
        assert!(t < 1.6 && f < 1.6, "{case}: rim ratios {t:.2} / {f:.2}");
    }
}

/// Why the ball's target is not met: with the rim held on the circle of the true
/// normals, the rim model's residual (mean image, best blur) is 3.04 times its residual
/// with the rim free sector by sector (on the circle found: 1.02); on the renders the
/// true circle gives 1.06 / 1.30. The photographed rim does not lie on the true
/// normals' circle: it lies 0.5–0.75 px outside it (the mask.png's boundary is 0.15 px
/// outside it). No blur rescues the true circle (with the rim held there, the best blur
/// is ≈ 1 px and the residual still 2.5× that of the free rim at σ ≈ 0; one-off check
/// on the green channel, 16 sectors).
#[test]
fn diligent_ball_rim_is_not_on_the_true_circle() {
    let Some(dir) = common::shared::path(
        "diligent_ball_rim_is_not_on_the_true_circle",
        "data/real/diligent_ball",
    ) else {
        return;
    };
    let truth = truth_circle(&dir);
    let (t, f) = rim_ratios(&dir, &truth);
    assert!(
        t > 1.8 && f < 1.2,
        "rim ratios: true circle {t:.2}, found {f:.2}"
    );
}
