//! Property tests: any size and shape renders without panicking.

use photostereo::synth::{default_lights, render, Material, SceneOptions, Shape, ShapeKind};
use proptest::prelude::*;

fn kind() -> impl Strategy<Value = ShapeKind> {
    prop_oneof![
        Just(ShapeKind::Sphere),
        Just(ShapeKind::Blob),
        Just(ShapeKind::Vase),
        Just(ShapeKind::Bowl),
        Just(ShapeKind::VGroove),
    ]
}

fn material() -> impl Strategy<Value = Material> {
    prop_oneof![
        Just(Material::lambertian(0.9)),
        Just(Material::phong()),
        Just(Material::shiny_plastic()),
        Just(Material::metal()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn any_size_and_shape_renders(
        w in 0usize..24, h in 0usize..24, kind in kind(), material in material(),
        k in 1usize..6, shadows in any::<bool>(), texture in any::<bool>(),
        noise in 0f32..0.1, quant in any::<bool>(), seed in any::<u64>(),
    ) {
        let o = SceneOptions {
            width: w, height: h, shape: Shape::preset(kind, w, h), material,
            lights: default_lights(k), cast_shadows: shadows, albedo_texture: texture,
            noise_sigma: noise, camera: photostereo::synth::Camera { bits: quant.then_some(16), ..Default::default() }, seed, ..Default::default()
        };
        match render(&o) {
            Ok(s) => {
                prop_assert!(w > 0 && h > 0);
                prop_assert_eq!(s.stack.data.len(), w * h * k);
                prop_assert!(s.stack.data.iter().all(|v| v.is_finite()));
                for i in 0..s.mask.len() {
                    prop_assert_eq!(s.mask.data[i], s.depth.data[i].is_finite());
                }
            }
            Err(e) => {
                prop_assert!(w == 0 || h == 0, "unexpected error {}", e);
                prop_assert!(e.to_string().contains("at least 1 pixel"));
            }
        }
    }

    #[test]
    fn arbitrary_shape_parameters_render(
        a in 0.1f64..40.0, b in 0.1f64..40.0, c in 0.0f64..40.0, ang in -180f64..180.0,
        opening in 1f64..179.0,
    ) {
        let shapes = [
            Shape::Sphere { radius: a },
            Shape::Blob { rx: a, ry: b, height: c, angle_deg: ang },
            Shape::Bowl { radius: a.max(b), depth: a.min(b) },
            Shape::VGroove { angle_deg: opening, depth: a },
        ];
        for shape in shapes {
            let o = SceneOptions { width: 17, height: 12, shape, lights: default_lights(4), ..Default::default() };
            let s = render(&o).unwrap();
            prop_assert!(s.stack.data.iter().all(|v| v.is_finite()));
        }
    }
}
