use photostereo::synth::*;
fn main() {
    for kind in [
        ShapeKind::Sphere,
        ShapeKind::Blob,
        ShapeKind::Vase,
        ShapeKind::Bowl,
        ShapeKind::VGroove,
    ] {
        for size in [256usize, 512] {
            let o = SceneOptions {
                width: size,
                height: size,
                shape: Shape::preset(kind, size, size),
                ..Default::default()
            };
            let t = std::time::Instant::now();
            let s = render(&o).unwrap();
            let sh: u64 = s.shadowed.data.iter().map(|&v| v as u64).sum();
            let mx = s.stack.data.iter().cloned().fold(0f32, f32::max);
            println!(
                "{kind:?} {size}: {:.3}s shadowed {sh} max {mx}",
                t.elapsed().as_secs_f64()
            );
        }
    }
}
