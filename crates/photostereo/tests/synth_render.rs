//! Numerical checks of the synthetic renderer against closed-form ground truth.

use photostereo::image::{dot3, normalize, pixel_to_xy, Lights};
use photostereo::synth::{
    default_lights, peak_radiance, render, render_calibration_sphere, shade, shape_geometry, Bump,
    Material, SceneOptions, Shape, ShapeKind,
};

fn opts(shape: Shape, material: Material, size: usize) -> SceneOptions {
    SceneOptions {
        width: size,
        height: size,
        shape,
        material,
        ..Default::default()
    }
}

#[test]
fn lambertian_sphere_reproduces_albedo_n_dot_l() {
    let o = SceneOptions {
        albedo_texture: true,
        ..opts(
            Shape::Sphere { radius: 40.0 },
            Material::lambertian(0.8),
            96,
        )
    };
    let s = render(&o).unwrap();
    let mut checked = 0;
    for r in (0..96).step_by(5) {
        for c in (0..96).step_by(3) {
            let (x, y) = pixel_to_xy(r, c, 96, 96);
            let rho2 = x * x + y * y;
            if rho2 >= 40.0 * 40.0 {
                assert!(!*s.mask.get(r, c));
                assert!(s.stack.pixel(r, c).iter().all(|&v| v == 0.0));
                continue;
            }
            // Exact sphere normal, independent of the renderer.
            let n = [
                (x / 40.0) as f32,
                (y / 40.0) as f32,
                ((1.0 - rho2 / 1600.0).sqrt()) as f32,
            ];
            let a = *s.albedo.get(r, c);
            assert!((0.8 * 0.4 - 1e-6..=0.8 + 1e-6).contains(&a));
            for (i, l) in s.lights.directions.iter().enumerate() {
                let expected = a * dot3(n, *l).max(0.0);
                let got = s.stack.pixel(r, c)[i];
                assert!(
                    (got - expected).abs() < 1e-5,
                    "({r},{c}) light {i}: {got} vs {expected}"
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 100);
}

#[test]
fn default_lights_are_unit_and_within_15_to_60_degrees() {
    for k in [1, 3, 16, 96] {
        let l = default_lights(k);
        assert_eq!(l.len(), k);
        for d in &l.directions {
            assert!((dot3(*d, *d) - 1.0).abs() < 1e-6);
            let theta = d[2].acos().to_degrees();
            assert!((15.0 - 1e-3..=60.0 + 1e-3).contains(&theta), "{theta}");
        }
    }
    // Spread: with 16 lights every azimuth quadrant holds at least 2 lights.
    let l = default_lights(16);
    for q in 0..4 {
        let n = l
            .directions
            .iter()
            .filter(|d| ((d[1].atan2(d[0]).to_degrees() + 360.0) % 360.0 / 90.0) as usize == q)
            .count();
        assert!(n >= 2, "quadrant {q} has {n} lights");
    }
}

/// A flat disc-shaped plate with one tall narrow bump at the centre.
fn tower() -> Shape {
    Shape::Vase {
        rx: 60.0,
        ry: 60.0,
        height: 0.0,
        bumps: vec![Bump {
            x: 0.0,
            y: 0.0,
            amplitude: 40.0,
            sigma: 4.0,
        }],
    }
}

#[test]
fn pixel_behind_a_bump_is_in_cast_shadow() {
    // Light from +x at 10° elevation; the pixel 20 px left of the bump lies in its
    // shadow: the bump is 40 px tall, the ray rises only tan(10°)·20 ≈ 3.5 px.
    let elev = 10f32.to_radians();
    let from_right = [elev.cos(), 0.0, elev.sin()];
    let from_left = [-elev.cos(), 0.0, elev.sin()];
    let o = SceneOptions {
        lights: Lights::from_directions(vec![from_right, from_left]),
        ..opts(tower(), Material::lambertian(1.0), 128)
    };
    let s = render(&o).unwrap();
    // x = c + 0.5 - 64 = -20.5 at c = 43, y = 64 - r - 0.5 = -0.5 at r = 64.
    let (r, c) = (64, 43);
    let n = *s.normals.get(r, c);
    assert!(n[2] > 0.99999, "the plate is flat there: {n:?}");
    assert_eq!(s.stack.pixel(r, c)[0], 0.0, "dark behind the bump");
    assert!(
        (s.stack.pixel(r, c)[1] - elev.sin()).abs() < 1e-4,
        "lit from the other side"
    );
    assert_eq!(*s.shadowed.get(r, c), 1);
    // The same pixel without cast shadows is lit by both.
    let s2 = render(&SceneOptions {
        cast_shadows: false,
        ..o.clone()
    })
    .unwrap();
    assert!((s2.stack.pixel(r, c)[0] - elev.sin()).abs() < 1e-4);
    // Along the row: the shadow of the 40 px top reaches x ≈ -40/tan(10°) ≈ -227,
    // beyond the plate, so every flat pixel behind the bump is dark, and every flat
    // pixel in front of it (facing the light, nothing in between) is lit.
    for c in 0..128 {
        let (x, _) = pixel_to_xy(r, c, 128, 128);
        if !*s.mask.get(r, c) {
            continue;
        }
        if x < -25.0 {
            assert_eq!(s.stack.pixel(r, c)[0], 0.0, "x={x}");
        }
        if x > 25.0 {
            assert!((s.stack.pixel(r, c)[0] - elev.sin()).abs() < 1e-3, "x={x}");
        }
    }
}

#[test]
fn low_bump_casts_shadow_where_geometry_predicts() {
    // Bump of height 10, σ = 4 under a light at 30° elevation from +x. A pixel at x is
    // shadowed iff some point at horizontal distance t toward the light is higher than
    // z(x) + t·tan(30°); predicted here on the analytic surface with fine steps.
    let elev = 30f64.to_radians();
    let l = [elev.cos() as f32, 0.0, elev.sin() as f32];
    let bump = Bump {
        x: 0.0,
        y: 0.0,
        amplitude: 10.0,
        sigma: 4.0,
    };
    let o = SceneOptions {
        lights: Lights::from_directions(vec![l]),
        shape: Shape::Vase {
            rx: 60.0,
            ry: 60.0,
            height: 0.0,
            bumps: vec![bump],
        },
        ..opts(tower(), Material::lambertian(1.0), 128)
    };
    let s = render(&o).unwrap();
    let r = 64; // y = -0.5
    let g = |x: f64| 10.0 * (-(x * x + 0.25) / 32.0).exp();
    let (mut disagreements, mut dark_count) = (0, 0);
    for c in 20..64 {
        let (x, _) = pixel_to_xy(r, c, 128, 128);
        let predicted = (1..1000).any(|i| {
            let t = i as f64 * 0.05;
            g(x + t) > g(x) + t * elev.tan() + 0.05
        });
        let dark = s.stack.pixel(r, c)[0] == 0.0;
        let lit_by_brdf = dot3(*s.normals.get(r, c), l) > 0.0;
        if lit_by_brdf {
            dark_count += dark as usize;
            if predicted != dark {
                disagreements += 1;
            }
        }
    }
    assert!(dark_count >= 5, "only {dark_count} shadowed pixels");
    assert!(
        disagreements <= 1,
        "{disagreements} pixels disagree with geometry"
    );
}

#[test]
fn ggx_metal_is_black_far_from_the_highlight() {
    let l = normalize([0.0, 0.5, 1.0]);
    let o = SceneOptions {
        lights: Lights::from_directions(vec![l]),
        ..opts(Shape::Sphere { radius: 50.0 }, Material::metal(), 120)
    };
    let s = render(&o).unwrap();
    let h = normalize([l[0], l[1], l[2] + 1.0]);
    let mut far = 0;
    let mut peak = 0f32;
    for i in 0..s.mask.len() {
        if !s.mask.data[i] {
            continue;
        }
        let n = s.normals.data[i];
        let v = s.stack.pixel_flat(i)[0];
        peak = peak.max(v);
        // GGX tail at n·h = 0.4, α = 0.2: π·D ≈ 0.056, so F·G·πD/(4 n_z) < 0.03.
        if dot3(n, h) < 0.4 && n[2] > 0.5 {
            assert!(v < 0.03, "metal away from the highlight: {v}");
            far += 1;
        }
        // kd = 0: exactly the plastic radiance minus its diffuse part.
        let with_diffuse = shade(
            &Material::Ggx {
                kd: 0.6,
                ks: 0.9,
                roughness: 0.2,
            },
            n,
            l,
            1.0,
        );
        assert!((with_diffuse - 0.6 * dot3(n, l).max(0.0) - v).abs() < 1e-5);
    }
    assert!(far > 150, "{far}");
    assert!(peak > 2.0, "metal highlight peak {peak}");
}

#[test]
fn noise_has_the_requested_sigma() {
    let base = SceneOptions {
        noise_sigma: 0.0,
        ..opts(
            Shape::preset(ShapeKind::Vase, 96, 96),
            Material::shiny_plastic(),
            96,
        )
    };
    let clean = render(&base).unwrap();
    for sigma in [0.01f32, 0.05] {
        let noisy = render(&SceneOptions {
            noise_sigma: sigma,
            seed: 7,
            ..base.clone()
        })
        .unwrap();
        let n = clean.stack.data.len() as f64;
        let diffs: Vec<f64> = clean
            .stack
            .data
            .iter()
            .zip(&noisy.stack.data)
            .map(|(a, b)| (*b - *a) as f64)
            .collect();
        let mean = diffs.iter().sum::<f64>() / n;
        let sd = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n).sqrt();
        assert!(
            (sd / sigma as f64 - 1.0).abs() < 0.1,
            "sigma {sigma}: measured {sd}"
        );
        assert!(mean.abs() < 0.1 * sigma as f64);
    }
    // Deterministic for a given seed.
    let a = render(&SceneOptions {
        noise_sigma: 0.01,
        seed: 3,
        ..base.clone()
    })
    .unwrap();
    let b = render(&SceneOptions {
        noise_sigma: 0.01,
        seed: 3,
        ..base
    })
    .unwrap();
    assert_eq!(a.stack.data, b.stack.data);
}

#[test]
fn sixteen_bit_quantisation_error_is_half_a_level() {
    let base = SceneOptions {
        exposure: 0.5,
        ..opts(
            Shape::preset(ShapeKind::Blob, 80, 80),
            Material::phong(),
            80,
        )
    };
    let float = render(&base).unwrap();
    let q = render(&SceneOptions {
        camera: photostereo::synth::Camera::quantized(16),
        ..base
    })
    .unwrap();
    let mut max_err = 0f64;
    for (a, b) in float.stack.data.iter().zip(&q.stack.data) {
        let level = (*b as f64 * 65535.0).round();
        assert_eq!((level / 65535.0) as f32, *b, "not on a 16-bit level");
        max_err = max_err.max((a.clamp(0.0, 1.0) as f64 - *b as f64).abs());
    }
    assert!(max_err <= 0.5 / 65535.0 + 1e-9, "max error {max_err}");
}

#[test]
fn normals_agree_with_depth_differences() {
    let size = 128;
    for kind in [
        ShapeKind::Sphere,
        ShapeKind::Blob,
        ShapeKind::Vase,
        ShapeKind::Bowl,
        ShapeKind::VGroove,
    ] {
        let shape = Shape::preset(kind, size, size);
        let (depth, mask, normals) = shape_geometry(&shape, size, size);
        let mut checked = 0;
        for r in 2..size - 2 {
            for c in 2..size - 2 {
                let z = |dr: isize, dc: isize| {
                    *depth.get((r as isize + dr) as usize, (c as isize + dc) as usize) as f64
                };
                if !(0..25).all(|i| *mask.get(r + i / 5 - 2, c + i % 5 - 2)) {
                    continue;
                }
                // Smooth neighbourhood only (skips the rims of the bowl and the groove,
                // where the exact normal jumps by > 0.5 between neighbours).
                let n = *normals.get(r, c);
                let jump = (0..25)
                    .map(|i| {
                        let m = *normals.get(r + i / 5 - 2, c + i % 5 - 2);
                        (0..3).map(|j| (m[j] - n[j]).abs()).fold(0f32, f32::max)
                    })
                    .fold(0f32, f32::max);
                if jump > 0.2 || n[2] < 0.5 {
                    continue;
                }
                let p = -(n[0] / n[2]) as f64;
                let q = -(n[1] / n[2]) as f64;
                // Fourth-order central differences (truncation error h⁴·z⁽⁵⁾/30).
                let dzdc = (8.0 * (z(0, 1) - z(0, -1)) - (z(0, 2) - z(0, -2))) / 12.0;
                let dzdr = (8.0 * (z(1, 0) - z(-1, 0)) - (z(2, 0) - z(-2, 0))) / 12.0;
                assert!(
                    (dzdc - p).abs() < 0.01,
                    "{kind:?} ({r},{c}): {dzdc} vs p {p}"
                );
                assert!(
                    (dzdr + q).abs() < 0.01,
                    "{kind:?} ({r},{c}): {dzdr} vs -q {}",
                    -q
                );
                checked += 1;
            }
        }
        assert!(checked > 1000, "{kind:?}: only {checked} pixels checked");
    }
}

#[test]
fn shapes_have_the_documented_curvature() {
    let size = 101;
    let geo = |s: &Shape| shape_geometry(s, size, size);
    let (d, _, _) = geo(&Shape::preset(ShapeKind::Sphere, size, size));
    assert!((*d.get(50, 50) as f64 - 0.45 * 101.0).abs() < 1e-3);
    let (d, _, _) = geo(&Shape::Bowl {
        radius: 30.0,
        depth: 10.0,
    });
    // Rim radius 30: the pixel 29 px right of the centre is inside, 30 px is on the plane.
    assert!((*d.get(50, 50) + 10.0).abs() < 1e-4);
    assert!(*d.get(50, 79) < 0.0 && *d.get(50, 80) == 0.0 && *d.get(0, 0) == 0.0);
    let (d, _, _) = geo(&Shape::VGroove {
        angle_deg: 90.0,
        depth: 20.0,
    });
    assert!((*d.get(50, 50) + 20.0).abs() < 1e-4);
    assert!(
        (*d.get(10, 60) + 10.0).abs() < 1e-4,
        "slope 1 for a 90° groove"
    );
    assert_eq!(*d.get(30, 100), 0.0);
    // Vase: convex and concave regions (sign of the discrete Laplacian).
    let (d, m, _) = geo(&Shape::preset(ShapeKind::Vase, size, size));
    let lap = |r: usize, c: usize| {
        d.get(r - 1, c) + d.get(r + 1, c) + d.get(r, c - 1) + d.get(r, c + 1) - 4.0 * d.get(r, c)
    };
    let (mut convex, mut concave) = (0, 0);
    for r in 1..size - 1 {
        for c in 1..size - 1 {
            if (0..9).all(|i| *m.get(r + i / 3 - 1, c + i % 3 - 1)) {
                let v = lap(r, c);
                convex += (v < -1e-3) as usize;
                concave += (v > 1e-3) as usize;
            }
        }
    }
    assert!(
        convex > 200 && concave > 100,
        "convex {convex}, concave {concave}"
    );
}

#[test]
fn calibration_sphere_matches_the_target_material_and_lights() {
    let o = SceneOptions {
        albedo_texture: true,
        ..opts(tower(), Material::phong(), 64)
    };
    let s = render_calibration_sphere(&o, 20.0).unwrap();
    assert_eq!((s.stack.width, s.stack.height), (44, 44));
    assert_eq!(s.lights, o.lights);
    // Blinn–Phong: kd·(n·l) + ks·(n·h)^s at a pixel near the centre.
    let n = *s.normals.get(21, 21);
    let l = o.lights.directions[0];
    let h = normalize([l[0], l[1], l[2] + 1.0]);
    let expected = 0.7 * dot3(n, l) + 0.5 * dot3(n, h).powf(50.0);
    assert!((s.stack.pixel(21, 21)[0] - expected).abs() < 1e-5);
    assert!(render_calibration_sphere(&o, -1.0).is_err());
}

#[test]
fn bad_options_give_clear_errors() {
    let d = SceneOptions::default;
    let cases = [
        (SceneOptions { width: 0, ..d() }, "at least 1 pixel"),
        (
            SceneOptions {
                lights: Lights::from_directions(vec![]),
                ..d()
            },
            "at least one light",
        ),
        (
            SceneOptions {
                noise_sigma: -1.0,
                ..d()
            },
            "noise_sigma",
        ),
        (
            SceneOptions {
                shape: Shape::Bowl {
                    radius: 10.0,
                    depth: 20.0,
                },
                ..d()
            },
            "depth <= radius",
        ),
        (
            SceneOptions {
                shape: Shape::VGroove {
                    angle_deg: 180.0,
                    depth: 5.0,
                },
                ..d()
            },
            "opening angle",
        ),
        (
            SceneOptions {
                material: Material::Ggx {
                    kd: 0.5,
                    ks: 0.5,
                    roughness: 0.0,
                },
                ..d()
            },
            "roughness > 0",
        ),
    ];
    for (o, needle) in cases {
        let err = render(&o).unwrap_err().to_string();
        assert!(err.contains(needle), "`{err}` lacks `{needle}`");
    }
}

#[test]
fn background_fills_every_image_outside_the_mask() {
    let o = SceneOptions {
        background: 0.25,
        ..opts(Shape::Sphere { radius: 20.0 }, Material::metal(), 50)
    };
    let s = render(&o).unwrap();
    let outside = (0..s.mask.len()).filter(|&i| !s.mask.data[i]).count();
    assert!(outside > 1000);
    for i in (0..s.mask.len()).filter(|&i| !s.mask.data[i]) {
        assert!(s.stack.pixel_flat(i).iter().all(|&v| v == 0.25));
        assert_eq!(s.albedo.data[i], 0.0);
        assert!(s.depth.data[i].is_nan());
    }
}

#[test]
fn peak_radiance_is_the_brightest_unshadowed_sample() {
    for material in [
        Material::metal(),
        Material::shiny_plastic(),
        Material::lambertian(0.5),
    ] {
        let o = SceneOptions {
            cast_shadows: false,
            ..opts(Shape::preset(ShapeKind::Vase, 64, 64), material, 64)
        };
        let s = render(&o).unwrap();
        let max = s.stack.data.iter().copied().fold(0f32, f32::max);
        let peak = peak_radiance(&o).unwrap();
        assert!(
            (peak - max).abs() <= 1e-6 * max,
            "{material:?}: {peak} vs {max}"
        );
    }
}
