//! The five real objects of `../shared/data/real` as a new user runs them
//! (`run --lambertian --chrome chrome <object>`): the mesh seen from the side, and how
//! far the outline stands off the surface just inside it.
//!
//! The outline step is |z_b − z_i| over the edges from an outline pixel b (a mask pixel
//! with a 4-neighbour outside the mask) to its neighbour i one pixel further in. Before
//! the trust weights of `integrate::trust_weights` (issue 11, item 5), the side views
//! showed saw-tooth flaps 8–15 px tall along every outline. With `PHOTOSTEREO_DOCS=1`
//! the side views are written to `docs/side-<object>.png` (how the README's pictures
//! are made); `PHOTOSTEREO_SIDE_DEBUG=DIR` writes the weighted and the unweighted
//! meshes seen at 90° and 60° into DIR.

mod common;
use std::path::Path;

use photostereo::integrate;
use photostereo::mesh::Mesh;
use photostereo::pipeline::{self, Inputs, Options};
use photostereo::progress::NoProgress;
use photostereo::Mask;

const OBJECTS: [&str; 5] = ["buddha", "cat", "owl", "horse", "rock"];

/// Outline steps (px) of a depth map: their 95th percentile and their maximum.
fn outline_steps(depth: &[f32], mask: &Mask) -> (f32, f32) {
    let (w, h) = (mask.width, mask.height);
    let inside = |r: isize, c: isize| {
        r >= 0
            && c >= 0
            && (r as usize) < h
            && (c as usize) < w
            && mask.data[r as usize * w + c as usize]
    };
    const N4: [(isize, isize); 4] = [(0, 1), (0, -1), (1, 0), (-1, 0)];
    let outline =
        |r: isize, c: isize| inside(r, c) && N4.iter().any(|&(dr, dc)| !inside(r + dr, c + dc));
    let mut steps = Vec::new();
    for r in 0..h as isize {
        for c in 0..w as isize {
            if !outline(r, c) {
                continue;
            }
            for (dr, dc) in N4 {
                let (ri, ci) = (r + dr, c + dc);
                if inside(ri, ci) && !outline(ri, ci) {
                    let (b, i) = (r as usize * w + c as usize, ri as usize * w + ci as usize);
                    steps.push((depth[b] - depth[i]).abs());
                }
            }
        }
    }
    steps.sort_by(f32::total_cmp);
    let p95 = steps[(steps.len() * 95 / 100).min(steps.len() - 1)];
    (p95, *steps.last().unwrap_or(&0.0))
}

/// A shaded picture of the mesh turned `deg` degrees about the vertical axis (90: seen
/// from the right), orthographic, z-buffered, lit from the viewer.
fn side_view(mesh: &Mesh, deg: f64, size: (u32, u32)) -> image::RgbImage {
    let (s, c) = deg.to_radians().sin_cos();
    let turn = |v: [f32; 3]| {
        let (x, y, z) = (v[0] as f64, v[1] as f64, v[2] as f64);
        [x * c - z * s, y, x * s + z * c]
    };
    let pts: Vec<[f64; 3]> = mesh.vertices.iter().map(|&v| turn(v)).collect();
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for p in &pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let (wf, hf) = (size.0 as f64, size.1 as f64);
    let scale = (0.9 * wf / (hi[0] - lo[0]).max(1e-9)).min(0.9 * hf / (hi[1] - lo[1]).max(1e-9));
    let mid = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let screen = |p: [f64; 3]| {
        [
            wf / 2.0 + (p[0] - mid[0]) * scale,
            hf / 2.0 - (p[1] - mid[1]) * scale,
            p[2],
        ]
    };
    let mut img = image::RgbImage::from_pixel(size.0, size.1, image::Rgb([27, 30, 36]));
    let mut zbuf = vec![f64::MIN; (size.0 * size.1) as usize];
    for f in &mesh.faces {
        let [a, b, cc] = f.map(|k| pts[k as usize]);
        let (u, v) = (sub(b, a), sub(cc, a));
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-12);
        let shade = 0.15 + 0.85 * (n[2] / len).abs();
        let grey = (255.0 * shade).round().clamp(0.0, 255.0) as u8;
        raster(
            &mut img,
            &mut zbuf,
            [screen(a), screen(b), screen(cc)],
            grey,
        );
    }
    img
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Fill a screen triangle (x, y, depth) with `grey` where it is nearest.
fn raster(img: &mut image::RgbImage, zbuf: &mut [f64], t: [[f64; 3]; 3], grey: u8) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let area =
        (t[1][0] - t[0][0]) * (t[2][1] - t[0][1]) - (t[2][0] - t[0][0]) * (t[1][1] - t[0][1]);
    if area.abs() < 1e-12 {
        return;
    }
    let x0 = t
        .iter()
        .map(|p| p[0])
        .fold(f64::MAX, f64::min)
        .floor()
        .max(0.0) as i64;
    let x1 = (t.iter().map(|p| p[0]).fold(f64::MIN, f64::max).ceil() as i64).min(w - 1);
    let y0 = t
        .iter()
        .map(|p| p[1])
        .fold(f64::MAX, f64::min)
        .floor()
        .max(0.0) as i64;
    let y1 = (t.iter().map(|p| p[1]).fold(f64::MIN, f64::max).ceil() as i64).min(h - 1);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let e = |a: [f64; 3], b: [f64; 3]| {
                (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0])
            };
            let l = [
                e(t[1], t[2]) / area,
                e(t[2], t[0]) / area,
                e(t[0], t[1]) / area,
            ];
            if l.iter().any(|&v| v < 0.0) {
                continue;
            }
            let z = l[0] * t[0][2] + l[1] * t[1][2] + l[2] * t[2][2];
            let k = (y * w + x) as usize;
            if z > zbuf[k] {
                zbuf[k] = z;
                img.put_pixel(x as u32, y as u32, image::Rgb([grey; 3]));
            }
        }
    }
}

/// The integrator row of the figures, with the seconds of the integration stage.
fn integrator(out: &pipeline::Output) -> String {
    let row = out.figures.iter().find(|r| r.name == "integrator");
    let secs = out
        .stages
        .iter()
        .find(|s| s.0 == "integration")
        .map_or(0.0, |s| s.1);
    format!("{} [{secs:.2} s]", row.map_or("?", |r| r.value.as_str()))
}

#[test]
fn real_objects_side_views_and_outline_steps() {
    let test = "real_objects_side_views_and_outline_steps";
    let Some(real) = common::shared::path(test, "data/real") else {
        return;
    };
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs");
    for name in OBJECTS {
        let inputs = Inputs {
            target: real.join(name),
            sphere: None,
            calibration: None,
            lambertian: true,
            lights: None,
            chrome: Some(real.join("chrome")),
            mask: None,
            image_scale: None,
            response: Default::default(),
        };
        let opts = Options::default();
        let loaded = pipeline::load(&inputs, &opts, &NoProgress).expect("load");
        let out = pipeline::solve(&loaded.job, &opts, &NoProgress).expect("run");
        let mask = &loaded.job.mask;
        let (p95, max) = outline_steps(&out.depth.data, mask);
        // The same normals integrated without weights, as before item 5.
        let plain = integrate::solve(&out.normals, mask, &integrate::Options::default())
            .expect("unweighted lsq");
        let (p95_plain, max_plain) = outline_steps(&plain.depth.data, mask);
        eprintln!(
            "{name}: {}, outline step 95th percentile {p95:.2} px (unweighted lsq {p95_plain:.2}), \
             max {max:.2} px ({max_plain:.2}), depth range {:.1} px ({:.1}), {} triangles",
            integrator(&out),
            pipeline::depth_range(&out.depth, mask),
            pipeline::depth_range(&plain.depth, mask),
            out.mesh.faces.len()
        );
        assert!(out.mesh.faces.len() > 1000, "{name}: almost no mesh");
        // the camera's black level, measured on the Lambertian fits: 0.0137 / 0.1066 / 0.0012
        // (not taken) / 0.1141 / 0.1080 of full scale (buddha, cat, owl, horse, rock; 2026-12-07).
        // Measured again with itself taken off, every correction here was upwards and, had it
        // been followed, climbed towards the largest level (cat 0.219, horse 0.247): the
        // refinement only lowers a level (`lambertian::measure_black_level`)
        let level = (out.figures.iter())
            .find(|r| r.name == "black level")
            .and_then(|r| r.value.split(' ').next()?.parse::<f32>().ok())
            .expect("a black level row");
        assert!(level < 0.12, "{name}: black level {level}");
        assert!(p95 < p95_plain, "{name}: the outline did not calm down");
        if std::env::var_os("PHOTOSTEREO_DOCS").is_some() {
            let img = side_view(&out.mesh, 90.0, (400, 400));
            img.save(docs.join(format!("side-{name}.png")))
                .expect("write docs picture");
        }
        if let Some(dir) = std::env::var_os("PHOTOSTEREO_SIDE_DEBUG") {
            let dir = Path::new(&dir);
            let pm = photostereo::mesh::from_depth(&plain.depth, mask, Some(&out.normals), None)
                .expect("mesh");
            for (tag, m) in [("plain", &pm), ("trust", &out.mesh)] {
                for deg in [90.0, 60.0] {
                    side_view(m, deg, (400, 400))
                        .save(dir.join(format!("{name}-{tag}-{deg}.png")))
                        .expect("write");
                }
            }
        }
    }
}
