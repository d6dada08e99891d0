//! Interreflection benchmarks (`cargo bench -p photostereo --bench interreflect`).
//!
//! * Kernel at 64×64 (one facet per pixel): horizon visibility (O(n·D·L + n²)) against the
//!   brute-force segment test (O(n²·L)); before measuring, prints how far the bounced light
//!   of the fast kernel is from the brute-force one (target: within 3 %).
//! * The whole iteration on a 256×256 Lambertian bowl (depth 0.4 × radius, albedo 0.8,
//!   12 lights), 4×4-pixel facets (4096 cells): 10 compensation steps (tolerance 0 so that
//!   none stops early), timed once and printed (target: under 30 s on 2 cores), then one step
//!   measured by criterion.

use criterion::{criterion_group, criterion_main, Criterion};
use photostereo::image::{ImageStack, Mask};
use photostereo::interreflect::{
    render_with_interreflections, solve, Kernel, KernelOptions, Model, NikOptions,
    RadiosityOptions, Visibility,
};
use photostereo::progress::NoProgress;
use photostereo::synth::{default_lights, Material, SceneOptions, Shape};
use photostereo::{DepthMap, GrayImage, NormalMap};
use std::time::{Duration, Instant};

// The analytic height fields of the interreflection tests.
#[path = "../tests/common/interreflect_scene.rs"]
#[allow(dead_code)]
mod common;

/// A ring trough around a central hill (many hidden facet pairs).
fn trough(n: usize) -> (DepthMap, NormalMap) {
    let nf = n as f64;
    common::sample(n, n, common::trough(nf / 4.0, nf / 12.0, nf / 8.0))
}

fn bounced(z: &DepthMap, n: &NormalMap, visibility: Visibility) -> ImageStack {
    let mask = Mask::full(z.width, z.height);
    let opts = RadiosityOptions {
        block: 1,
        visibility,
        ..Default::default()
    };
    let model = Model::new(z, n, &mask, &opts, &NoProgress).unwrap();
    let lights = [[0.0f32, 0.0, 1.0], [0.5, 0.0, 0.866], [-0.3, 0.4, 0.866]];
    let direct = common::direct(n, 0.8, &lights);
    model
        .bounce(&direct, &GrayImage::filled(z.width, z.height, 0.8))
        .unwrap()
}

fn kernel_64(c: &mut Criterion) {
    let (z, n) = trough(64);
    let brute = bounced(&z, &n, Visibility::BruteForce);
    let fast = bounced(&z, &n, Visibility::Horizon { azimuths: 64 });
    let none = bounced(&z, &n, Visibility::None);
    let rel = |a: &ImageStack| {
        let num: f64 = a
            .data
            .iter()
            .zip(&brute.data)
            .map(|(x, y)| (x - y).abs() as f64)
            .sum();
        num / brute.data.iter().map(|y| y.abs() as f64).sum::<f64>()
    };
    println!(
        "trough 64x64 bounced light vs brute force: horizon (64 azimuths) {:.2} %, no visibility {:.2} %",
        100.0 * rel(&fast),
        100.0 * rel(&none)
    );
    let mask = Mask::full(64, 64);
    let facets = photostereo::interreflect::facets::Facets::build(&z, &n, &mask, 1).unwrap();
    let opts = |visibility| KernelOptions {
        visibility,
        ..Default::default()
    };
    // The brute-force kernel is far too slow for repeated sampling: timed once.
    let t0 = Instant::now();
    Kernel::build(&facets, &opts(Visibility::BruteForce), &NoProgress).unwrap();
    println!(
        "trough 64x64 brute-force kernel: {:.2} s (one run)",
        t0.elapsed().as_secs_f64()
    );
    let horizon = opts(Visibility::Horizon { azimuths: 64 });
    let mut g = c.benchmark_group("interreflect-kernel-64");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    g.bench_function("horizon-64", |b| {
        b.iter(|| Kernel::build(&facets, &horizon, &NoProgress).unwrap())
    });
    g.finish();
}

fn nik_256(c: &mut Criterion) {
    let size = 256;
    let scene = SceneOptions {
        width: size,
        height: size,
        shape: Shape::Bowl {
            radius: 100.0,
            depth: 40.0,
        },
        material: Material::lambertian(0.8),
        lights: default_lights(12),
        ..Default::default()
    };
    let t0 = Instant::now();
    let radiosity = RadiosityOptions {
        block: 4,
        ..Default::default()
    };
    let s = render_with_interreflections(&scene, &radiosity).unwrap();
    println!(
        "256x256 bowl rendered with interreflections (4x4 facets) in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    let ten = NikOptions {
        max_iter: 10,
        tol: 0.0,
        radiosity,
        ..Default::default()
    };
    let t0 = Instant::now();
    let out = solve(&s.stack, &s.mask, &s.lights, &ten, &NoProgress).unwrap();
    println!(
        "256x256 bowl, {} iterations: {:.1} s (target < 30 s); concavity {:.3} -> {:.3} of truth",
        out.iterations.len() - 1,
        t0.elapsed().as_secs_f64(),
        out.iterations[0].depth_range / 40.0,
        out.iterations[out.best].depth_range / 40.0
    );
    let one = NikOptions {
        max_iter: 1,
        ..ten.clone()
    };
    let mut g = c.benchmark_group("interreflect-nik-256");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("raw + 1 iteration", |b| {
        b.iter(|| solve(&s.stack, &s.mask, &s.lights, &one, &NoProgress).unwrap())
    });
    g.finish();
}

criterion_group!(benches, kernel_64, nik_256);
criterion_main!(benches);
