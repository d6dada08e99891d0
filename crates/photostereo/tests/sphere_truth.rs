//! Where is DiLiGenT's ball? The circle of its true normals against what the
//! photographs show (`../shared`, skipped with a message when absent). Issue 10 asks for
//! the circle found within 0.15 px (centre) and 0.2 px (radius) of the true normals'
//! circle (112.370, 112.368, r 70.751); these tests record why no measurement of the
//! images' silhouette lands there:
//!
//! * the true normals are an orthographic model of a circle of radius exactly 70.7500 px
//!   (283/4: a radius rounded at the camera's full resolution, 4× this one), and the
//!   dataset's own mask (the normals' support) reaches 0.24 px beyond it;
//!   Mask and normals share their centre (the mask's own circle: (112.33–112.36,
//!   112.38), r 70.90); the photographs' silhouette does not;
//! * every edge model puts the silhouette 0.36–0.75 px outside that radius and its
//!   centre 0.23–0.27 px from that centre (0.25 px along rows): the rim model on the
//!   maximum image (`detect`, +0.74 px), the rim model on the lit arcs (+0.72 px; within
//!   0.1 px on every synthetic defect of `sphere_rim`, dark rim included), mid-level
//!   edge points (+0.49 px) and the lit arcs' outer tails (+0.36 px, a lower bound:
//!   blur pulls them inward on synthetic spheres);
//! * the specular highlights (calibrated lights, mirror direction) put the centre
//!   0.13 px from the truth's but say nothing firm about the radius (+1.45 px).

mod common;
use common::solve3;
use common::sphere_measure::{errors, normals_circle};
use photostereo::io;
use photostereo::sphere::photometric::{self, PhotometricOptions};
use photostereo::sphere::{detect, litarc, Circle, DetectOptions};

/// The truth is a model: an exact orthographic sphere of radius 70.7500 px (fit
/// residual 0.0000 px over the pixels with n_z ≥ 0.05; measured), the mask is exactly
/// the normals' support, its area gives r 70.897, and its outermost pixels lie 0.24 px
/// beyond the circle with n_z clamped to 0 (measured 70.989).
#[test]
fn diligent_truth_circle_is_a_rounded_model() {
    let Some(dir) = common::shared::path(
        "diligent_truth_circle_is_a_rounded_model",
        "data/real/diligent_ball",
    ) else {
        return;
    };
    let (c, rms, n) = normals_circle(&dir, 0.05);
    println!(
        "true normals (n_z ≥ 0.05, {n} px): ({:.4}, {:.4}, r {:.4}), rms {rms:.5} px",
        c.cx, c.cy, c.radius
    );
    assert!(
        (c.radius - 70.75).abs() < 5e-4 && rms < 1e-3,
        "r {:.4}",
        c.radius
    );
    let normals = io::read_normals_npy(&dir.join("normal_gt.npy")).unwrap();
    let mask = io::read_mask(&dir.join("mask.png")).unwrap();
    let (mut area, mut same, mut reach) = (0usize, true, 0.0f64);
    for r in 0..mask.height {
        for col in 0..mask.width {
            let v = normals.get(r, col);
            let has = v.iter().map(|x| x * x).sum::<f32>() > 0.25;
            same &= has == *mask.get(r, col);
            if has {
                area += 1;
                let d = (col as f64 + 0.5 - c.cx).hypot(r as f64 + 0.5 - c.cy);
                reach = reach.max(d);
            }
        }
    }
    let r_area = (area as f64 / std::f64::consts::PI).sqrt();
    println!("mask = normals' support: {same}; area radius {r_area:.3}; outermost pixel centre {reach:.3}");
    assert!(same);
    assert!((r_area - 70.897).abs() < 0.01 && (reach - 70.989).abs() < 0.01);
}

/// The lit arcs on the renders: within 0.1 px of the true circle. Outer tails: measured
/// centre < 0.001 px, radius −0.010 / −0.025 px (diffuse / rough plastic); rim model on
/// the lit-arc composite: centre < 0.001 px, radius +0.001 / +0.022 px.
#[test]
fn lit_arcs_on_renders_within_0_1_px() {
    for case in ["calib_diffuse", "calib_roughplastic"] {
        let Some(dir) =
            common::shared::path("lit_arcs_on_renders_within_0_1_px", &format!("data/{case}"))
        else {
            return;
        };
        let truth = normals_circle(&dir, 0.05).0;
        let data = io::load_dataset(&dir, &io::LoadOptions::default()).unwrap();
        let start = detect(&data.stack, &DetectOptions::default())
            .unwrap()
            .circle;
        let f = litarc::fit(&data.stack, &start).unwrap();
        let (ec, er) = errors(&f.circle, &truth);
        println!(
            "{case}: lit arcs ({:.3}, {:.3}, r {:.3}), σ {:.2} px, rms {:.3} px over {} sectors; centre {ec:.3}, radius {er:+.3} px",
            f.circle.cx, f.circle.cy, f.circle.radius, f.sigma_px, f.rms_px, f.sectors_used
        );
        assert!(
            ec < 0.1 && er.abs() < 0.1,
            "{case}: centre {ec:.3}, radius {er:+.3}"
        );
        let (c, s, u) = litarc::rim_model(&data.stack, &start).unwrap();
        let (mc, mr) = errors(&c, &truth);
        println!("{case}: rim model on the lit arcs centre {mc:.3}, radius {mr:+.3} px (σ {s:.2} ± {u:.3})");
        assert!(
            mc < 0.1 && mr.abs() < 0.1,
            "{case}: centre {mc:.3}, radius {mr:+.3}"
        );
    }
}

/// The ball's silhouette from the lit arcs. Outer tails: measured (112.326, 112.112,
/// r 71.114), centre 0.260 px and radius +0.364 px from the true normals' circle, σ 0.65
/// px with pixel and sampling (0.50 on the renders). Rim model on the lit-arc composite:
/// (112.339, 112.131, r 71.469), centre 0.239 px, radius +0.719 px, σ 0.16 px — the
/// method within 0.1 px on all of `sphere_rim`'s synthetic defects agrees with the rim
/// model on the maximum image (detect: +0.74 px) within 0.03 px, not with the truth.
#[test]
fn diligent_ball_lit_arcs_put_the_rim_outside_the_truth() {
    let Some(dir) = common::shared::path(
        "diligent_ball_lit_arcs_put_the_rim_outside_the_truth",
        "data/real/diligent_ball",
    ) else {
        return;
    };
    let truth = normals_circle(&dir, 0.05).0;
    let data = io::load_dataset(&dir, &io::LoadOptions::default()).unwrap();
    let found = detect(&data.stack, &DetectOptions::default())
        .unwrap()
        .circle;
    let f = litarc::fit(&data.stack, &found).unwrap();
    let (ec, er) = errors(&f.circle, &truth);
    let (dc, dr) = errors(&f.circle, &found);
    println!(
        "ball: lit arcs ({:.3}, {:.3}, r {:.3}), σ {:.2} px, rms {:.3} px over {} sectors; vs truth centre {ec:.3}, radius {er:+.3} px; vs the rim model's circle centre {dc:.3}, radius {dr:+.3} px",
        f.circle.cx, f.circle.cy, f.circle.radius, f.sigma_px, f.rms_px, f.sectors_used
    );
    let (c, s, u) = litarc::rim_model(&data.stack, &found).unwrap();
    let (mc, mr) = errors(&c, &truth);
    println!(
        "ball: rim model on the lit arcs ({:.3}, {:.3}, r {:.3}), σ {s:.2} ± {u:.3}: centre {mc:.3}, radius {mr:+.3} px from the truth",
        c.cx, c.cy, c.radius
    );
    assert!(
        (0.55..0.9).contains(&mr) && (0.15..0.35).contains(&mc),
        "rim model on the lit arcs: centre {mc:.3}, radius {mr:+.3}"
    );
    assert!(
        (0.3..0.6).contains(&er) && (0.18..0.32).contains(&ec),
        "centre {ec:.3}, radius {er:+.3}"
    );
    assert!(
        dc < 0.1 && f.sigma_px < 0.8,
        "centre vs rim model {dc:.3}, σ {:.2}",
        f.sigma_px
    );
}

/// The specular highlights: in image k the peak lies where the normal is the half
/// vector h_k = (l_k + v)/|l_k + v| of the calibrated light, so u = cx + R h_x,
/// v = cy − R h_y over the 96 images is a circle fit that uses no edge. Measured: centre
/// (112.496, 112.380), 0.127 px from the truth's; radius 72.197 (+1.45 px: the peak
/// of a rough lobe sits beyond the mirror direction, and the fit's radius scales with
/// any error in the lights' elevations); rms 0.164 px.
#[test]
fn diligent_ball_highlights_centre() {
    let Some(dir) =
        common::shared::path("diligent_ball_highlights_centre", "data/real/diligent_ball")
    else {
        return;
    };
    let truth = normals_circle(&dir, 0.05).0;
    let data = io::load_dataset(&dir, &io::LoadOptions::default()).unwrap();
    let lights = data.lights.unwrap().directions;
    let s = &data.stack;
    let (mut a, mut b) = ([[0.0f64; 3]; 3], [0.0f64; 3]);
    for (k, l) in lights.iter().enumerate() {
        let hl = [l[0] as f64, l[1] as f64, l[2] as f64 + 1.0];
        let n = (hl[0] * hl[0] + hl[1] * hl[1] + hl[2] * hl[2]).sqrt();
        let (hx, hy) = (hl[0] / n, hl[1] / n);
        let (pu, pv) = (truth.cx + truth.radius * hx, truth.cy - truth.radius * hy);
        let at = |r: usize, c: usize| s.data[(r * s.width + c) * s.k + k];
        let win = |c: f64, h: usize| (c as usize - h)..=(c as usize + h);
        let (mut best, mut br, mut bc) = (0.0f32, 0, 0);
        for r in win(pv, 15) {
            for c in win(pu, 15) {
                if at(r, c) > best {
                    (best, br, bc) = (at(r, c), r, c);
                }
            }
        }
        let floor = win(br as f64, 8)
            .flat_map(|r| win(bc as f64, 8).map(move |c| (r, c)))
            .map(|(r, c)| at(r, c))
            .fold(f32::MAX, f32::min);
        let thr = floor + 0.5 * (best - floor);
        let (mut sw, mut su, mut sv) = (0.0, 0.0, 0.0);
        for r in win(br as f64, 8) {
            for c in win(bc as f64, 8) {
                let wgt = (at(r, c) - thr).max(0.0) as f64;
                (sw, su, sv) = (
                    sw + wgt,
                    su + wgt * (c as f64 + 0.5),
                    sv + wgt * (r as f64 + 0.5),
                );
            }
        }
        for (row, rhs) in [([1.0, 0.0, hx], su / sw), ([0.0, 1.0, -hy], sv / sw)] {
            for i in 0..3 {
                for j in 0..3 {
                    a[i][j] += row[i] * row[j];
                }
                b[i] += row[i] * rhs;
            }
        }
    }
    let x = solve3(a, b);
    let c = Circle {
        cx: x[0],
        cy: x[1],
        radius: x[2],
    };
    let (ec, er) = errors(&c, &truth);
    println!(
        "highlights: ({:.3}, {:.3}, r {:.3}); centre {ec:.3} px, radius {er:+.3} px from the truth",
        c.cx, c.cy, c.radius
    );
    assert!(
        ec < 0.25 && (1.0..2.0).contains(&er),
        "centre {ec:.3}, radius {er:+.3}"
    );
}

/// The circle from the sphere's shading (`sphere::photometric`): the circle whose
/// normals make one isotropic reflectance, shared by all the calibrated lights, fit
/// best; no edge enters. Renders (started from the circle found): measured centre
/// < 0.001 px, radius +0.004 / +0.004 px (Lambertian / GGX plastic); the plastic blurred
/// by σ 0.75 px and quantised to 8 bits: see the printout, bound 0.1 px.
#[test]
fn photometric_circle_on_renders_within_0_1_px() {
    for case in ["calib_diffuse", "calib_roughplastic"] {
        let Some(dir) = common::shared::path(
            "photometric_circle_on_renders_within_0_1_px",
            &format!("data/{case}"),
        ) else {
            return;
        };
        let truth = normals_circle(&dir, 0.05).0;
        let data = io::load_dataset(&dir, &io::LoadOptions::default()).unwrap();
        let lights = data.lights.unwrap().directions;
        let mut stacks = vec![("as rendered", data.stack)];
        if case == "calib_roughplastic" {
            let degraded = common::sphere_measure::degrade(&stacks[0].1, 0.75, true);
            stacks.push(("blur σ 0.75 px, 8 bits", degraded));
        }
        for (what, stack) in &stacks {
            let found = detect(stack, &DetectOptions::default()).unwrap().circle;
            let f =
                photometric::fit(stack, &lights, &found, &PhotometricOptions::default()).unwrap();
            let (ec, er) = errors(&f.circle, &truth);
            println!(
                "{case}, {what}: photometric ({:.3}, {:.3}, r {:.3}) ± ({:.3}, {:.3}, {:.3}); centre {ec:.3}, radius {er:+.3} px from the truth; rms {:.2e} (start {:.2e}) over {} samples",
                f.circle.cx, f.circle.cy, f.circle.radius, f.sd_px[0], f.sd_px[1], f.sd_px[2],
                f.rms, f.rms_at_start, f.samples
            );
            assert!(
                ec < 0.1 && er.abs() < 0.1,
                "{case}, {what}: centre {ec:.3}, radius {er:+.3}"
            );
        }
    }
}

/// The ball's shading through its calibrated lights. Measured: (112.460, 112.328,
/// r 72.176), centre 0.098 px from the true normals' circle — within issue 10's 0.15 px —
/// but radius +1.43 px, farther out than the silhouette (+0.74 px) and close to the
/// highlights' +1.45 px; rms 7.8e-3 against 9.3e-3 on the circle found, formal σ
/// ≤ 0.002 px (the model's misfit, not noise, dominates). With the same lights, the
/// ball's shading is that of a sphere 2% larger than the true normals' circle: the
/// truth's radius is not in the photographs' photometry either.
#[test]
fn diligent_ball_photometric_circle() {
    let Some(dir) = common::shared::path(
        "diligent_ball_photometric_circle",
        "data/real/diligent_ball",
    ) else {
        return;
    };
    let truth = normals_circle(&dir, 0.05).0;
    let data = io::load_dataset(&dir, &io::LoadOptions::default()).unwrap();
    let lights = data.lights.unwrap().directions;
    let found = detect(&data.stack, &DetectOptions::default())
        .unwrap()
        .circle;
    let f = photometric::fit(&data.stack, &lights, &found, &PhotometricOptions::default()).unwrap();
    let (ec, er) = errors(&f.circle, &truth);
    let on_truth = photometric::residual(
        &data.stack,
        &lights,
        &found,
        &truth,
        &PhotometricOptions::default(),
    )
    .unwrap();
    let rms_truth = (on_truth / f.samples as f64).sqrt();
    println!(
        "ball: photometric ({:.3}, {:.3}, r {:.3}) ± ({:.3}, {:.3}, {:.3}); centre {ec:.3}, radius {er:+.3} px from the truth; rms {:.2e} (circle found {:.2e}, true circle {rms_truth:.2e}) over {} samples",
        f.circle.cx, f.circle.cy, f.circle.radius, f.sd_px[0], f.sd_px[1], f.sd_px[2],
        f.rms, f.rms_at_start, f.samples
    );
    assert!(
        ec < 0.2 && (1.1..1.8).contains(&er),
        "centre {ec:.3}, radius {er:+.3}"
    );
    assert!(
        rms_truth > f.rms_at_start,
        "the true circle fits the shading worse than the circle found"
    );
}
