//! An analogue of issue 24's hidden real grey sphere (the psmImages course data's grey
//! sphere: 12 lights within 40° of the view axis, 8-bit RGB, 512 × 340): a Lambertian
//! sphere of radius 170 px lit by the course's published lights
//! (`../shared/data/real/lights_published.txt`), area-sampled (4 × 4 per pixel),
//! brightest sample at 200 grey levels, each of R, G, B with Gaussian read noise of 0.5
//! levels and rounded to 8 bits, then combined to luminance as the loader does. The
//! target is the same photographs at 0.75× (area averaging), stored in floats or
//! rounded to 8 bits again; the table is built on the true circle.
//!
//! Radius and noise were chosen so that the two baselines the issue gives for the hidden
//! sphere come out the same here (nearest 0.33°, 6 neighbours 0.24°): they are set by
//! the table's density, and barely move with the noise. The refined lookup was
//! 0.21° there; a build of that day (70e23b5) gives 0.065° on this analogue, so the hidden
//! sphere's floor comes from something this model leaves out (docs/accuracy.md).
//! Skips with a note when the shared data is absent.

mod common;
use common::lut_score::{print, score};
use common::resample::{rescale, sphere_truth};
use common::Rng;
use photostereo::image::{dot3, ImageStack};
use photostereo::lut::{self, BuildOptions, Method, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::Circle;
use photostereo::{eval, io, normals};

/// Luminance weights of R, G, B (the loader's).
const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// The Lambertian sphere `circle` under `lights`, each pixel the mean of 4 × 4 samples
/// (0 outside), scaled so that the brightest pixel is 1.
fn radiance(circle: &Circle, size: usize, lights: &[[f32; 3]]) -> ImageStack {
    let mut stack = ImageStack::zeros(size, size, lights.len());
    let sub = 4;
    for r in 0..size {
        for c in 0..size {
            let px = stack.pixel_flat_mut(r * size + c);
            for s in 0..sub * sub {
                let x = c as f64 + ((s % sub) as f64 + 0.5) / sub as f64;
                let y = r as f64 + ((s / sub) as f64 + 0.5) / sub as f64;
                let (nx, ny) = (
                    (x - circle.cx) / circle.radius,
                    (circle.cy - y) / circle.radius,
                );
                let rr = nx * nx + ny * ny;
                if rr >= 1.0 {
                    continue;
                }
                let n = [nx as f32, ny as f32, (1.0 - rr).sqrt() as f32];
                for (p, l) in px.iter_mut().zip(lights) {
                    *p += dot3(n, *l).max(0.0) / (sub * sub) as f32;
                }
            }
        }
    }
    let peak = stack.data.iter().copied().fold(0.0f32, f32::max);
    stack.data.iter_mut().for_each(|v| *v /= peak);
    stack
}

/// 8-bit RGB photographs of a grey `radiance` (brightest at `peak` levels), read noise
/// `read` levels per channel, as luminance in units of full scale.
fn photograph(radiance: &ImageStack, peak: f32, read: f32, seed: u64) -> ImageStack {
    let mut out = radiance.clone();
    let mut rng = Rng(seed);
    for v in out.data.iter_mut() {
        let level = *v * peak;
        *v = LUMA
            .iter()
            .map(|w| w * (level + read * rng.gauss()).round().clamp(0.0, 255.0))
            .sum::<f32>()
            / 255.0;
    }
    out
}

/// Mean errors (degrees): nearest entry, 6 neighbours, lookup alone, default pipeline.
fn measure(test: &str, target_8bit: bool) -> Option<[f64; 4]> {
    let file = common::shared::path(test, "data/real/lights_published.txt")?;
    let lights = io::read_lights(&file).unwrap().directions;
    let size = 400;
    let circle = Circle {
        cx: 200.3,
        cy: 199.8,
        radius: 170.0,
    };
    let photo = photograph(&radiance(&circle, size, &lights), 200.0, 0.5, 7);
    let mut target = rescale(&photo, &circle, 0.75, size, size);
    if target_8bit {
        // luminance of rounded channels is close to the rounded luminance of a grey scene
        target
            .data
            .iter_mut()
            .for_each(|v| *v = (*v * 255.0).round() / 255.0);
    }
    let scaled = Circle {
        radius: circle.radius * 0.75,
        ..circle
    };
    let (mask, truth) = sphere_truth(&scaled, size, size, 0.71);
    let table = Table::build(&photo, &circle, &BuildOptions::default()).unwrap();
    let tables = std::slice::from_ref(&table);
    let lookup = |method: Method| {
        let opts = lut::Options {
            method,
            ..lut::Options::default()
        };
        score(
            &lut::solve(&target, &mask, tables, &opts, &NoProgress).unwrap(),
            &truth,
            &mask,
        )
    };
    let pipeline = |spatial: bool| {
        let opts = lut::Options::default();
        let mut n_opts = normals::Options::default();
        if !spatial {
            n_opts.spatial = None;
        }
        let input = normals::Input::Tables(tables, &opts);
        let out = normals::solve(&target, &mask, &input, &n_opts, &NoProgress).unwrap();
        eval::angular_errors(&out.normals, &truth, &mask)
            .unwrap()
            .mean
    };
    let name = format!(
        "grey sphere r 170, psmImages lights, 8-bit RGB, target 0.75× in {}",
        if target_8bit { "8 bits" } else { "floats" }
    );
    let (nearest, idw6) = (
        lookup(Method::Nearest),
        lookup(Method::InverseDistance { neighbours: 6 }),
    );
    print(&format!("{name}, nearest"), &nearest);
    print(&format!("{name}, 6-NN IDW"), &idw6);
    let (alone, default) = (pipeline(false), pipeline(true));
    println!("{name}: lookup (--no-spatial) {alone:.4}°, default {default:.4}°");
    Some([nearest.mean, idw6.mean, alone, default])
}

/// Issue 24's rules, and the hidden sphere's target (< 0.15°) on the analogue.
fn check([nearest, idw6, alone, default]: [f64; 4]) {
    assert!(
        default <= 1.02 * alone,
        "default {default} vs lookup {alone}"
    );
    assert!(
        alone < nearest && default < idw6,
        "{nearest} {idw6} {alone} {default}"
    );
    assert!(default < 0.15, "default {default}");
}

#[test]
fn psm_grey_sphere_analogue_target_in_floats() {
    // measured 2026-12-05: nearest 0.330°, 6-NN IDW 0.236°, lookup 0.062°, default 0.058°
    // (the same scene written as PNGs, through the CLI of 70e23b5, before issue 24's
    // work: lookup 0.065°, default 0.065°)
    if let Some(r) = measure("psm_grey_sphere_analogue_target_in_floats", false) {
        check(r);
    }
}

#[test]
fn psm_grey_sphere_analogue_target_in_8_bits() {
    // measured 2026-12-05: nearest 0.360°, 6-NN IDW 0.289°, lookup 0.148°, default 0.085°
    // (with each channel rounded, as PNGs through the CLI: 0.122° / 0.078°, and through
    // that of 70e23b5: 0.124° / 0.103°)
    if let Some(r) = measure("psm_grey_sphere_analogue_target_in_8_bits", true) {
        check(r);
    }
}
