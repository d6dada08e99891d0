//! Lookup speed: a 1024 × 1024 target, K = 16, table from a sphere of radius 150 px.
//!
//! `cargo bench -p photostereo --bench lut` prints the time of one whole-image lookup;
//! the pixel rate (Mpx/s over the mask) is printed once before the measurement.

#[path = "../tests/lut_support/mod.rs"]
mod lut_support;

use criterion::{criterion_group, criterion_main, Criterion};
use lut_support::{bumps, lights, sphere, Brdf};
use photostereo::lut::{self, BuildOptions, Options, Table};
use photostereo::progress::NoProgress;
use std::time::Instant;

fn lookup(c: &mut Criterion) {
    let brdf = Brdf {
        kd: 0.6,
        ks: 0.5,
        shininess: 40.0,
    };
    let l = lights(16);
    let (sph, circle) = sphere(310, 150.0, &l, brdf);
    let table = Table::build(&sph, &circle, &BuildOptions::default()).expect("table");
    let (target, mask, _) = bumps(1024, &l, brdf, &|_, _| 1.0);
    let tables = [table];
    let opts = Options {
        method: match std::env::var("LUT_METHOD").as_deref() {
            Ok("nearest") => lut::Method::Nearest,
            _ => lut::Method::Refined,
        },
        candidates: env_or("LUT_CANDIDATES", 4),
        pca_dims: env_or("LUT_DIMS", 6),
        ..Options::default()
    };
    let (start, cpu0) = (Instant::now(), cpu_seconds());
    let out = lut::solve(&target, &mask, &tables, &opts, &NoProgress).expect("solve");
    let (secs, cpu) = (start.elapsed().as_secs_f64(), cpu_seconds() - cpu0);
    println!(
        "lookup 1024x1024, K=16, table r=150 ({} entries): {:.3} s, {:.2} Mpx/s ({} threads)",
        tables[0].entries.len(),
        secs,
        out.stats.pixels as f64 / secs / 1e6,
        rayon::current_num_threads()
    );
    // The machine is shared: CPU time tells what 2 idle cores would do.
    println!(
        "  CPU time {cpu:.3} s = {:.2} µs/px per core -> {:.2} Mpx/s on 2 idle cores",
        cpu / out.stats.pixels as f64 * 1e6,
        2.0 * out.stats.pixels as f64 / cpu / 1e6
    );
    println!("{:?}", out.stats);
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

/// User + system CPU time of this process (Linux `/proc/self/stat`), 0 elsewhere.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit(')')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (ticks(11) + ticks(12)) / 100.0
}

criterion_group!(benches, lookup);
criterion_main!(benches);
