//! Render speed of the synthetic scenes: 256 × 256, K = 16, shiny plastic, cast shadows,
//! one measurement per shape.
//!
//! `cargo bench -p photostereo --bench synth`

use criterion::{criterion_group, criterion_main, Criterion};
use photostereo::synth::{render, SceneOptions, Shape, ShapeKind};
use std::time::Duration;

fn shapes(c: &mut Criterion) {
    let mut group = c.benchmark_group("synth render 256x256 K=16");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    for (name, kind) in [
        ("sphere", ShapeKind::Sphere),
        ("blob", ShapeKind::Blob),
        ("vase", ShapeKind::Vase),
        ("bowl", ShapeKind::Bowl),
        ("vgroove", ShapeKind::VGroove),
    ] {
        let opts = SceneOptions {
            shape: Shape::preset(kind, 256, 256),
            ..SceneOptions::default()
        };
        group.bench_function(name, |b| b.iter(|| render(&opts).expect("render")));
    }
    group.finish();
}

criterion_group!(benches, shapes);
criterion_main!(benches);
