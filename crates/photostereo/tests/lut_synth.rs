//! Done-when figures of the lookup-table method on rendered scenes (`synth`): tables
//! from a rendered calibration sphere of the same material, targets with exact normals.
//! Every test prints the figures and the 6-nearest-neighbour inverse-distance baseline.

mod common;
use common::angle_deg;
use photostereo::image::{dot3, Mask, NormalMap};
use photostereo::lut::{self, BuildOptions, Method, Options, Output, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::Circle;
use photostereo::synth::{self, Material, Scene, SceneOptions, Shape, ShapeKind};

fn scene(material: Material, noise: f32, texture: bool) -> SceneOptions {
    SceneOptions {
        width: 192,
        height: 192,
        shape: Shape::preset(ShapeKind::Vase, 192, 192),
        material,
        noise_sigma: noise,
        albedo_texture: texture,
        seed: 3,
        ..SceneOptions::default()
    }
}

fn table(opts: &SceneOptions, radius: f64, rim: f64) -> Table {
    let sphere = synth::render_calibration_sphere(
        &SceneOptions {
            seed: 99,
            ..opts.clone()
        },
        radius,
    )
    .unwrap();
    let circle = Circle {
        cx: sphere.stack.width as f64 / 2.0,
        cy: sphere.stack.height as f64 / 2.0,
        radius,
    };
    Table::build(
        &sphere.stack,
        &circle,
        &BuildOptions {
            rim,
            ..BuildOptions::default()
        },
    )
    .unwrap()
}

/// Mean angular error over the pixels selected by `keep`.
fn mean_err(est: &NormalMap, truth: &NormalMap, keep: impl Fn(usize) -> bool) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for i in 0..truth.data.len() {
        if keep(i) {
            sum += angle_deg(est.data[i], truth.data[i]);
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

struct Figures {
    all: f64,
    unshadowed: f64,
    shadowed: f64,
    confident: f64,
    baseline: f64,
}

fn figures(s: &Scene, out: &Output, base: &Output) -> Figures {
    let m = &s.mask;
    Figures {
        all: mean_err(&out.normals, &s.normals, |i| m.data[i]),
        unshadowed: mean_err(&out.normals, &s.normals, |i| {
            m.data[i] && s.shadowed.data[i] == 0
        }),
        shadowed: mean_err(&out.normals, &s.normals, |i| {
            m.data[i] && s.shadowed.data[i] > 0
        }),
        confident: mean_err(&out.normals, &s.normals, |i| {
            m.data[i] && out.confidence.data[i] >= 0.5
        }),
        baseline: mean_err(&base.normals, &s.normals, |i| m.data[i]),
    }
}

fn run(name: &str, opts: &SceneOptions, radius: f64, rim: f64, lut_opts: &Options) -> Figures {
    let s = synth::render(opts).unwrap();
    let t = [table(opts, radius, rim)];
    let out = lut::solve(&s.stack, &s.mask, &t, lut_opts, &NoProgress).unwrap();
    let base_opts = Options {
        method: Method::InverseDistance { neighbours: 6 },
        ..lut_opts.clone()
    };
    let base = lut::solve(&s.stack, &s.mask, &t, &base_opts, &NoProgress).unwrap();
    check_outputs(&s.mask, &out);
    let f = figures(&s, &out, &base);
    let shadowed = s
        .mask
        .data
        .iter()
        .zip(&s.shadowed.data)
        .filter(|(m, s)| **m && **s > 0)
        .count();
    println!(
        "{name}: mean {:.3}° (no cast shadow {:.3}°, {shadowed} cast-shadow px {:.3}°, confidence ≥ 0.5 {:.3}°); 6-NN IDW baseline {:.3}°",
        f.all, f.unshadowed, f.shadowed, f.confident, f.baseline
    );
    f
}

fn check_outputs(mask: &Mask, out: &Output) {
    for i in 0..mask.data.len() {
        if mask.data[i] {
            let n = out.normals.data[i];
            assert!((dot3(n, n) - 1.0).abs() < 1e-4, "pixel {i} normal {n:?}");
            assert!((0.0..=1.0).contains(&out.confidence.data[i]));
        }
    }
}

/// Plain Lambertian least squares with the true lights (all K samples), for comparison.
/// Mean angular error over the mask of plain Lambertian least squares on the scene
/// `opts` renders (the comparison the issue asks to print beside the lookup).
fn lambertian_lsq_error(opts: &SceneOptions) -> f64 {
    let s = synth::render(opts).unwrap();
    mean_err(&lambertian_lsq(&s), &s.normals, |i| s.mask.data[i])
}

fn lambertian_lsq(s: &Scene) -> NormalMap {
    let l = &s.lights.directions;
    let mut ata = [[0.0f64; 3]; 3];
    for d in l {
        for a in 0..3 {
            for b in 0..3 {
                ata[a][b] += (d[a] * d[b]) as f64;
            }
        }
    }
    let inv = invert3(ata);
    NormalMap::from_fn(s.stack.width, s.stack.height, |r, c| {
        let px = s.stack.pixel(r, c);
        let mut atb = [0.0f64; 3];
        for (d, v) in l.iter().zip(px) {
            (0..3).for_each(|a| atb[a] += (d[a] * v) as f64);
        }
        let g: Vec<f64> = (0..3)
            .map(|a| (0..3).map(|b| inv[a][b] * atb[b]).sum())
            .collect();
        photostereo::image::normalize([g[0] as f32, g[1] as f32, g[2] as f32])
    })
}

fn invert3(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            let (r0, r1) = ((j + 1) % 3, (j + 2) % 3);
            let (c0, c1) = ((i + 1) % 3, (i + 2) % 3);
            *v = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det;
        }
    }
    inv
}

#[test]
fn ggx_plastic_clean_and_noisy() {
    let clean = scene(Material::shiny_plastic(), 0.0, false);
    let f = run(
        "GGX plastic, clean, rim 1 px",
        &clean,
        100.0,
        1.0,
        &Options::default(),
    );
    assert!(
        f.all < 0.25 && f.unshadowed < 0.15,
        "clean: {:.3}° / {:.3}°",
        f.all,
        f.unshadowed
    );
    assert!(f.shadowed < 2.0 && f.all < f.baseline);
    let f2 = run(
        "GGX plastic, clean, rim 2 px",
        &clean,
        100.0,
        2.0,
        &Options::default(),
    );
    assert!(f2.all < 0.25);
    let noisy = scene(Material::shiny_plastic(), 0.01, false);
    let f = run(
        "GGX plastic, 1% noise",
        &noisy,
        100.0,
        1.0,
        &Options::default(),
    );
    let lsq = lambertian_lsq_error(&noisy);
    println!("  Lambertian least squares on the same noisy data: {lsq:.2}°");
    // the issue expects > 5° for Lambertian least squares on its scene; on this one it
    // is what is printed: the lookup must be several times better
    assert!(
        f.all < 0.8 && f.all < lsq / 5.0,
        "noisy {:.3}°, Lambertian {lsq:.2}°",
        f.all
    );
}

/// The comparison scene: a grey GGX plastic with sharper highlights than
/// `Material::shiny_plastic` — k_d 0.5, F₀ 0.04 (a dielectric of index 1.5), α 0.07 —
/// under the same 16 lights. Its specular part is large enough against the diffuse one
/// that plain Lambertian least squares is off by more than 5°, the lookup is not.
#[test]
fn grey_sharp_plastic_lookup_against_lambertian_least_squares() {
    let grey = Material::Ggx {
        kd: 0.5,
        ks: 0.04,
        roughness: 0.07,
    };
    let clean = scene(grey, 0.0, false);
    let f = run(
        "grey GGX plastic α 0.07, clean",
        &clean,
        100.0,
        1.0,
        &Options::default(),
    );
    let lsq_clean = lambertian_lsq_error(&clean);
    let noisy = scene(grey, 0.01, false);
    let f_noisy = run(
        "grey GGX plastic α 0.07, 1% noise",
        &noisy,
        100.0,
        1.0,
        &Options::default(),
    );
    let lsq_noisy = lambertian_lsq_error(&noisy);
    println!(
        "  Lambertian least squares: {lsq_clean:.2}° clean, {lsq_noisy:.2}° with 1% noise; \
         lookup {:.3}° / {:.3}°",
        f.all, f_noisy.all
    );
    assert!(f.all < 0.25 && f.unshadowed < 0.15 && f.shadowed < 2.0 && f.all < f.baseline);
    assert!(f_noisy.all < 0.8 && f_noisy.all < f_noisy.baseline);
    assert!(lsq_clean > 5.0 && lsq_noisy > 5.0);
}

#[test]
fn metal_uses_confidence_against_dark_pixels() {
    let f = run(
        "metal, clean",
        &scene(Material::metal(), 0.0, false),
        100.0,
        1.0,
        &Options::default(),
    );
    assert!(f.all < 0.3, "{:.3}°", f.all); // measured 0.088°
    let f = run(
        "metal, 1% noise",
        &scene(Material::metal(), 0.01, false),
        100.0,
        1.0,
        &Options::default(),
    );
    // measured: all 0.843°, confident (≥ 0.5) 0.131°: the confidence flags the dark,
    // noise-dominated pixels
    assert!(
        f.confident < 0.35 && f.all < 2.0 && f.confident < f.all / 3.0,
        "{:.3}° / confident {:.3}°",
        f.all,
        f.confident
    );
}

#[test]
fn lambertian_material() {
    let f = run(
        "Lambertian, clean",
        &scene(Material::lambertian(0.8), 0.0, false),
        100.0,
        1.0,
        &Options::default(),
    );
    assert!(f.all < 0.15, "{:.3}°", f.all);
    let f = run(
        "Lambertian, 1% noise",
        &scene(Material::lambertian(0.8), 0.01, false),
        100.0,
        1.0,
        &Options::default(),
    );
    assert!(f.all < 0.6, "{:.3}°", f.all);
}

#[test]
fn small_sphere_and_textured_albedo() {
    let clean = scene(Material::shiny_plastic(), 0.0, false);
    let f = run(
        "GGX plastic, sphere radius 50 px",
        &clean,
        50.0,
        1.0,
        &Options::default(),
    );
    assert!(f.all < 0.35, "{:.3}°", f.all);
    let textured = scene(Material::shiny_plastic(), 0.0, true);
    let opts = Options {
        normalize: true,
        ..Options::default()
    };
    let f = run(
        "GGX plastic, textured albedo, normalised matching",
        &textured,
        100.0,
        1.0,
        &opts,
    );
    assert!(f.all < 0.5, "{:.3}°", f.all);
}

#[test]
fn two_material_mixture() {
    let (ma, mb) = (Material::lambertian(0.8), Material::metal());
    let sa = synth::render(&scene(ma, 0.0, false)).unwrap();
    let sb = synth::render(&scene(mb, 0.0, false)).unwrap();
    let w = sa.stack.width;
    let weights = |i: usize| {
        let u = (i % w) as f32 / (w - 1) as f32;
        (1.0 - 0.5 * u, 0.1 + 0.3 * u)
    };
    let mut target = sa.stack.clone();
    for i in 0..sa.stack.pixels() {
        let (a, b) = weights(i);
        for (t, v) in target
            .pixel_flat_mut(i)
            .iter_mut()
            .zip(sb.stack.pixel_flat(i))
        {
            *t = a * *t + b * v;
        }
    }
    let tables = [
        table(&scene(ma, 0.0, false), 100.0, 1.0),
        table(&scene(mb, 0.0, false), 100.0, 1.0),
    ];
    let out = lut::solve(&target, &sa.mask, &tables, &Options::default(), &NoProgress).unwrap();
    check_outputs(&sa.mask, &out);
    let err = mean_err(&out.normals, &sa.normals, |i| sa.mask.data[i]);
    let wts = out.weights.as_ref().unwrap();
    let sigma = out.weight_sigma.as_ref().unwrap();
    // Weights are undefined where the table has no such normal (grazing, beyond the
    // table's rim) and poorly defined at grazing normals lit by few lights without a
    // highlight (the two materials then trade off against the normal): there the
    // weights' standard error is large and the confidence low. Report the share of
    // pixels within 0.05 over the whole mask, the mean and the worst, and the same over
    // the confident pixels (confidence ≥ 0.5).
    let (mut within, mut sum, mut worst, mut n) = (0usize, 0.0f64, 0.0f32, 0usize);
    let (mut c_within, mut c_worst, mut c_n, mut sigma_ok) = (0usize, 0.0f32, 0usize, 0usize);
    for i in (0..sa.mask.data.len()).filter(|&i| sa.mask.data[i]) {
        let (a, b) = weights(i);
        let e = (wts[0].data[i] - a).abs().max((wts[1].data[i] - b).abs());
        within += (e <= 0.05) as usize;
        sum += e as f64;
        worst = worst.max(e);
        n += 1;
        // the stated standard error covers the actual error (within 3σ, or 0.01)
        sigma_ok += (e <= (3.0 * sigma.data[i]).max(0.01)) as usize;
        if out.confidence.data[i] >= 0.5 {
            c_within += (e <= 0.05) as usize;
            c_worst = c_worst.max(e);
            c_n += 1;
        }
    }
    let share = within as f64 / n as f64;
    let c_share = c_within as f64 / c_n as f64;
    println!(
        "mixture Lambertian + metal: mean {err:.3}°; weights: {:.2}% of {n} px within 0.05, mean error {:.4}, worst {worst:.3}; \
         confident ({:.2}% of the mask): {:.3}% within 0.05, worst {c_worst:.3}; error within 3σ_w: {:.2}%",
        100.0 * share,
        sum / n as f64,
        100.0 * c_n as f64 / n as f64,
        100.0 * c_share,
        100.0 * sigma_ok as f64 / n as f64,
    );
    assert!(err < 1.0 && share > 0.99 && sum / (n as f64) < 0.01);
    assert!(c_share >= 0.999 && c_n as f64 > 0.97 * n as f64);
    assert!(sigma_ok as f64 > 0.995 * n as f64);
}
