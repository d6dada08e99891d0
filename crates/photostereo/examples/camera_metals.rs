//! Issue 24's camera cases on metals other than `synth`'s (GGX, no diffuse part, F₀ and α
//! given): 8-bit, exposed for the brightest highlight, optionally blurred with a black
//! level; the sphere's circle found. Prints the table's plain nearest entry, the lookup
//! alone (`--no-spatial`) and the default pipeline, mean angular error over the mask.
//!
//! ```sh
//! cargo run --release -p photostereo --example camera_metals -- 0.9 0.1 0.8 0.03
//! ```
//! (arguments: F₀, α, blur σ in px, black level as a fraction of full scale)

use photostereo::lut::{self, BuildOptions, Method, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::{self, DetectOptions};
use photostereo::synth::{self, Camera, Material, SceneOptions, Shape, ShapeKind};
use photostereo::{eval, spatial};

fn main() -> anyhow::Result<()> {
    let a: Vec<f32> = std::env::args()
        .skip(1)
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let [f0, alpha, blur, black] = a[..] else {
        anyhow::bail!("usage: camera_metals F0 ALPHA BLUR BLACK");
    };
    let mut opts = SceneOptions {
        shape: Shape::preset(ShapeKind::Blob, 256, 256),
        material: Material::Ggx {
            kd: 0.0,
            ks: f0,
            roughness: alpha,
        },
        lights: synth::default_lights(16),
        camera: Camera {
            bits: Some(8),
            blur_sigma: blur,
            black_level: black,
        },
        seed: 5,
        ..SceneOptions::default()
    };
    opts.exposure = synth::exposure_for_full_scale(&opts, Some(100.0), 1.0)?;
    let target = synth::render(&opts)?;
    let sphere = synth::render_calibration_sphere(&opts, 100.0)?;
    // the sphere's true circle (centre at 2 + r, see `render_calibration_sphere`) where
    // detection fails: a shiny sphere's maximum image may show only its lit cap
    let circle = match sphere::detect(&sphere.stack, &DetectOptions::default()) {
        Ok(found) => {
            let c = found.circle;
            println!(
                "circle found on the {}: centre ({:.3}, {:.3}), radius {:.3} px (truth (102, 102), 100)",
                found.fitted_on, c.cx, c.cy, c.radius
            );
            c
        }
        Err(e) => {
            println!("circle not found ({e}); the true circle is used");
            sphere::Circle {
                cx: 102.0,
                cy: 102.0,
                radius: 100.0,
            }
        }
    };
    let table = Table::build(&sphere.stack, &circle, &BuildOptions::default())?;
    let tables = std::slice::from_ref(&table);
    let err = |n: &photostereo::NormalMap| {
        eval::angular_errors(n, &target.normals, &target.mask).map(|e| e.mean)
    };
    let solve = |method: Method| {
        let o = lut::Options {
            method,
            ..lut::Options::default()
        };
        lut::solve(&target.stack, &target.mask, tables, &o, &NoProgress)
    };
    let out = solve(Method::Refined)?;
    let noise = spatial::NoiseModel::estimate(&target.stack, &target.mask);
    let sp = spatial::solve_table(
        &target.stack,
        &target.mask,
        &table,
        &out,
        &noise,
        &spatial::Options::default(),
    )?;
    let inside = (0..target.mask.data.len()).filter(|&i| target.mask.data[i]);
    let (zeros, samples) = inside.fold((0usize, 0usize), |(z, n), i| {
        let px = target.stack.pixel_flat(i);
        (z + px.iter().filter(|&&v| v <= 0.0).count(), n + px.len())
    });
    let zeros = zeros as f64 / samples as f64;
    by_lit(&target, &out.normals, &sp.normals);
    println!(
        "F0 {f0} alpha {alpha} blur {blur} black {black}: zeros {:.1}%, nearest {:.3}°, \
         lookup {:.3}°, default {:.3}° ({} decided by neighbours)",
        100.0 * zeros,
        err(&solve(Method::Nearest)?.normals)?,
        err(&out.normals)?,
        err(&sp.normals)?,
        sp.stats.decided_by_neighbours
    );
    Ok(())
}

/// Mean error of the lookup and the default by the number of lights above 5 grey levels.
fn by_lit(t: &synth::Scene, lookup: &photostereo::NormalMap, default: &photostereo::NormalMap) {
    let mut acc = vec![(0usize, 0.0f64, 0.0f64); 17];
    for i in 0..t.mask.data.len() {
        if !t.mask.data[i] {
            continue;
        }
        let lit = t
            .stack
            .pixel_flat(i)
            .iter()
            .filter(|&&v| v > 5.0 / 255.0)
            .count();
        let e = |n: &photostereo::NormalMap| eval::angle_deg(&n.data[i], &t.normals.data[i]);
        acc[lit].0 += 1;
        acc[lit].1 += e(lookup);
        acc[lit].2 += e(default);
    }
    let total: usize = acc.iter().map(|a| a.0).sum();
    for (k, (n, l, d)) in acc.iter().enumerate().filter(|a| a.1 .0 > 0) {
        println!(
            "  {k:2} lit: {:5.1}% of px, lookup {:6.2}°, default {:6.2}° (share of the mean {:4.1}% / {:4.1}%)",
            100.0 * *n as f64 / total as f64,
            l / *n as f64,
            d / *n as f64,
            100.0 * l / acc.iter().map(|a| a.1).sum::<f64>(),
            100.0 * d / acc.iter().map(|a| a.2).sum::<f64>()
        );
    }
}
