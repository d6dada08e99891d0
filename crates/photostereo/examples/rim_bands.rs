//! Lookup accuracy by band of the true normal's angle on the project's own clean 16-bit
//! renders (`synth`'s blob 256², 16 lights, sphere of radius R, exposure `auto`), as
//! `calibrate` + `normals` do it by default (circle found, default table, lookup then
//! the spatial stage), and with `--no-spatial`.
//!
//! ```sh
//! cargo run --release -p photostereo --example rim_bands -- metal 100
//! cargo run --release -p photostereo --example rim_bands -- all
//! ```

use photostereo::lut::{self, BuildOptions, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::{self, DetectOptions};
use photostereo::synth::{self, Camera, Material, SceneOptions, Shape, ShapeKind};
use photostereo::{normals, NormalMap};

const EDGES: [f64; 6] = [0.0, 60.0, 75.0, 80.0, 85.0, 90.01];

fn material(name: &str) -> Material {
    match name {
        "lambertian" => Material::lambertian(0.8),
        "plastic" => Material::shiny_plastic(),
        _ => Material::metal(),
    }
}

/// (whole-mask mean, mean by band) of `est` against `truth` over `mask`.
fn bands(est: &NormalMap, truth: &NormalMap, mask: &photostereo::Mask) -> (f64, [f64; 5]) {
    let (mut s, mut n, mut all, mut count) = ([0.0; 5], [0usize; 5], 0.0, 0usize);
    for i in 0..mask.data.len() {
        if !mask.data[i] {
            continue;
        }
        let (a, b) = (est.data[i], truth.data[i]);
        let e = photostereo::eval::angle_deg(&a, &b);
        let tilt = (b[2] as f64).clamp(-1.0, 1.0).acos().to_degrees();
        let k = (1..6).position(|j| tilt < EDGES[j]).unwrap_or(4);
        s[k] += e;
        n[k] += 1;
        all += e;
        count += 1;
    }
    (
        all / count as f64,
        std::array::from_fn(|k| s[k] / n[k].max(1) as f64),
    )
}

fn case(name: &str, radius: f64) -> anyhow::Result<()> {
    let mut opts = SceneOptions {
        shape: Shape::preset(ShapeKind::Blob, 256, 256),
        material: material(name),
        lights: synth::default_lights(16),
        camera: Camera::quantized(16),
        ..SceneOptions::default()
    };
    opts.exposure = synth::exposure_for_full_scale(&opts, Some(radius), 0.98)?.min(1.0);
    let target = synth::render(&opts)?;
    let sphere = synth::render_calibration_sphere(&opts, radius)?;
    let detect = DetectOptions {
        mask: Some(sphere.mask.clone()),
        ..DetectOptions::default()
    };
    let circle = sphere::detect(&sphere.stack, &detect)?.circle;
    let table = Table::build(&sphere.stack, &circle, &BuildOptions::default())?;
    let tables = [table];
    let lo = lut::Options::default();
    let input = normals::Input::Tables(&tables, &lo);
    for spatial in [true, false] {
        let o = normals::Options {
            spatial: if spatial {
                Some(Default::default())
            } else {
                None
            },
        };
        let out = normals::solve(&target.stack, &target.mask, &input, &o, &NoProgress)?;
        let (m, b) = bands(&out.normals, &target.normals, &target.mask);
        println!(
            "{name:10} r {radius:5.1} {:10}: {m:.4}° | {:.4} {:.4} {:.4} {:.3} {:.3}",
            if spatial { "default" } else { "no-spatial" },
            b[0],
            b[1],
            b[2],
            b[3],
            b[4]
        );
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    println!("case           whole     | 0–60   60–75  75–80  80–85 85–90");
    if args.first().map(|s| s.as_str()) == Some("all") {
        for r in [100.0, 50.0] {
            for m in ["lambertian", "plastic", "metal"] {
                case(m, r)?;
            }
        }
    } else {
        let m = args.first().map(|s| s.as_str()).unwrap_or("metal");
        let r = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(100.0);
        case(m, r)?;
    }
    Ok(())
}
