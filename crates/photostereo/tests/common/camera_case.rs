//! One camera-degraded case scored as issue 24 asks (`camera_images.rs`,
//! `camera_mitsuba.rs`): the plain nearest neighbour and the 6-neighbour inverse-distance
//! baseline of a table, the lookup alone (`normals --no-spatial`) and the default
//! pipeline (`normals`), with the true circle and with the circle the detector finds.

use photostereo::lut::{self, BuildOptions, Method, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::{self, Circle, DetectOptions};
use photostereo::synth::Camera;
use photostereo::{eval, spatial, ImageStack, Mask, NormalMap};

/// A sphere's images with its true circle, and a target's images, mask and true normals.
#[derive(Clone)]
pub struct Case {
    pub sphere: ImageStack,
    pub truth_circle: Circle,
    pub target: ImageStack,
    pub mask: Mask,
    pub truth: NormalMap,
}

/// A camera of `bits` per sample, a Gaussian blur of `blur_sigma` px and a black level
/// (fraction of full scale).
pub fn camera(bits: u32, blur_sigma: f32, black_level: f32) -> Camera {
    Camera {
        bits: Some(bits),
        blur_sigma,
        black_level,
    }
}

pub fn mean_error(n: &NormalMap, case: &Case) -> f64 {
    eval::angular_errors(n, &case.truth, &case.mask)
        .unwrap()
        .mean
}

/// Mean errors (degrees) of one table on one case.
#[derive(Debug)]
pub struct Row {
    pub nearest: f64,
    pub idw6: f64,
    pub lookup: f64,
    pub spatial: f64,
    pub stats: spatial::Stats,
}

/// The four methods with the table of `case.sphere` on `circle`.
pub fn measure(case: &Case, circle: &Circle) -> Row {
    let table = Table::build(&case.sphere, circle, &BuildOptions::default()).unwrap();
    let tables = std::slice::from_ref(&table);
    let solve = |method: Method| {
        let opts = lut::Options {
            method,
            ..lut::Options::default()
        };
        lut::solve(&case.target, &case.mask, tables, &opts, &NoProgress).unwrap()
    };
    let out = solve(Method::Refined);
    let noise = spatial::NoiseModel::estimate(&case.target, &case.mask);
    let opts = spatial::Options::default();
    let sp = spatial::solve_table(&case.target, &case.mask, &table, &out, &noise, &opts).unwrap();
    Row {
        nearest: mean_error(&solve(Method::Nearest).normals, case),
        idw6: mean_error(
            &solve(Method::InverseDistance { neighbours: 6 }).normals,
            case,
        ),
        lookup: mean_error(&out.normals, case),
        spatial: mean_error(&sp.normals, case),
        stats: sp.stats,
    }
}

/// (row with the true circle, row with the circle found, circle found), printed.
pub fn both(name: &str, case: &Case) -> (Row, Row, Circle) {
    let found = sphere::detect(&case.sphere, &DetectOptions::default())
        .unwrap()
        .circle;
    let (t, f) = (measure(case, &case.truth_circle), measure(case, &found));
    for (what, r) in [("true circle", &t), ("circle found", &f)] {
        println!(
            "{name}, {what}: nearest {:.3}°, 6-NN IDW {:.3}°, lookup (--no-spatial) {:.4}°, \
             default {:.4}° ({} of {} px decided by neighbours, {} cuts, {} kept their own)",
            r.nearest,
            r.idw6,
            r.lookup,
            r.spatial,
            r.stats.decided_by_neighbours,
            r.stats.pixels,
            r.stats.cut_triples,
            r.stats.kept_own
        );
    }
    let c = &case.truth_circle;
    println!(
        "{name}: circle found off by centre {:.3} px, radius {:+.3} px",
        ((found.cx - c.cx).powi(2) + (found.cy - c.cy).powi(2)).sqrt(),
        found.radius - c.radius
    );
    (t, f, found)
}

/// The rules on one case: the default is never worse than the lookup alone by
/// more than 2%, beats the plain nearest neighbour, and is within `bound` degrees of the
/// truth with either circle; the circle is found within 0.1 px (centre) / 0.15 px
/// (radius).
pub fn check(name: &str, case: &Case, bound: f64) {
    check_within(name, case, bound, [0.1, 0.15]);
}

/// [`check`] with the circle found within `[centre, radius]` px.
pub fn check_within(name: &str, case: &Case, bound: f64, [centre, radius]: [f64; 2]) {
    let (t, f, found) = both(name, case);
    for r in [&t, &f] {
        assert!(
            r.spatial <= 1.02 * r.lookup,
            "{name}: default worse than --no-spatial: {r:?}"
        );
        assert!(r.spatial < r.nearest && r.spatial < bound, "{name}: {r:?}");
    }
    let c = &case.truth_circle;
    let off = ((found.cx - c.cx).powi(2) + (found.cy - c.cy).powi(2)).sqrt();
    assert!(off < centre, "{name}: centre off by {off:.3} px");
    let dr = found.radius - c.radius;
    assert!(dr.abs() < radius, "{name}: radius off by {dr:+.3} px");
}

/// With `PHOTOSTEREO_EXPORT_CAMERA=DIR` set, write `case` as two datasets,
/// `DIR/<slug>/sphere` and `DIR/<slug>/target` (16-bit PNGs named as the stack's images,
/// the target's `mask.png` and `normal_gt.npy`), so that another build's CLI can be run
/// on the very images a test scores (`calibrate DIR/<slug>/sphere`, `normals
/// DIR/<slug>/target --lut …`, `eval`). 8-bit images are held exactly (k/255 is k·257 of
/// 65535).
pub fn export_if_asked(slug: &str, case: &Case) {
    let Some(root) = std::env::var_os("PHOTOSTEREO_EXPORT_CAMERA") else {
        return;
    };
    let dir = std::path::Path::new(&root).join(slug);
    write_pngs(&dir.join("sphere"), &case.sphere);
    let target = dir.join("target");
    write_pngs(&target, &case.target);
    photostereo::io::write_mask_png(&target.join("mask.png"), &case.mask).unwrap();
    photostereo::io::write_normals(&target.join("normal_gt.npy"), &case.truth).unwrap();
}

fn write_pngs(dir: &std::path::Path, stack: &ImageStack) {
    std::fs::create_dir_all(dir).unwrap();
    for (i, name) in stack.names.iter().enumerate() {
        let (w, h) = (stack.width as u32, stack.height as u32);
        let img = image::ImageBuffer::from_fn(w, h, |c, r| {
            let v = stack.pixel(r as usize, c as usize)[i];
            image::Luma([(v.clamp(0.0, 1.0) * 65535.0).round() as u16])
        });
        img.save(dir.join(name)).unwrap();
    }
}
