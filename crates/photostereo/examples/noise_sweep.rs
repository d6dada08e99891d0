//! Accuracy of the lookup under noise, with and without the spatial stage, against the
//! nearest-neighbour baseline.
//!
//! ```sh
//! # the sweep on the project's own renders (blob target, sphere r = 100, 16 lights),
//! # noise 0, 0.5, 1, 2, 5 % of full scale; writes the plot and a CSV
//! cargo run --release -p photostereo --example noise_sweep -- sweep docs/noise-sweep.png
//! # one case on any pair of datasets with normal_gt.npy (noise: fraction of the
//! # brightest sample of the two, added to sphere and target, clipped at 0)
//! cargo run --release -p photostereo --example noise_sweep -- pair \
//!     ../shared/data/calib_diffuse ../shared/data/target_diffuse 0.01
//! ```
//!
//! `NOISE_SWEEP_DENOISE=image` (or `normal`) builds the tables with the image blur (or
//! the normal-space fit) instead of the default rule, for before/after comparisons.

use photostereo::interreflect::plot::{LinePlot, Series};
use photostereo::lut::{self, BuildOptions, Denoise, Method, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::{self, Circle, DetectOptions};
use photostereo::synth::{self, Material, SceneOptions, Shape, ShapeKind};
use photostereo::{eval, io, spatial, ImageStack, Mask, NormalMap};
use std::time::Instant;

/// One scene: the sphere's images, the target's, its mask and true normals.
struct Case {
    sphere: ImageStack,
    target: ImageStack,
    mask: Mask,
    truth: NormalMap,
    /// The sphere's circle when known (synthetic), else detected.
    circle: Option<Circle>,
}

/// Errors (mean angular, degrees) of one case.
#[derive(Debug, Default, Clone, Copy)]
struct Result3 {
    lookup: f64,
    spatial: f64,
    idw: f64,
    lookup_s: f64,
    spatial_s: f64,
}

fn run(case: &Case) -> anyhow::Result<Result3> {
    let detect = DetectOptions {
        circle: case.circle,
        ..DetectOptions::default()
    };
    let det = sphere::detect(&case.sphere, &detect)?;
    let denoise = match std::env::var("NOISE_SWEEP_DENOISE").as_deref() {
        Ok("image") => Denoise::ImageBlur,
        Ok("normal") => Denoise::NormalSpace { width: None },
        _ => Denoise::Auto,
    };
    let build = BuildOptions {
        denoise,
        ..BuildOptions::default()
    };
    let table = Table::build(&case.sphere, &det.circle, &build)?;
    let t0 = Instant::now();
    let out = lut::solve(
        &case.target,
        &case.mask,
        std::slice::from_ref(&table),
        &lut::Options::default(),
        &NoProgress,
    )?;
    let lookup_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let noise = spatial::NoiseModel::estimate(&case.target, &case.mask);
    let sp = spatial::solve_table(
        &case.target,
        &case.mask,
        &table,
        &out,
        &noise,
        &spatial::Options::default(),
    )?;
    let spatial_s = t1.elapsed().as_secs_f64();
    let idw = lut::solve(
        &case.target,
        &case.mask,
        std::slice::from_ref(&table),
        &lut::Options {
            method: Method::InverseDistance { neighbours: 6 },
            ..lut::Options::default()
        },
        &NoProgress,
    )?;
    let err = |n: &NormalMap| -> anyhow::Result<f64> {
        Ok(eval::angular_errors(n, &case.truth, &case.mask)?.mean)
    };
    let sig = sp.sigma_deg.clone();
    let sigs: Vec<f32> = sig
        .data
        .iter()
        .zip(&case.mask.data)
        .filter(|(_, &m)| m)
        .map(|(s, _)| *s)
        .collect();
    eprintln!(
        "  noise σ0 {:.5} g {:.2e}; σθ mean {:.2}°; neighbours decide {} of {} px; {} cut; {} CG its",
        noise.read,
        noise.gain,
        sigs.iter().map(|&s| s as f64).sum::<f64>() / sigs.len() as f64,
        sp.stats.decided_by_neighbours,
        sp.stats.pixels,
        sp.stats.cut_triples,
        sp.stats.iterations
    );
    if std::env::var_os("NOISE_SWEEP_DEBUG").is_some() {
        diagnose(&sig, &out.normals, &sp.normals, &case.truth, &case.mask);
        by_distance(&out.normals, &sp.normals, &case.truth, &case.mask);
    }
    Ok(Result3 {
        lookup: err(&out.normals)?,
        spatial: err(&sp.normals)?,
        idw: err(&idw.normals)?,
        lookup_s,
        spatial_s,
    })
}

#[allow(clippy::needless_range_loop)]
/// Mean errors binned by the pixel's own angular standard error.
fn diagnose(sig: &photostereo::GrayImage, a: &NormalMap, b: &NormalMap, t: &NormalMap, m: &Mask) {
    let edges = [0.0f32, 1.0, 3.0, 10.0, 30.0, 1e9];
    let ang = |x: [f32; 3], y: [f32; 3]| {
        (x[0] * y[0] + x[1] * y[1] + x[2] * y[2])
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees() as f64
    };
    for w in edges.windows(2) {
        let (mut n, mut ea, mut eb) = (0usize, 0.0, 0.0);
        for i in 0..m.data.len() {
            if m.data[i] && sig.data[i] >= w[0] && sig.data[i] < w[1] {
                n += 1;
                ea += ang(a.data[i], t.data[i]);
                eb += ang(b.data[i], t.data[i]);
            }
        }
        if n > 0 {
            eprintln!(
                "    σθ in [{}, {}): {n} px, lookup {:.2}°, spatial {:.2}° (sums {:.0} / {:.0})",
                w[0],
                w[1],
                ea / n as f64,
                eb / n as f64,
                ea,
                eb
            );
        }
    }
}

#[allow(clippy::needless_range_loop)]
/// Mean errors binned by the distance (pixels, 4-connected) to the mask's edge.
fn by_distance(a: &NormalMap, b: &NormalMap, t: &NormalMap, m: &Mask) {
    let (w, h) = (m.width, m.height);
    let mut d = vec![u32::MAX; w * h];
    let mut queue = std::collections::VecDeque::new();
    for r in 0..h {
        for c in 0..w {
            let i = r * w + c;
            let edge = |rr: i64, cc: i64| {
                rr < 0
                    || cc < 0
                    || rr >= h as i64
                    || cc >= w as i64
                    || !m.data[rr as usize * w + cc as usize]
            };
            let (ri, ci) = (r as i64, c as i64);
            if m.data[i]
                && (edge(ri - 1, ci) || edge(ri + 1, ci) || edge(ri, ci - 1) || edge(ri, ci + 1))
            {
                d[i] = 0;
                queue.push_back(i);
            }
        }
    }
    while let Some(i) = queue.pop_front() {
        let (r, c) = (i / w, i % w);
        for (rr, cc) in [
            (r.wrapping_sub(1), c),
            (r + 1, c),
            (r, c.wrapping_sub(1)),
            (r, c + 1),
        ] {
            if rr < h && cc < w {
                let j = rr * w + cc;
                if m.data[j] && d[j] == u32::MAX {
                    d[j] = d[i] + 1;
                    queue.push_back(j);
                }
            }
        }
    }
    let ang = |x: [f32; 3], y: [f32; 3]| {
        (x[0] * y[0] + x[1] * y[1] + x[2] * y[2])
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees() as f64
    };
    for w2 in [0u32, 3, 10, 20, 40, u32::MAX].windows(2) {
        let (mut n, mut ea, mut eb) = (0usize, 0.0, 0.0);
        for i in 0..m.data.len() {
            if m.data[i] && d[i] >= w2[0] && d[i] < w2[1] {
                n += 1;
                ea += ang(a.data[i], t.data[i]);
                eb += ang(b.data[i], t.data[i]);
            }
        }
        if n > 0 {
            eprintln!(
                "    edge distance [{}, {}): {n} px, lookup {:.2}°, spatial {:.2}°",
                w2[0],
                w2[1],
                ea / n as f64,
                eb / n as f64
            );
        }
    }
}

/// Gaussian noise of standard deviation `sigma`, clipped at 0 (as in a 16-bit image).
fn add_noise(stack: &mut ImageStack, sigma: f32, seed: u64) {
    let mut g = synth::random::SplitMix64::new(seed);
    for v in stack.data.iter_mut() {
        *v = (*v + sigma * g.normal() as f32).max(0.0);
    }
}

fn peak(s: &ImageStack) -> f32 {
    s.data.iter().copied().fold(0.0, f32::max)
}

fn pair(sphere_dir: &str, target_dir: &str, noise: f32) -> anyhow::Result<()> {
    let opts = io::LoadOptions::default();
    let s = io::load_dataset(sphere_dir.as_ref(), &opts)?;
    let t = io::load_dataset(target_dir.as_ref(), &opts)?;
    let truth = io::read_normals_npy(&std::path::Path::new(target_dir).join("normal_gt.npy"))?;
    let mask = t
        .mask
        .clone()
        .ok_or_else(|| anyhow::anyhow!("{target_dir}: no mask.png"))?;
    let mut case = Case {
        sphere: s.stack,
        target: t.stack,
        mask,
        truth,
        circle: None,
    };
    let sigma = noise * peak(&case.sphere).max(peak(&case.target));
    add_noise(&mut case.sphere, sigma, 1);
    add_noise(&mut case.target, sigma, 2);
    let r = run(&case)?;
    println!(
        "noise {:.3}: lookup {:.3}°, spatial {:.3}°, idw {:.3}°; lookup {:.3} s, spatial {:.3} s",
        noise, r.lookup, r.spatial, r.idw, r.lookup_s, r.spatial_s
    );
    Ok(())
}

fn synth_case(material: Material, noise: f32) -> anyhow::Result<Case> {
    let mut opts = SceneOptions {
        shape: Shape::preset(ShapeKind::Blob, 256, 256),
        material,
        noise_sigma: 0.0,
        seed: 3,
        ..SceneOptions::default()
    };
    // exposure so that the brightest sample of target and sphere is 0.98 (as `synth`)
    let p = synth::peak_radiance_with_sphere(&opts, 100.0)?;
    opts.exposure = if p > 0.98 { 0.98 / p } else { 1.0 };
    opts.noise_sigma = noise;
    opts.camera = synth::Camera::quantized(16);
    let target = synth::render(&opts)?;
    let sphere = synth::render_calibration_sphere(&opts, 100.0)?;
    Ok(Case {
        sphere: sphere.stack,
        target: target.stack,
        mask: target.mask,
        truth: target.normals,
        circle: Some(Circle {
            cx: 102.0,
            cy: 102.0,
            radius: 100.0,
        }),
    })
}

fn sweep(png: &str) -> anyhow::Result<()> {
    let levels = [0.0f32, 0.005, 0.01, 0.02, 0.05];
    let materials = [
        ("lambertian", Material::lambertian(0.8)),
        ("plastic", Material::shiny_plastic()),
        ("metal", Material::metal()),
    ];
    let mut csv = String::from("material,noise,lookup_deg,spatial_deg,idw6_deg\n");
    let mut series = Vec::new();
    let colors = [[30, 60, 200], [200, 100, 20], [30, 150, 60]];
    for ((name, mat), color) in materials.iter().zip(colors) {
        let mut pts = [Vec::new(), Vec::new(), Vec::new()];
        for &n in &levels {
            let r = run(&synth_case(*mat, n)?)?;
            println!(
                "{name:>10} noise {:>4.1}%: lookup {:6.2}°  spatial {:6.2}°  idw6 {:6.2}°",
                100.0 * n,
                r.lookup,
                r.spatial,
                r.idw
            );
            csv += &format!("{name},{n},{:.4},{:.4},{:.4}\n", r.lookup, r.spatial, r.idw);
            let x = 100.0 * n as f64;
            pts[0].push((x, r.spatial));
            pts[1].push((x, r.lookup));
            pts[2].push((x, r.idw));
        }
        let [sp, lk, idw] = pts;
        let dim = |c: [u8; 3]| c.map(|v| (v as u16 + 2 * 255).div_ceil(3) as u8);
        series.push(Series {
            label: format!("{name}: lookup + spatial"),
            points: sp,
            color,
            width: 3,
        });
        series.push(Series {
            label: format!("{name}: lookup alone"),
            points: lk,
            color: dim(color),
            width: 2,
        });
        series.push(Series {
            label: format!("{name}: 6 nearest entries"),
            points: idw,
            color: dim(dim(color)),
            width: 1,
        });
    }
    let plot = LinePlot {
        title: "Blob, sphere r = 100, 16 lights: mean angular error vs noise".into(),
        x_label: "noise (% of full scale)".into(),
        y_label: "mean angular error (deg)".into(),
        series,
        ref_lines: Vec::new(),
        y_log: true,
    };
    std::fs::write(png, plot.to_png((900, 600))?)?;
    std::fs::write(std::path::Path::new(png).with_extension("csv"), csv)?;
    println!("wrote {png} and its .csv");
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args
        .iter()
        .map(|s| s.as_str())
        .collect::<Vec<_>>()
        .as_slice()
    {
        ["sweep", png] => sweep(png),
        ["pair", s, t, n] => pair(s, t, n.parse()?),
        ["one", m, n] => {
            let mat = match *m {
                "lambertian" => Material::lambertian(0.8),
                "plastic" => Material::shiny_plastic(),
                _ => Material::metal(),
            };
            let r = run(&synth_case(mat, n.parse()?)?)?;
            println!("{r:?}");
            Ok(())
        }
        _ => anyhow::bail!(
            "usage: noise_sweep sweep OUT.png | noise_sweep pair SPHERE_DIR TARGET_DIR NOISE"
        ),
    }
}
