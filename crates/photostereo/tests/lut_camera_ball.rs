//! A real sphere through an 8-bit camera (issue 24's "real grey sphere" row, on data
//! the project has): DiLiGenT's ball (`../shared/data/real/diligent_ball`, 16-bit,
//! 96 lights) cut to 12 lights spread over the sky and quantised to 8 bits; the target
//! is the ball at 0.75× (area averaging of the 16-bit photographs, then the same 8-bit
//! camera, `synth::camera::develop`: the camera further away), the table is built from
//! the 8-bit originals on the truth's circle. Two exposures: the brightest sample at full scale
//! (the ball's highlights are about 12× its diffuse light, so 99% of the samples are
//! under 20 grey levels) and four times that (highlights clipped, the diffuse light
//! at 5–60 levels). Prints the plain nearest entry, 6 neighbours, the lookup alone
//! (`normals --no-spatial`) and the default pipeline, by band of the true normal's
//! angle; skips with a note when the shared data is absent.

mod common;
use common::resample::{rescale, sphere_truth};
use photostereo::image::ImageStack;
use photostereo::io::{self, LoadOptions};
use photostereo::lut::{self, BuildOptions, Method, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::Circle;
use photostereo::synth::{self, Camera};
use photostereo::{eval, normals};

use common::lut_score::{print, score};

/// `count` lights spread over the sphere of directions (farthest-point sampling from
/// the one nearest the view axis): DiLiGenT's lights are a 12 × 8 grid, and every 8th
/// of them would be one nearly coplanar row.
fn spread_lights(directions: &[[f32; 3]], count: usize) -> Vec<usize> {
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let first = (0..directions.len())
        .max_by(|&a, &b| directions[a][2].total_cmp(&directions[b][2]))
        .unwrap();
    let mut chosen = vec![first];
    while chosen.len() < count.min(directions.len()) {
        // the light whose largest cosine to the chosen ones is smallest
        let next = (0..directions.len())
            .filter(|i| !chosen.contains(i))
            .min_by(|&a, &b| {
                let near = |i: usize| {
                    chosen
                        .iter()
                        .map(|&c| dot(directions[i], directions[c]))
                        .fold(f32::MIN, f32::max)
                };
                near(a).total_cmp(&near(b))
            })
            .unwrap();
        chosen.push(next);
    }
    chosen.sort_unstable();
    chosen
}

/// The lights `keep` of `stack`, in that order.
fn select_lights(stack: &ImageStack, keep: &[usize]) -> ImageStack {
    let mut out = ImageStack::zeros(stack.width, stack.height, keep.len());
    out.names = keep.iter().map(|&i| stack.names[i].clone()).collect();
    for i in 0..stack.pixels() {
        let src = stack.pixel_flat(i);
        for (d, &k) in out.pixel_flat_mut(i).iter_mut().zip(keep) {
            *d = src[k];
        }
    }
    out
}

/// Mean errors (degrees) of one exposure.
#[derive(Debug)]
struct Row {
    nearest: f64,
    idw6: f64,
    lookup: f64,
    default: f64,
}

/// The ball's 12 lights through an 8-bit camera whose full scale is `over` times
/// the brightest sample's exposure (`None`: the 16-bit photographs as they are), with
/// Gaussian read noise of `read` grey levels added before the quantisation (sphere and
/// target drawn apart); table on the truth's circle, target at 0.75×.
fn measure(test: &str, over: Option<f32>, read: f32) -> Option<Row> {
    let dir = common::shared::path(test, "data/real/diligent_ball")?;
    let ball = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    let circle = Circle {
        cx: 112.370,
        cy: 112.368,
        radius: 70.751,
    };
    let lights = ball
        .lights
        .as_ref()
        .expect("the ball's light_directions.txt");
    let sphere16 = select_lights(&ball.stack, &spread_lights(&lights.directions, 12));
    let peak = sphere16.data.iter().copied().fold(0.0f32, f32::max);
    // the project's own camera model (`synth`): samples in units of full scale, read
    // noise, clipping and rounding to 8 bits; sphere and target drawn apart
    let camera = |mut s: ImageStack, seed: u64| {
        if let Some(over) = over {
            let to_full = over / peak;
            s.data.iter_mut().for_each(|v| *v *= to_full);
            synth::camera::develop(&mut s, &Camera::quantized(8), read / 255.0, seed);
        }
        s
    };
    let (w, h) = (sphere16.width, sphere16.height);
    let target = camera(rescale(&sphere16, &circle, 0.75, w, h), 1);
    let sphere = camera(sphere16, 2);
    let scaled = Circle {
        radius: circle.radius * 0.75,
        ..circle
    };
    let (mask, truth) = sphere_truth(&scaled, w, h, 0.71);
    let table = Table::build(&sphere, &circle, &BuildOptions::default()).unwrap();
    let tables = std::slice::from_ref(&table);
    let lookup = |method: Method| {
        let opts = lut::Options {
            method,
            ..lut::Options::default()
        };
        lut::solve(&target, &mask, tables, &opts, &NoProgress).unwrap()
    };
    let pipeline = |spatial: bool| {
        let opts = lut::Options::default();
        let input = normals::Input::Tables(tables, &opts);
        let mut n_opts = normals::Options::default();
        if !spatial {
            n_opts.spatial = None;
        }
        normals::solve(&target, &mask, &input, &n_opts, &NoProgress).unwrap()
    };
    let name = match over {
        Some(over) => format!(
            "DiLiGenT ball, 12 lights, 8-bit, exposure ×{over}, read noise {read} levels, 0.75×"
        ),
        None => "DiLiGenT ball, 12 lights, 16-bit, 0.75×".to_string(),
    };
    let nearest = score(&lookup(Method::Nearest), &truth, &mask);
    let idw6 = score(
        &lookup(Method::InverseDistance { neighbours: 6 }),
        &truth,
        &mask,
    );
    let errors = |out: &normals::Output| eval::angular_errors(&out.normals, &truth, &mask);
    let alone = errors(&pipeline(false)).unwrap().mean;
    let out = pipeline(true);
    let default = errors(&out).unwrap().mean;
    print(&format!("{name}, nearest"), &nearest);
    print(&format!("{name}, 6-NN IDW"), &idw6);
    println!(
        "{name}: lookup (--no-spatial) {alone:.4}°, default {default:.4}° ({:?})",
        out.spatial
    );
    Some(Row {
        nearest: nearest.mean,
        idw6: idw6.mean,
        lookup: alone,
        default,
    })
}

/// Issue 24's rules: the default is never worse than the lookup alone by more than
/// 2%, the lookup beats the table's plain nearest entry, the default beats 6
/// neighbours; and the default within `bound` degrees of the truth.
fn check(r: &Row, bound: f64) {
    assert!(r.default <= 1.02 * r.lookup, "{r:?}");
    assert!(r.lookup < r.nearest && r.default < r.idw6, "{r:?}");
    assert!(r.default < bound, "{r:?}");
}

#[test]
fn diligent_ball_8bit_12_lights_exposed_for_the_highlight() {
    // measured 2026-12-04: nearest 1.144°, 6-NN IDW 1.096°, lookup 0.957°, default
    // 0.258° (bands 0.21 / 0.30 / 0.89 / 1.35°); the same 12 lights in 16 bits:
    // lookup 0.167°, default 0.113°
    if let Some(r) = measure(
        "diligent_ball_8bit_12_lights_exposed_for_the_highlight",
        Some(1.0),
        0.0,
    ) {
        check(&r, 0.27);
    }
}

#[test]
fn diligent_ball_8bit_12_lights_exposed_four_times_clipped() {
    // measured 2026-12-04: nearest 0.674°, 6-NN IDW 0.485°, lookup 0.316°, default
    // 0.136° (0.139° before the spatial solve's per-pixel stopping test; bands 0.12 /
    // 0.15 / 0.39 / 0.54°); issue 24's hidden real grey sphere
    // (8-bit, 12 lights): 0.21°, target < 0.15°
    if let Some(r) = measure(
        "diligent_ball_8bit_12_lights_exposed_four_times_clipped",
        Some(4.0),
        0.0,
    ) {
        check(&r, 0.15);
    }
}

#[test]
fn diligent_ball_16bit_12_lights_reference() {
    // the same 12 lights without the 8-bit camera. measured 2026-12-04: nearest 0.619°,
    // 6-NN IDW 0.376°, lookup 0.167°, default 0.113°
    if let Some(r) = measure("diligent_ball_16bit_12_lights_reference", None, 0.0) {
        check(&r, 0.125);
    }
}

#[test]
fn diligent_ball_8bit_12_lights_with_read_noise() {
    // exposed ×4 as above, plus Gaussian read noise of one grey level before the
    // quantisation (`synth::camera::develop`). measured 2026-12-04: nearest 1.239°,
    // 6-NN IDW 1.100°, lookup 1.039°, default 0.393°
    if let Some(r) = measure(
        "diligent_ball_8bit_12_lights_with_read_noise",
        Some(4.0),
        1.0,
    ) {
        check(&r, 0.45);
    }
}
