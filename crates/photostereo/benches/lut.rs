//! Lookup speed: a 1024 × 1024 rendered target (shiny-plastic vase, 16 lights), K = 16,
//! table from a rendered sphere of radius 150 px — the data of the `lookup` row of
//! `photostereo bench`.
//!
//! `cargo bench -p photostereo --bench lut` prints the rate of one whole-image lookup
//! (Mpx/s over the mask pixels) and the CPU time it took (the machine may be shared),
//! then times it with criterion. `LUT_ONCE=1` stops after the first figure; `LUT_REPEAT=n`
//! runs it n more times, prints the CPU time per run and stops (for a profiler).

use criterion::{criterion_group, criterion_main, Criterion};
use photostereo::lut::{self, BuildOptions, Options, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::Circle;
use photostereo::synth::{self, SceneOptions, Shape, ShapeKind};
use std::time::Instant;

mod common;
use common::cpu_seconds;

fn lookup(c: &mut Criterion) {
    let scene_opts = SceneOptions {
        width: 1024,
        height: 1024,
        shape: Shape::preset(ShapeKind::Vase, 1024, 1024),
        lights: synth::default_lights(16),
        ..SceneOptions::default()
    };
    let scene = synth::render(&scene_opts).expect("target");
    let radius = 150.0;
    let sphere = synth::render_calibration_sphere(&scene_opts, radius).expect("sphere");
    let circle = Circle {
        cx: sphere.stack.width as f64 / 2.0,
        cy: sphere.stack.height as f64 / 2.0,
        radius,
    };
    let table = Table::build(&sphere.stack, &circle, &BuildOptions::default()).expect("table");
    let (target, mask) = (scene.stack, scene.mask);
    let tables = [table];
    let opts = Options {
        candidates: env_or("LUT_CANDIDATES", Options::default().candidates),
        pca_dims: env_or("LUT_DIMS", Options::default().pca_dims),
        shadow_level: std::env::var("LUT_SHADOW")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(Options::default().shadow_level),
        ..Options::default()
    };
    let (start, cpu0) = (Instant::now(), cpu_seconds());
    let out = lut::solve(&target, &mask, &tables, &opts, &NoProgress).expect("solve");
    let (secs, cpu) = (start.elapsed().as_secs_f64(), cpu_seconds() - cpu0);
    let px = out.stats.pixels as f64;
    println!(
        "lookup 1024x1024 ({} mask px), K=16, table r=150 ({} entries): {secs:.3} s, {:.2} Mpx/s ({} threads)",
        out.stats.pixels,
        tables[0].entries.len(),
        px / secs / 1e6,
        rayon::current_num_threads()
    );
    // On a shared machine the CPU time tells what 2 idle cores would do.
    println!(
        "  CPU time {cpu:.3} s = {:.3} µs/px on one core -> {:.2} Mpx/s on 2 idle cores",
        cpu / px * 1e6,
        2.0 * px / cpu / 1e6
    );
    println!("  {:?}", out.stats);
    // `LUT_REPEAT=n` runs the lookup n more times (for a profiler), then stops
    if let Some(n) = std::env::var("LUT_REPEAT")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        let mut cpu = f64::INFINITY;
        for _ in 0..n {
            let cpu0 = cpu_seconds();
            let out = lut::solve(&target, &mask, &tables, &opts, &NoProgress).expect("solve");
            cpu = cpu.min(cpu_seconds() - cpu0);
            std::hint::black_box(out);
        }
        println!(
            "  {n} more runs: least CPU time {cpu:.3} s per run = {:.3} µs/px",
            cpu / px * 1e6
        );
        return;
    }
    if std::env::var("LUT_ONCE").is_ok() {
        return;
    }
    let mut group = c.benchmark_group("lut");
    group
        .sample_size(10)
        .measurement_time(std::time::Duration::from_secs(8));
    group.bench_function("solve_1024_k16_r150", |b| {
        b.iter(|| lut::solve(&target, &mask, &tables, &opts, &NoProgress).expect("solve"))
    });
    group.finish();
}

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

criterion_group!(benches, lookup);
criterion_main!(benches);
