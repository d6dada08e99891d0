//! Criterion benchmarks of the integrators (`cargo bench -p photostereo --bench integrate`).
//! Targets (issue 4): fc and dct on 2048² under 0.3 s and within 2× the FFT floor
//! (one forward + one inverse 2-D real FFT of the grid); lsq on a 1024² disk under 3 s.
//! Issue 11: lsq on the 1024² disk within 3× Frankot–Chellappa on the same input
//! (`fc-disk` in the same group gives the ratio in one run).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use photostereo::image::pixel_to_xy;
use photostereo::integrate::{fft_floor, integrate_gradients, Method, Options};
use photostereo::{GrayImage, Mask};
use std::time::Duration;

fn sphere_gradients(n: usize) -> (GrayImage, GrayImage) {
    photostereo::synth::sphere_cap_gradients(n, n, 0.8 * n as f64)
}

fn fourier(c: &mut Criterion) {
    let n = 2048;
    let (p, q) = sphere_gradients(n);
    let mask = Mask::full(n, n);
    let mut g = c.benchmark_group("integrate-2048");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    g.throughput(Throughput::Elements((n * n) as u64));
    g.bench_function("fft-floor", |b| b.iter(|| fft_floor(&p)));
    for method in [
        Method::FrankotChellappa { reflect: false },
        Method::Dct,
        Method::Path,
    ] {
        let opts = Options {
            method,
            ..Options::default()
        };
        g.bench_with_input(BenchmarkId::from_parameter(method.name()), &opts, |b, o| {
            b.iter(|| integrate_gradients(&p, &q, &mask, o).unwrap())
        });
    }
    g.finish();
}

fn lsq(c: &mut Criterion) {
    let n = 1024;
    let (p, q) = sphere_gradients(n);
    let rad = 0.48 * n as f64;
    let mask = Mask::from_fn(n, n, |r, col| {
        let (x, y) = pixel_to_xy(r, col, n, n);
        x * x + y * y < rad * rad
    });
    let mut g = c.benchmark_group("integrate-lsq-1024");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.throughput(Throughput::Elements(mask.count() as u64));
    for (name, method) in [
        ("lsq-disk", Method::Lsq),
        ("fc-disk", Method::FrankotChellappa { reflect: false }),
    ] {
        let opts = Options {
            method,
            ..Options::default()
        };
        g.bench_function(name, |b| {
            b.iter(|| integrate_gradients(&p, &q, &mask, &opts).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, fourier, lsq);
criterion_main!(benches);
