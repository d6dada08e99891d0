//! Images as cameras make them (issue 24): 8-bit quantisation, optical blur, a black
//! level and highlights clipped at full scale, on the project's own renders (blob target
//! 256², sphere r = 100, 16 lights, no added noise). Every case prints the plain
//! nearest neighbour and the 6-neighbour inverse-distance baseline of the same table,
//! the lookup alone (`normals --no-spatial`) and the default pipeline (`normals`), with
//! the true circle and with the circle found by the sphere detection.
//!
//! The "measured" comments give each test's figures at their date. Two changes of the
//! spatial stage came after most of them (2026-12-07: the prior's largest scale 0.01 →
//! 0.005, the contour's tilt 0.98 ± 0.03 → 0.995 ± 0.01; docs/accuracy.md). The defaults
//! that moved, measured 2026-12-08 (true circle / circle found): metal 8-bit 0.241 /
//! 0.235°; blurred with a black level 0.238 / 0.258°; clipped 0.151 / 0.155°; blurred and
//! clipped 0.238 / 0.236°; α 0.15 8-bit 0.574 / 0.557°, blurred 0.404 / 0.502°; α 0.1
//! 8-bit 0.874°; Lambertian clipped 0.088 / 0.144°. Every other default is within 0.003°
//! of its comment.

mod common;
use common::camera_case::{camera, check, measure, Case};
use photostereo::sphere::Circle;
use photostereo::synth::{self, Camera, Material, SceneOptions, Shape, ShapeKind};

/// Target and sphere of `material` through `camera`, exposed so that the brightest
/// highlight of both is at full scale (`synth --exposure peak`).
fn render(material: Material, camera: Camera) -> Case {
    render_exposed(material, camera, 1.0)
}

/// [`render`] with `over` times that exposure: every sample above full scale clipped
/// (`synth --exposure FACTOR`).
fn render_exposed(material: Material, camera: Camera, over: f32) -> Case {
    render_shape((ShapeKind::Blob, true), material, camera, over)
}

/// [`render_exposed`] with a target of another shape (`synth --shape`), with or without
/// cast shadows (`synth --no-shadows`).
fn render_shape(
    (kind, cast_shadows): (ShapeKind, bool),
    material: Material,
    camera: Camera,
    over: f32,
) -> Case {
    let mut opts = SceneOptions {
        shape: Shape::preset(kind, 256, 256),
        cast_shadows,
        material,
        lights: synth::default_lights(16),
        camera,
        seed: 5,
        ..SceneOptions::default()
    };
    opts.exposure = over * synth::exposure_for_full_scale(&opts, Some(100.0), 1.0).unwrap();
    let target = synth::render(&opts).unwrap();
    let sphere = synth::render_calibration_sphere(&opts, 100.0).unwrap();
    Case {
        sphere: sphere.stack,
        truth_circle: Circle {
            cx: 102.0,
            cy: 102.0,
            radius: 100.0,
        },
        target: target.stack,
        mask: target.mask,
        truth: target.normals,
    }
}

// Measured 2026-12-03 (true circle / circle found), default against `--no-spatial`;
// before the censored samples, the quantisation floor of the noise and the rule that
// a pixel's own data may reject its neighbours' normal the default was 3.88 / 11.32°
// (8-bit metal) and 22.0° (blurred metal, circle found); with them but before the
// quantisation floor of the sphere's noise (which sets the table's smoothing) 1.050 /
// 1.077° and 1.254 / 1.268°, the lookup 1.161 / 1.141° and 1.265 / 1.264°.

// With the prior's local scale (`spatial::roughness`) the defaults went 0.536 / 0.516 →
// 0.418 / 0.378° (8-bit metal), 0.594 / 0.620 → 0.496 / 0.509° (blurred metal), 0.091 /
// 0.095 → 0.061 / 0.066° (8-bit plastic), 0.211 → 0.184° (blurred plastic); the bounds
// below were tightened to those figures. With the rim model that follows a metal to 90°
// as well (lut/fit/rim.rs), the figures in the tests' comments.

#[test]
fn metal_8bit_exposed_for_its_peak() {
    // measured: nearest 1.184 / 1.178°, lookup 0.788 / 0.784°, default 0.273 / 0.267°
    // (before the spatial solve's per-pixel stopping test 0.284 / 0.285°)
    let case = render(Material::metal(), camera(8, 0.0, 0.0));
    check("metal 8-bit", &case, 0.45);
}

#[test]
fn metal_8bit_blurred_with_black_level() {
    // measured 2026-12-07: nearest 1.193 / 1.191°, lookup 1.009 / 1.009°, default 0.321 /
    // 0.346° (0.481 / 0.496° before the outline's evidence was weighted by the sphere's
    // measured blur, `spatial::outline_weight`)
    let case = render(Material::metal(), camera(8, 0.8, 0.03));
    check("metal 8-bit blur 0.8 black 3%", &case, 0.4);
}

#[test]
fn plastic_8bit_exposed_for_its_peak() {
    // measured: nearest 0.448 / 0.448°, lookup 0.101 / 0.103°, default 0.063 / 0.067°
    // (0.059 / 0.063° before the spatial stage's lack-of-fit scaling, 2026-12-06)
    let case = render(Material::shiny_plastic(), camera(8, 0.0, 0.0));
    check("plastic 8-bit", &case, 0.075);
}

#[test]
fn plastic_8bit_blurred_with_black_level() {
    // measured 2026-12-06: nearest 0.459 / 0.460°, lookup 0.161 / 0.160°, default 0.082 /
    // 0.083° (0.117 / 0.116° before the spatial stage's lack-of-fit scaling; 0.081 /
    // 0.080° since 2026-12-07, the outline weighted by the measured blur); before the
    // outline's coverage divided the light above the black level (`lut::coverage_refit`)
    // lookup 0.205 / 0.204°, default 0.158 / 0.158°. Issue 24's target < 0.20° (hidden
    // renders there)
    let case = render(Material::shiny_plastic(), camera(8, 0.8, 0.03));
    check("plastic 8-bit blur 0.8 black 3%", &case, 0.10);
}

#[test]
fn metal_8bit_overexposed_twice_clips_its_highlights() {
    // twice the exposure for the peak: the lobe's top is clipped at 255 on sphere and
    // target. measured: nearest 0.915 / 0.909°, lookup 0.460 / 0.458°, default 0.159 /
    // 0.161° (0.190 / 0.192° before the spatial stage's lack-of-fit scaling)
    let case = render_exposed(Material::metal(), camera(8, 0.0, 0.0), 2.0);
    check("metal 8-bit, exposure ×2 (clipped)", &case, 0.25);
}

#[test]
fn plastic_8bit_blurred_overexposed_twice_clips_its_highlights() {
    // measured 2026-12-06: nearest 0.430 / 0.433°, lookup 0.140 / 0.138°, default 0.095 /
    // 0.094° (0.080 / 0.080° since 2026-12-07, the outline weighted by the measured blur;
    // 0.123 / 0.122° before the spatial stage's lack-of-fit scaling; before the
    // outline's coverage divided the light above the black level lookup 0.165 / 0.163°,
    // default 0.149 / 0.147°)
    let case = render_exposed(Material::shiny_plastic(), camera(8, 0.8, 0.03), 2.0);
    check(
        "plastic 8-bit blur 0.8 black 3%, exposure ×2 (clipped)",
        &case,
        0.11,
    );
}

// The rest of issue 24's table of error by case (docs/accuracy.md, "Error by case"):
// Lambertian through each camera, and the clean 16-bit renders of the three materials.

#[test]
fn lambertian_16bit() {
    // measured (true circle / circle found): nearest 0.407 / 0.408°, lookup 0.006 / 0.018°, default 0.006 / 0.018°
    // (before `spatial::DECIDED_BY_OWN` 0.0058 against the lookup's 0.0057°: +2.6%)
    let case = render(Material::lambertian(0.8), camera(16, 0.0, 0.0));
    check("lambertian 16-bit", &case, 0.025);
}

#[test]
fn lambertian_8bit_exposed_for_its_peak() {
    // measured (true circle / circle found): nearest 0.412 / 0.412°, lookup 0.052 / 0.055°,
    // default 0.041 / 0.046° (0.039 / 0.042° before the spatial stage's lack-of-fit
    // scaling: its quantised table's interpolation error exceeds σ here)
    let case = render(Material::lambertian(0.8), camera(8, 0.0, 0.0));
    check("lambertian 8-bit", &case, 0.05);
}

#[test]
fn lambertian_8bit_blurred_with_black_level() {
    // measured 2026-12-06 (true circle / circle found): nearest 0.426 / 0.427°, lookup
    // 0.138 / 0.136°, default 0.097 / 0.095° (0.083 / 0.081° since 2026-12-07, the
    // outline weighted by the measured blur; 0.124 / 0.123° before the spatial stage's
    // lack-of-fit scaling; before the outline's coverage divided the light above the black
    // level lookup 0.161 / 0.160°, default 0.148 / 0.146°)
    let case = render(Material::lambertian(0.8), camera(8, 0.8, 0.03));
    check("lambertian 8-bit blur 0.8 black 3%", &case, 0.095);
}

#[test]
fn lambertian_8bit_overexposed_twice_clips() {
    // measured (true circle / circle found): nearest 0.586 / 0.593°, lookup 0.209 / 0.224°,
    // default 0.103 / 0.104° (0.130 / 0.120° before the lack-of-fit scaling)
    // (before the spatial solve's per-pixel stopping test 0.172 / 0.188°)
    let case = render_exposed(Material::lambertian(0.8), camera(8, 0.0, 0.0), 2.0);
    check("lambertian 8-bit, exposure ×2 (clipped)", &case, 0.21);
}

#[test]
fn plastic_16bit() {
    // measured (true circle / circle found): nearest 0.433 / 0.433°, lookup 0.009 / 0.020°, default 0.009 / 0.020°
    let case = render(Material::shiny_plastic(), camera(16, 0.0, 0.0));
    check("plastic 16-bit", &case, 0.025);
}

#[test]
fn metal_16bit() {
    // measured (true circle / circle found): nearest 0.709 / 0.705°, lookup 0.0124 /
    // 0.0523°, default 0.0120 / 0.0521°. Before the spatial solve stopped on every
    // pixel's own correction (`spatial::solve`, `converged`) the default was 0.0133 /
    // 0.053° (+7.8% with the true circle, issue 24's rule missed): the conjugate
    // gradients stopped at a relative residual dominated by the best-lit pixels, with
    // the dim rim (80–90°) still where the coarser level's interpolation had put it,
    // 0.053 / 0.114° instead of the lookup's 0.021 / 0.023°.
    let case = render(Material::metal(), camera(16, 0.0, 0.0));
    check("metal 16-bit", &case, 0.06);
}

#[test]
fn plastic_8bit_overexposed_twice_clips() {
    // measured (true circle / circle found): nearest 0.415 / 0.416°, lookup 0.059 / 0.063°,
    // default 0.046 / 0.051° (0.043 / 0.047° before the lack-of-fit scaling)
    let case = render_exposed(Material::shiny_plastic(), camera(8, 0.0, 0.0), 2.0);
    check("plastic 8-bit, exposure ×2 (clipped)", &case, 0.06);
}

#[test]
fn metal_8bit_blurred_overexposed_twice_clips() {
    // measured (true circle / circle found): nearest 0.820 / 0.820°, lookup 0.648 / 0.648°, default 0.388 / 0.389°
    // (before the spatial solve's per-pixel stopping test 0.420 / 0.417°; 2026-12-07:
    // 0.261 / 0.257°, from 0.364 / 0.366°, the outline weighted by the measured blur)
    let case = render_exposed(Material::metal(), camera(8, 0.8, 0.03), 2.0);
    check(
        "metal 8-bit blur 0.8 black 3%, exposure ×2 (clipped)",
        &case,
        0.32,
    );
}

/// The metal of [`Material::metal`] (GGX, no diffuse part, F₀ 0.9) with GGX width `alpha`.
fn metal_of_width(alpha: f32) -> Material {
    Material::Ggx {
        kd: 0.0,
        ks: 0.9,
        roughness: alpha,
    }
}

#[test]
fn shinier_metal_8bit_leaves_a_dark_rim_that_the_prior_continues() {
    // GGX α 0.15: 37% of the target's pixels are below 6 levels in every image (an
    // annulus beyond about 45° of tilt), the hidden rough aluminium's share of pixels
    // with at most two lights above 5 levels (55%) is matched (57%). Measured (true
    // circle / circle found): nearest 2.091 / 2.085°, lookup 1.902 / 1.897°, default
    // 0.777 / 0.774°; with the solve's former ridge (1e-3, `spatial::solve`) the default
    // was 1.74° with the circle found; with the refit without the pixels whose own
    // data reject the solution (`spatial::solve_with_rejection`) 0.715 / 0.694°
    let case = render(metal_of_width(0.15), camera(8, 0.0, 0.0));
    check("metal α 0.15 8-bit", &case, 0.75);
}

#[test]
fn shiniest_metal_8bit_true_circle() {
    // GGX α 0.1: three quarters of the samples are 0 and the sphere's circle is not
    // found in its maximum image (only the lit cap shows), so the true circle. Measured:
    // nearest 21.9°, lookup 21.7°, default 1.04° (17.9° with the former ridge)
    let case = render(metal_of_width(0.1), camera(8, 0.0, 0.0));
    let r = measure(&case, &case.truth_circle);
    println!("metal α 0.1 8-bit, true circle: {r:?}");
    assert!(r.spatial < 1.2 && r.spatial < 0.1 * r.lookup, "{r:?}");
}

#[test]
fn vgroove_metal_8bit_without_cast_shadows_keeps_its_flat_faces() {
    // Two planar faces at ±45° meeting at a crease, GGX α 0.15, 8-bit, no cast shadows
    // (`synth --shape vgroove --no-shadows`). Measured (true circle / circle found):
    // nearest 0.484 / 0.493°, lookup 0.1568 / 0.1652°, default 0.1568 / 0.1651°. Before the refit
    // without the pixels whose own data reject the solution
    // (`spatial::solve_with_rejection`) the default was 0.1721° (true circle), +9.8%
    // over the lookup: their matches bent the flat faces near the crease by 0.1–0.2°.
    let shape = (ShapeKind::VGroove, false);
    let case = render_shape(shape, metal_of_width(0.15), camera(8, 0.0, 0.0), 1.0);
    check("V-groove metal α 0.15 8-bit, no cast shadows", &case, 0.2);
}

#[test]
fn shinier_metal_8bit_blurred_with_black_level_found_as_a_faint_disk() {
    // GGX α 0.15, 0.8 px blur, 3% black level: the sphere's maximum image is the lit cap
    // and a rim one grey level above the background (9 against 8), so neither the
    // bright blob nor the contrast edges find the circle; the faint disk (`sphere`,
    // step 6b) does. Before it, `calibrate` failed on this sphere.
    let case = render(metal_of_width(0.15), camera(8, 0.8, 0.03));
    check("metal α 0.15 8-bit, blur 0.8 px, black 3%", &case, 0.9);
}

#[test]
fn shinier_metal_16bit_keeps_its_grazing_normals() {
    // GGX α 0.15, clean 16-bit: the table ends at 78.5° and the lookup extends it by its
    // rim model. The spatial stage read the table clamped to its edge there, so a
    // grazing pixel's own data could not tell 79° from 89°, and the prior moved pixels
    // matched within 0.05° by up to 10°. Measured (true circle / circle found): nearest
    // 0.779 / 0.767°, lookup 0.0485 / 0.0896°; the default was 0.0632 / 0.1049° (+30% /
    // +17%, the 2% rule broken), with the rim model in the evidence
    // (`spatial::info::Reflectance`) 0.0458 / 0.0879°, with the lack-of-fit scaling
    // 0.0239 / 0.0646°.
    let case = render(metal_of_width(0.15), camera(16, 0.0, 0.0));
    check("metal α 0.15 16-bit", &case, 0.1);
}
