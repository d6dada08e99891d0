//! Speed of the lookup's mixture paths against the single-table lookup, side by side
//! on the same render: `split_specular` (one sphere's table split into a diffuse and a
//! specular part) and two tables (two materials blended), beside the single table with
//! normalised matching.
//!
//! Scenes (the project's renderer, 256², K = 16, tables of radius-100 spheres): a GGX
//! plastic vase with 16-px albedo patches on its diffuse part (single normalised and
//! split), and the vase blended column by column from a Lambertian and a shiny-plastic
//! render (two tables). With `../shared/data` present, also the Mitsuba renders: the
//! textured plastic of `tests/data/mitsuba_textured_plastic` in the plastic sphere's
//! table, and the blob blended from the Lambertian and plastic renders in both tables.
//!
//! `cargo bench -p photostereo --bench lut_mixture` prints, per case, the wall and CPU
//! time of one whole lookup, the ratio to the single-table run on the same scene, and
//! the mean angular error against the true normals. `MIX_ONLY=name` runs only the cases
//! whose name contains it; `MIX_REPEAT=n` runs each n times (for a profiler).

use photostereo::image::{dot3, ImageStack, Mask, NormalMap};
use photostereo::io::{self, LoadOptions};
use photostereo::lut::{self, BuildOptions, Options, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::Circle;
use photostereo::synth::{self, Material, SceneOptions, Shape, ShapeKind};
use std::path::PathBuf;
use std::time::Instant;

mod common;
use common::cpu_seconds;

const SIZE: usize = 256;

struct Case {
    name: String,
    stack: ImageStack,
    mask: Mask,
    truth: NormalMap,
    tables: Vec<Table>,
    opts: Options,
    /// Index of the case this one is compared with (the single-table run).
    base: Option<usize>,
}

fn scene(material: Material, texture: bool, seed: u64) -> SceneOptions {
    SceneOptions {
        width: SIZE,
        height: SIZE,
        shape: Shape::preset(ShapeKind::Vase, SIZE, SIZE),
        material,
        albedo_texture: texture,
        lights: synth::default_lights(16),
        seed,
        ..SceneOptions::default()
    }
}

fn sphere_table(material: Material) -> Table {
    let sphere = synth::render_calibration_sphere(&scene(material, false, 99), 100.0).unwrap();
    let circle = Circle {
        cx: sphere.stack.width as f64 / 2.0,
        cy: sphere.stack.height as f64 / 2.0,
        radius: 100.0,
    };
    let build = BuildOptions {
        rim: 1.0,
        ..BuildOptions::default()
    };
    Table::build(&sphere.stack, &circle, &build).unwrap()
}

/// t·a + (1 − t)·b per pixel, t a ramp 0.1 … 0.9 over the columns.
fn blend(a: &ImageStack, b: &ImageStack) -> ImageStack {
    let mut out = a.clone();
    let w = a.width;
    for i in 0..a.pixels() {
        let t = 0.1 + 0.8 * (i % w) as f32 / (w - 1) as f32;
        for (o, v) in out.pixel_flat_mut(i).iter_mut().zip(b.pixel_flat(i)) {
            *o = t * *o + (1.0 - t) * v;
        }
    }
    out
}

fn normalized(split: bool) -> Options {
    Options {
        normalize: true,
        split_specular: split,
        ..Options::default()
    }
}

/// The synthetic cases: textured plastic (single normalised, split), two materials
/// (single normalised on the first table, two tables).
fn synthetic(cases: &mut Vec<Case>) {
    let (kd, ks, roughness) = (0.7, 0.04, 0.1);
    let ggx = Material::Ggx { kd, ks, roughness };
    let full = synth::render(&scene(ggx, true, 3)).unwrap();
    let spec_only = Material::Ggx {
        kd: 0.0,
        ks,
        roughness,
    };
    let spec = synth::render(&scene(spec_only, true, 3)).unwrap();
    let mut stack = full.stack.clone();
    for i in 0..stack.pixels() {
        let (r, c) = (i / SIZE, i % SIZE);
        let a = if (r / 16 + c / 16) % 2 == 0 {
            1.0
        } else {
            0.45
        };
        for (t, s) in stack
            .pixel_flat_mut(i)
            .iter_mut()
            .zip(spec.stack.pixel_flat(i))
        {
            *t = a * (*t - s) + s;
        }
    }
    let table = sphere_table(ggx);
    let base = cases.len();
    for (name, split) in [
        ("synthetic textured plastic, single", false),
        ("synthetic textured plastic, split", true),
    ] {
        cases.push(Case {
            name: name.into(),
            stack: stack.clone(),
            mask: full.mask.clone(),
            truth: full.normals.clone(),
            tables: vec![table.clone()],
            opts: normalized(split),
            base: split.then_some(base),
        });
    }
    let (ma, mb) = (Material::lambertian(0.8), Material::shiny_plastic());
    let a = synth::render(&scene(ma, false, 3)).unwrap();
    let b = synth::render(&scene(mb, false, 3)).unwrap();
    let target = blend(&a.stack, &b.stack);
    let tables = vec![sphere_table(ma), sphere_table(mb)];
    let base = cases.len();
    cases.push(Case {
        name: "synthetic two materials, single".into(),
        stack: target.clone(),
        mask: a.mask.clone(),
        truth: a.normals.clone(),
        tables: vec![tables[1].clone()],
        opts: normalized(false),
        base: None,
    });
    cases.push(Case {
        name: "synthetic two materials, two tables".into(),
        stack: target,
        mask: a.mask,
        truth: a.normals,
        tables,
        opts: Options::default(),
        base: Some(base),
    });
}

fn shared(rel: &str) -> Option<io::Dataset> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let dir = root.join(rel);
    dir.is_dir()
        .then(|| io::load_dataset(&dir, &LoadOptions::default()).unwrap())
}

/// The Mitsuba cases (skipped with a note when `../shared/data` is absent).
fn mitsuba(cases: &mut Vec<Case>) {
    let names = [
        "calib_diffuse",
        "calib_roughplastic",
        "target_diffuse",
        "target_roughplastic",
    ];
    let sets: Vec<_> = names.iter().map(|n| shared(n)).collect();
    let [Some(cd), Some(cp), Some(td), Some(tp)] = &sets[..] else {
        println!("(no ../shared/data: the Mitsuba cases are skipped)");
        return;
    };
    let circle = Circle {
        cx: 128.0,
        cy: 128.0,
        radius: 100.0,
    };
    let build = BuildOptions::default();
    let tp_table = Table::build(&cp.stack, &circle, &build).unwrap();
    let td_table = Table::build(&cd.stack, &circle, &build).unwrap();
    let tex = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba_textured_plastic");
    if let Ok(target) = io::load_dataset(&tex, &LoadOptions::default()) {
        let truth = io::read_normals_npy(&tex.join("normal_gt.npy")).unwrap();
        let mask = target.mask.clone().unwrap();
        let base = cases.len();
        for (name, split) in [
            ("Mitsuba textured plastic, single", false),
            ("Mitsuba textured plastic, split", true),
        ] {
            cases.push(Case {
                name: name.into(),
                stack: target.stack.clone(),
                mask: mask.clone(),
                truth: truth.clone(),
                tables: vec![tp_table.clone()],
                opts: normalized(split),
                base: split.then_some(base),
            });
        }
    }
    let truth = io::read_normals_npy(&td.dir.join("normal_gt.npy")).unwrap();
    let mask = td.mask.clone().unwrap();
    let target = blend(&td.stack, &tp.stack);
    let base = cases.len();
    cases.push(Case {
        name: "Mitsuba two materials, single".into(),
        stack: target.clone(),
        mask: mask.clone(),
        truth: truth.clone(),
        tables: vec![tp_table.clone()],
        opts: normalized(false),
        base: None,
    });
    cases.push(Case {
        name: "Mitsuba two materials, two tables".into(),
        stack: target,
        mask,
        truth,
        tables: vec![td_table, tp_table],
        opts: Options::default(),
        base: Some(base),
    });
}

fn mean_error(est: &NormalMap, truth: &NormalMap, mask: &Mask) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for i in (0..mask.data.len()).filter(|&i| mask.data[i]) {
        sum += (dot3(est.data[i], truth.data[i]) as f64)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        n += 1;
    }
    sum / n.max(1) as f64
}

fn main() {
    let only = std::env::var("MIX_ONLY").unwrap_or_default();
    let repeat: usize = std::env::var("MIX_REPEAT")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let mut cases = Vec::new();
    synthetic(&mut cases);
    mitsuba(&mut cases);
    println!(
        "lookup, mixture paths beside the single table ({} threads)",
        rayon::current_num_threads()
    );
    let mut times = vec![(0.0f64, 0.0f64); cases.len()];
    for (i, case) in cases.iter().enumerate() {
        let base_selected = cases
            .iter()
            .any(|c| c.base == Some(i) && c.name.contains(&only));
        if !case.name.contains(&only) && !base_selected {
            continue;
        }
        let (start, cpu0) = (Instant::now(), cpu_seconds());
        let mut out = None;
        for _ in 0..repeat {
            out = Some(
                lut::solve(
                    &case.stack,
                    &case.mask,
                    &case.tables,
                    &case.opts,
                    &NoProgress,
                )
                .unwrap(),
            );
        }
        let out = out.unwrap();
        let wall = start.elapsed().as_secs_f64() / repeat as f64;
        let cpu = (cpu_seconds() - cpu0) / repeat as f64;
        times[i] = (wall, cpu);
        // the fixed cost (tables split or extended, index, coarse grid): one pixel
        let mut one = Mask::filled(case.mask.width, case.mask.height, false);
        let first = case.mask.data.iter().position(|&m| m).unwrap_or(0);
        one.data[first] = true;
        let cpu1 = cpu_seconds();
        let start = Instant::now();
        lut::solve(&case.stack, &one, &case.tables, &case.opts, &NoProgress).unwrap();
        let (setup, setup_cpu) = (start.elapsed().as_secs_f64(), cpu_seconds() - cpu1);
        let ratio = case.base.map_or(String::new(), |b| {
            format!(
                ", ×{:.1} wall / ×{:.1} CPU of the single table",
                wall / times[b].0,
                cpu / times[b].1
            )
        });
        println!(
            "  {:<40} {:>6} px: {wall:.3} s wall, {cpu:.3} s CPU ({:.1} µs/px CPU; set-up {setup:.3} s wall, {setup_cpu:.2} s CPU){ratio}; mean error {:.4}°",
            case.name,
            out.stats.pixels,
            cpu / out.stats.pixels as f64 * 1e6,
            mean_error(&out.normals, &case.truth, &case.mask)
        );
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "  load average {}",
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
}
