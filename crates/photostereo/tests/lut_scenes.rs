//! The lookup on composed scenes (issue 10): the calibration sphere and the target in the
//! same images, the sphere found inside a window (`calibrate --sphere-region`), and a
//! target whose pixels blend two materials (`normals --lut A --lut B`). Each case runs on
//! the Mitsuba renders of `../shared/data` (skipped with a note when absent) and on the
//! project's own renderer (`synth`), scored against the true normals by band of the true
//! normal's angle from the view axis.

mod common;
use photostereo::image::{ImageStack, Mask, NormalMap};
use photostereo::io::{self, LoadOptions};
use photostereo::lut::{self, BuildOptions, Options, Output, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::{self, Circle, DetectOptions};
use photostereo::synth::{self, Material, SceneOptions};

use common::lut_score::{print, score, Score};

fn dataset(test: &str, rel: &str) -> Option<io::Dataset> {
    let dir = common::shared::path(test, &format!("data/{rel}"))?;
    Some(io::load_dataset(&dir, &LoadOptions::default()).unwrap())
}

/// `a` and `b` side by side on one canvas filled with `fill`: `a` at column 0, `b` at
/// column `a.width + gap`, each centred vertically. Returns the canvas and the (row,
/// column) offsets of `a` and `b`.
fn side_by_side(
    a: &ImageStack,
    b: &ImageStack,
    gap: usize,
    fill: f32,
) -> (ImageStack, [(usize, usize); 2]) {
    let (w, h) = (a.width + gap + b.width, a.height.max(b.height));
    let mut out = ImageStack::zeros(w, h, a.k);
    out.data.fill(fill);
    out.names = a.names.clone();
    let at = [((h - a.height) / 2, 0), ((h - b.height) / 2, a.width + gap)];
    for (src, &(r0, c0)) in [a, b].into_iter().zip(&at) {
        for r in 0..src.height {
            for c in 0..src.width {
                let i = (r + r0) * w + c + c0;
                out.pixel_flat_mut(i).copy_from_slice(src.pixel(r, c));
            }
        }
    }
    (out, at)
}

/// `mask` and `truth` moved by `(r0, c0)` onto a `w` × `h` canvas.
fn place(
    mask: &Mask,
    truth: &NormalMap,
    w: usize,
    h: usize,
    at: (usize, usize),
) -> (Mask, NormalMap) {
    let (r0, c0) = at;
    let mut m = Mask::filled(w, h, false);
    let mut n = NormalMap::filled(w, h, [0.0; 3]);
    for r in 0..mask.height {
        for c in 0..mask.width {
            *m.get_mut(r + r0, c + c0) = *mask.get(r, c);
            *n.get_mut(r + r0, c + c0) = *truth.get(r, c);
        }
    }
    (m, n)
}

fn lookup(stack: &ImageStack, mask: &Mask, tables: &[Table]) -> Output {
    lut::solve(stack, mask, tables, &Options::default(), &NoProgress).unwrap()
}

fn found(stack: &ImageStack, region: Option<(usize, usize, usize, usize)>) -> Circle {
    let opts = DetectOptions {
        region,
        ..DetectOptions::default()
    };
    sphere::detect(stack, &opts).unwrap().circle
}

/// The sphere found in `stack` (inside `region`), its table, and the target's score.
fn region_case(
    name: &str,
    stack: &ImageStack,
    region: Option<(usize, usize, usize, usize)>,
    mask: &Mask,
    truth: &NormalMap,
    build: &BuildOptions,
) -> (Circle, Score) {
    let circle = found(stack, region);
    let table = Table::build(stack, &circle, build).unwrap();
    let s = score(&lookup(stack, mask, &[table]), truth, mask);
    print(&format!("{name}: circle {circle:?}"), &s);
    (circle, s)
}

/// The Mitsuba sphere (r 100, centre (128, 128)) and blob side by side in one 512 × 256
/// stack; the sphere found inside a window that holds it alone and inside a looser one
/// that takes in part of the blob, against the sphere found in its own images.
#[test]
fn mitsuba_sphere_region() {
    let test = "mitsuba_sphere_region";
    for material in ["diffuse", "roughplastic"] {
        let (Some(calib), Some(target)) = (
            dataset(test, &format!("calib_{material}")),
            dataset(test, &format!("target_{material}")),
        ) else {
            return;
        };
        let truth = io::read_normals_npy(&target.dir.join("normal_gt.npy")).unwrap();
        let tmask = target.mask.clone().unwrap();
        let build = BuildOptions::default();
        let (alone_c, alone) = {
            let circle = found(&calib.stack, None);
            let table = Table::build(&calib.stack, &circle, &build).unwrap();
            let s = score(&lookup(&target.stack, &tmask, &[table]), &truth, &tmask);
            print(
                &format!("{material}, separate images: circle {circle:?}"),
                &s,
            );
            (circle, s)
        };
        let (stack, at) = side_by_side(&calib.stack, &target.stack, 0, 0.0);
        let (mask, truth) = place(&tmask, &truth, stack.width, stack.height, at[1]);
        for (what, region) in [
            ("sphere alone", (0, 0, 256, 256)),
            ("part of the target", (0, 0, 320, 256)),
        ] {
            let (c, s) = region_case(
                &format!("{material}, same images, window over the {what}"),
                &stack,
                Some(region),
                &mask,
                &truth,
                &build,
            );
            let off = ((c.cx - 128.0).powi(2) + (c.cy - 128.0).powi(2)).sqrt();
            assert!(off < 0.05 && (c.radius - 100.0).abs() < 0.05, "{c:?}");
            assert!(
                s.mean <= alone.mean + 0.005,
                "{:.3}° vs {:.3}° ({alone_c:?})",
                s.mean,
                alone.mean
            );
            // measured 0.061 / 0.067° (diffuse / rough plastic), the same as with the
            // sphere in its own images; issue 10's target: < 0.20°
            assert!(s.mean < 0.15, "{material}: {:.3}°", s.mean);
        }
    }
}

/// The project's renderer: a shiny-plastic sphere (r 80) left of a plastic blob in one
/// image stack on a grey background (0.05), the sphere found inside a window.
#[test]
fn synthetic_sphere_region() {
    let opts = SceneOptions {
        background: 0.05,
        ..SceneOptions::default()
    };
    let target = synth::render(&opts).unwrap();
    let sphere_scene = synth::render_calibration_sphere(&opts, 80.0).unwrap();
    let (stack, at) = side_by_side(&sphere_scene.stack, &target.stack, 12, 0.05);
    let (mask, truth) = place(
        &target.mask,
        &target.normals,
        stack.width,
        stack.height,
        at[1],
    );
    let side = sphere_scene.stack.width as f64;
    let truth_circle = Circle {
        cx: side / 2.0,
        cy: at[0].0 as f64 + side / 2.0,
        radius: 80.0,
    };
    let build = BuildOptions::default();
    let exact = Table::build(&stack, &truth_circle, &build).unwrap();
    let base = score(&lookup(&stack, &mask, &[exact]), &truth, &mask);
    print("synthetic, same images, true circle", &base);
    let w = stack.width;
    for (what, region) in [
        ("sphere alone", (0, 0, 180, 256)),
        ("part of the target", (0, 0, 240, 256)),
    ] {
        let (c, s) = region_case(
            &format!("synthetic, same images, window over the {what}"),
            &stack,
            Some(region),
            &mask,
            &truth,
            &build,
        );
        let off = ((c.cx - truth_circle.cx).powi(2) + (c.cy - truth_circle.cy).powi(2)).sqrt();
        assert!(
            off < 0.1 && (c.radius - 80.0).abs() < 0.1,
            "{c:?} (canvas {w} wide)"
        );
        // measured 0.010° (0.009° on the true circle)
        assert!(
            s.mean < base.mean + 0.01 && s.mean < 0.03,
            "{:.3}° vs {:.3}°",
            s.mean,
            base.mean
        );
    }
}

/// Per-pixel blend weight t of the first material: a ramp over the columns, 0.1 … 0.9.
fn ramp(c: usize, w: usize) -> f32 {
    0.1 + 0.8 * c as f32 / (w - 1) as f32
}

/// t·a + (1 − t)·b per pixel, t from [`ramp`].
fn blend(a: &ImageStack, b: &ImageStack) -> ImageStack {
    let mut out = a.clone();
    let w = a.width;
    for i in 0..a.pixels() {
        let t = ramp(i % w, w);
        for (o, v) in out.pixel_flat_mut(i).iter_mut().zip(b.pixel_flat(i)) {
            *o = t * *o + (1.0 - t) * v;
        }
    }
    out
}

/// Mean and worst error of the fitted weights against (t, 1 − t) over the pixels with
/// confidence ≥ 0.5, and the share of the mask that is.
fn weight_errors(out: &Output, mask: &Mask) -> (f64, f32, f64) {
    let wts = out.weights.as_ref().unwrap();
    let (mut sum, mut worst, mut n, mut all) = (0.0f64, 0.0f32, 0usize, 0usize);
    for i in (0..mask.data.len()).filter(|&i| mask.data[i]) {
        all += 1;
        if out.confidence.data[i] < 0.5 {
            continue;
        }
        let t = ramp(i % mask.width, mask.width);
        let e = (wts[0].data[i] - t)
            .abs()
            .max((wts[1].data[i] - (1.0 - t)).abs());
        sum += e as f64;
        worst = worst.max(e);
        n += 1;
    }
    (sum / n.max(1) as f64, worst, n as f64 / all.max(1) as f64)
}

/// The Mitsuba blob blended pixel by pixel from its Lambertian and GGX-plastic renders
/// (t·diffuse + (1 − t)·plastic, t a ramp over the columns: exactly a two-material
/// mixture), looked up in the two spheres' tables on the true and on the found circles.
#[test]
fn mitsuba_two_materials() {
    let test = "mitsuba_two_materials";
    let sets: Vec<_> = [
        "calib_diffuse",
        "calib_roughplastic",
        "target_diffuse",
        "target_roughplastic",
    ]
    .iter()
    .map(|d| dataset(test, d))
    .collect();
    let [Some(cd), Some(cp), Some(td), Some(tp)] = &sets[..] else {
        return;
    };
    let truth = io::read_normals_npy(&td.dir.join("normal_gt.npy")).unwrap();
    let mask = td.mask.clone().unwrap();
    let target = blend(&td.stack, &tp.stack);
    let true_circle = Circle {
        cx: 128.0,
        cy: 128.0,
        radius: 100.0,
    };
    let build = BuildOptions::default();
    for (what, circles) in [
        ("true circles", [true_circle, true_circle]),
        (
            "circles found",
            [found(&cd.stack, None), found(&cp.stack, None)],
        ),
    ] {
        let tables = [
            Table::build(&cd.stack, &circles[0], &build).unwrap(),
            Table::build(&cp.stack, &circles[1], &build).unwrap(),
        ];
        let out = lookup(&target, &mask, &tables);
        let s = score(&out, &truth, &mask);
        let (wmean, wworst, share) = weight_errors(&out, &mask);
        print(&format!("two materials blended, {what}"), &s);
        println!(
            "  weights vs (t, 1 − t) on {:.1}% of the mask (confidence ≥ 0.5): mean error {wmean:.4}, worst {wworst:.3}",
            100.0 * share
        );
        // measured (true circles / circles found): 0.035 / 0.037° (80–90° band 0.50 /
        // 0.51°; 0.182° and 4.53° there before both tables reached 90° on their rim
        // models); weights' mean error 0.0038 / 0.0042 on 94.7% of the mask. Issue 10's
        // target: < 0.15°
        assert!(s.mean < 0.08, "{what}: {:.3}°", s.mean);
        assert!(s.bands[3] < 1.2, "{what}: {s:?}");
        assert!(wmean < 0.01 && share > 0.9, "{wmean} {share}");
    }
}

/// The project's renderer: a blob blended pixel by pixel from a Lambertian (0.8) and a
/// shiny-plastic render, looked up in the two spheres' tables.
#[test]
fn synthetic_two_materials() {
    let scene = |material| SceneOptions {
        material,
        ..SceneOptions::default()
    };
    let (ma, mb) = (Material::lambertian(0.8), Material::shiny_plastic());
    let a = synth::render(&scene(ma)).unwrap();
    let b = synth::render(&scene(mb)).unwrap();
    let target = blend(&a.stack, &b.stack);
    let build = BuildOptions {
        rim: 1.0,
        ..BuildOptions::default()
    };
    let tables = [ma, mb].map(|m| {
        let s = synth::render_calibration_sphere(&scene(m), 100.0).unwrap();
        let half = s.stack.width as f64 / 2.0;
        let circle = Circle {
            cx: half,
            cy: half,
            radius: 100.0,
        };
        Table::build(&s.stack, &circle, &build).unwrap()
    });
    let out = lookup(&target, &a.mask, &tables);
    let s = score(&out, &a.normals, &a.mask);
    let (wmean, wworst, share) = weight_errors(&out, &a.mask);
    print("synthetic two materials blended", &s);
    println!(
        "  weights vs (t, 1 − t) on {:.1}% of the mask (confidence ≥ 0.5): mean error {wmean:.4}, worst {wworst:.3}",
        100.0 * share
    );
    // measured 0.028° (80–90° band 0.33°; 0.065° and 1.93° before the rim models);
    // weights' mean error 0.0016 on the 57% of the mask with confidence ≥ 0.5: without a
    // highlight the plastic's Lambertian diffuse part and the Lambertian material trade
    // off, the weights are unidentifiable there and the confidence says so
    assert!(s.mean < 0.07 && s.bands[3] < 0.8, "{s:?}");
    assert!(wmean < 0.005 && share > 0.45, "{wmean} {share}");
}
