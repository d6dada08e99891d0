//! Placing disconnected parts of the mask ([`Parts`]) on scenes with closed-form truth.
//!
//! * A goblet-like body of revolution (axis vertical, parallel to the image plane): a
//!   sphere (cup, radius 45 mm), a thin cylinder (stem, radius 5 mm) and a flat spheroid
//!   (foot, 28 × 5 mm), 1.5 m from a pinhole camera of focal length 1900 px (DiLiGenT's
//!   geometry at half resolution, 0.79 mm per pixel). The stem is cut out of the mask, so
//!   cup and foot are separate parts, as on DiLiGenT's goblet.
//! * The same goblet with its axis tilted 25° toward the camera (the contours are no
//!   longer at one depth: a limit of the contour rule).
//! * Two spheres side by side at distances 100 mm apart (parts at genuinely different
//!   depths: no rule can know it, the contour rule puts them at one depth).
//!
//! Scored as DiLiGenT is (Cao et al., ECCV 2022): perspective, the estimate scaled by the
//! median of true / estimated distance, then the mean absolute depth error (MADE, mm);
//! orthographic (the same scenes seen along parallel rays, depth in pixels, larger =
//! closer), the estimate shifted by the median difference, then MADE in mm.

mod common;
use common::Rng;
use photostereo::integrate::{solve, Camera, Method, Options, Parts};
use photostereo::{Image, Mask, NormalMap};

const W: usize = 160;
const H: usize = 220;
const F: f64 = 1900.0;
/// Millimetres per pixel of the orthographic views (the pinhole's at the goblet).
const MM: f64 = 1500.0 / F;

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// A ray o + t·d (intrinsics frame: x right, y down, z away from the camera; d_z = 1 so
/// that t is the distance along the optical axis).
#[derive(Clone, Copy)]
struct Ray {
    o: [f64; 3],
    d: [f64; 3],
}

/// Smallest root t > 0 of the quadric |S (o + t d − c)|² = 1 with S = diag(s), and the
/// point's unscaled normal S² (p − c).
fn quadric(ray: Ray, c: [f64; 3], s: [f64; 3]) -> Option<(f64, [f64; 3])> {
    let o = sub(ray.o, c);
    let so = [o[0] * s[0], o[1] * s[1], o[2] * s[2]];
    let sd = [ray.d[0] * s[0], ray.d[1] * s[1], ray.d[2] * s[2]];
    let (a, b, cc) = (dot(sd, sd), 2.0 * dot(so, sd), dot(so, so) - 1.0);
    let disc = b * b - 4.0 * a * cc;
    if disc <= 0.0 || a == 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / (2.0 * a);
    (t > 0.0).then(|| {
        let p = [
            o[0] + t * ray.d[0],
            o[1] + t * ray.d[1],
            o[2] + t * ray.d[2],
        ];
        (
            t,
            [p[0] * s[0] * s[0], p[1] * s[1] * s[1], p[2] * s[2] * s[2]],
        )
    })
}

/// What a pixel sees: distance along the axis, unit normal (crate frame), part id
/// (0 none / stem, 1.. the parts in the mask).
type Hit = Option<(f64, [f64; 3], u8)>;

/// The goblet, axis through `base` tilted by `tilt` (radians, top toward the camera),
/// in a frame where the axis is y: cup centre at −45 mm, foot centre at +45 mm.
fn goblet(ray: Ray, base: [f64; 3], tilt: f64) -> Hit {
    // Rotate the ray into the goblet's frame (rotation about x by −tilt).
    let (sn, cs) = tilt.sin_cos();
    let rot = |v: [f64; 3]| [v[0], cs * v[1] + sn * v[2], -sn * v[1] + cs * v[2]];
    let unrot = |v: [f64; 3]| [v[0], cs * v[1] - sn * v[2], sn * v[1] + cs * v[2]];
    let local = Ray {
        o: rot(sub(ray.o, base)),
        d: rot(ray.d),
    };
    let mut best: Hit = None;
    let mut take = |hit: Option<(f64, [f64; 3])>, id: u8| {
        if let Some((t, n)) = hit {
            if best.is_none_or(|b| t < b.0) {
                best = Some((t, n, id));
            }
        }
    };
    take(quadric(local, [0.0, -45.0, 0.0], [1.0 / 45.0; 3]), 1);
    take(
        quadric(local, [0.0, 45.0, 0.0], [1.0 / 28.0, 1.0 / 5.0, 1.0 / 28.0]),
        2,
    );
    // Stem: cylinder x² + z² = 5², between the cup and the foot.
    if let Some((t, n)) = quadric(local, [0.0; 3], [0.2, 0.0, 0.2]) {
        let y = local.o[1] + t * local.d[1];
        if (-5.0..45.0).contains(&y) {
            take(Some((t, n)), 0);
        }
    }
    best.map(|(t, n, id)| (t, unrot(n), id))
}

/// Two spheres side by side, the right one 100 mm farther.
fn spheres(ray: Ray) -> Hit {
    let a = quadric(ray, [-40.0, 0.0, 1450.0], [1.0 / 35.0; 3]).map(|(t, n)| (t, n, 1));
    let b = quadric(ray, [45.0, 0.0, 1550.0], [1.0 / 40.0; 3]).map(|(t, n)| (t, n, 2));
    match (a, b) {
        (Some(a), Some(b)) => Some(if a.0 < b.0 { a } else { b }),
        (a, b) => a.or(b),
    }
}

struct Scene {
    normals: NormalMap,
    mask: Mask,
    /// Orthographic: depth in pixels (larger = closer); perspective: distance in mm.
    truth: Vec<f64>,
    camera: Option<Camera>,
}

fn render(trace: &dyn Fn(Ray) -> Hit, perspective: bool) -> Scene {
    let cam = Camera::centred(F, W, H).unwrap();
    let mut truth = vec![f64::NAN; W * H];
    let mut inside = vec![false; W * H];
    let normals = Image::from_fn(W, H, |r, c| {
        let ray = if perspective {
            Ray {
                o: [0.0; 3],
                d: cam.ray(r, c),
            }
        } else {
            let x = (c as f64 - cam.cx) * MM;
            let y = (r as f64 - cam.cy) * MM;
            Ray {
                o: [x, y, 0.0],
                d: [0.0, 0.0, 1.0],
            }
        };
        match trace(ray) {
            Some((t, n, id)) if id > 0 => {
                let len = dot(n, n).sqrt();
                inside[r * W + c] = true;
                truth[r * W + c] = if perspective { t } else { -t / MM };
                [
                    (n[0] / len) as f32,
                    (-n[1] / len) as f32,
                    (-n[2] / len) as f32,
                ]
            }
            _ => [0.0, 0.0, 1.0],
        }
    });
    Scene {
        normals,
        mask: Mask::from_fn(W, H, |r, c| inside[r * W + c]),
        truth,
        camera: perspective.then_some(cam),
    }
}

/// MADE in mm after the median scale (perspective) or offset (orthographic).
fn made(s: &Scene, est: &[f32]) -> f64 {
    let idx: Vec<usize> = (0..W * H)
        .filter(|&i| s.mask.data[i] && s.truth[i].is_finite())
        .collect();
    let mut r: Vec<f64> = idx
        .iter()
        .map(|&i| match s.camera {
            Some(_) => s.truth[i] / est[i] as f64,
            None => s.truth[i] - est[i] as f64,
        })
        .collect();
    r.sort_by(f64::total_cmp);
    let m = r[r.len() / 2];
    let err = |i: usize| match s.camera {
        Some(_) => (m * est[i] as f64 - s.truth[i]).abs(),
        None => (m + est[i] as f64 - s.truth[i]).abs() * MM,
    };
    idx.iter().map(|&i| err(i)).sum::<f64>() / idx.len() as f64
}

fn score(s: &Scene, method: Method, parts: Parts) -> (f64, usize) {
    let opts = Options {
        method,
        camera: s.camera,
        parts,
        ..Options::default()
    };
    let out = solve(&s.normals, &s.mask, &opts).unwrap();
    (made(s, &out.depth.data), out.components)
}

const RULES: [Parts; 4] = [Parts::Separate, Parts::Median, Parts::Contour, Parts::Gap];

/// MADE (mm) of lsq and bini (rows) under every rule (columns, [`RULES`]).
fn table(name: &str, s: &Scene) -> [[f64; 4]; 2] {
    let mut rows = [[0.0; 4]; 2];
    for (row, method) in rows.iter_mut().zip([Method::Lsq, Method::bini()]) {
        for (k, &rule) in RULES.iter().enumerate() {
            let (e, parts) = score(s, method, rule);
            assert_eq!(parts, 2, "{name}: two parts");
            row[k] = e;
        }
        println!(
            "{name} {} {}: separate {:.3} median {:.3} contour {:.3} gap {:.3} mm",
            if s.camera.is_some() { "persp" } else { "ortho" },
            method.name(),
            row[0],
            row[1],
            row[2],
            row[3]
        );
    }
    rows
}

/// Perturb every normal by Gaussian noise of standard deviation `sigma` per component
/// (renormalised; deterministic).
fn add_noise(s: &mut Scene, sigma: f32) {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut gauss = || rng.gauss();
    for n in &mut s.normals.data {
        let mut v = [
            n[0] + sigma * gauss(),
            n[1] + sigma * gauss(),
            n[2] + sigma * gauss(),
        ];
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.iter_mut().for_each(|x| *x /= len);
        *n = v;
    }
}

const GOBLET: [f64; 3] = [15.0, 5.0, 1500.0];

#[test]
fn goblet_contours_place_cup_and_foot() {
    // Measured (MADE mm; separate / median / contour / gap):
    //   persp lsq  0.818 / 0.870 / 0.220 / 0.203   persp bini 0.816 / 0.887 / 0.224 / 0.236
    //   ortho lsq  0.829 / 0.859 / 0.107 / 0.549   ortho bini 0.781 / 0.789 / 0.267 / 0.333
    // (with the linear extrapolation to the contour instead of the quadratic one:
    // contour 0.099 / 0.060 / 0.274 / 0.113, but 0.356 / 0.339 on the eroded mask below)
    let persp = table("goblet", &render(&|r| goblet(r, GOBLET, 0.0), true));
    let ortho = table("goblet", &render(&|r| goblet(r, GOBLET, 0.0), false));
    let bounds = [[0.5, 0.5], [0.3, 0.6]];
    for (rows, b) in [persp, ortho].iter().zip(bounds) {
        for (row, bound) in rows.iter().zip(b) {
            let [separate, median, contour, gap] = *row;
            assert!(
                separate > 0.6 && median > 0.6,
                "the problem is real: {row:?}"
            );
            assert!(contour < bound, "contour {contour:.3} mm ({row:?})");
            assert!(contour < separate / 2.5 && gap < separate, "{row:?}");
        }
    }
}

#[test]
fn goblet_contours_with_noisy_normals() {
    // Measured (σ = 0.05 per normal component, MADE mm; separate / median / contour /
    // gap): lsq 0.901 / 0.958 / 0.231 / 0.296, bini 0.877 / 0.927 / 0.132 / 0.279.
    let mut s = render(&|r| goblet(r, GOBLET, 0.0), true);
    add_noise(&mut s, 0.05);
    let rows = table("noisy goblet", &s);
    for row in rows {
        assert!(row[2] < 0.6 && row[2] < row[0] / 2.0, "{row:?}");
    }
}

#[test]
fn limits_tilted_axis_and_parts_at_different_depths() {
    // Where the assumptions fail every rule is centimetres off. Measured (MADE mm;
    // separate / median / contour / gap):
    //   tilted persp lsq 8.358 / 8.386 / 5.459 / 8.384   bini 8.352 / 8.386 / 5.444 / 8.204
    //   tilted ortho lsq 8.259 / 8.288 / 5.383 / 8.036   bini 8.214 / 8.242 / 5.393 / 7.368
    //   spheres persp lsq 46.44 / 46.38 / 47.31 / 48.65  bini 46.46 / 46.39 / 47.34 / 50.34
    //   spheres ortho lsq 44.91 / 44.74 / 46.71 / 46.44  bini 44.91 / 44.74 / 46.70 / 46.74
    for perspective in [true, false] {
        let tilted = table(
            "tilted",
            &render(&|r| goblet(r, GOBLET, 25f64.to_radians()), perspective),
        );
        let spheres = table("spheres", &render(&spheres, perspective));
        for row in tilted {
            assert!(row.iter().all(|&e| (3.0..20.0).contains(&e)), "{row:?}");
        }
        for row in spheres {
            assert!(row.iter().all(|&e| (20.0..100.0).contains(&e)), "{row:?}");
        }
    }
}

/// The goblet with its outline one pixel inside the silhouette (`erode`) and a dozen
/// one-pixel specks in the background (no truth: not scored).
fn real_mask(erode: bool, specks: bool) -> Scene {
    let mut s = render(&|r| goblet(r, GOBLET, 0.0), true);
    if erode {
        let inside = |i: usize| s.mask.data[i];
        s.mask = Mask::from_fn(W, H, |r, c| {
            let i = r * W + c;
            (1..H - 1).contains(&r)
                && (1..W - 1).contains(&c)
                && [i, i - 1, i + 1, i - W, i + W].iter().all(|&j| inside(j))
        });
    }
    for k in (0..12).filter(|_| specks) {
        let i = (5 + 17 * k) * W + 3 + (k * 29) % 20;
        assert!(!s.mask.data[i] && !s.mask.data[i + 1] && !s.mask.data[i - 1]);
        s.mask.data[i] = true;
        s.truth[i] = f64::NAN;
    }
    s
}

#[test]
fn goblet_with_specks_and_an_eroded_mask() {
    // DiLiGenT's outlines are like the eroded one: median n_z of the outline pixels 0.29
    // on bear, 0.41 on harvest; here 0.137 as rendered, 0.236 eroded. Measured (MADE mm,
    // contour / separate / gap): specks lsq 0.220 / 0.818 / 0.203, bini 0.224 / 0.816 /
    // 0.236; eroded lsq 0.237 / 0.584 / 0.271, bini 0.191 / 0.586 / 0.244; both: as
    // eroded (the specks are placed after the parts, and gap leaves them out of its tree;
    // before it did, gap gave 0.055 / 0.027 there, by luck of the chain through specks).
    for (erode, specks) in [(false, true), (true, false), (true, true)] {
        let s = real_mask(erode, specks);
        for method in [Method::Lsq, Method::bini()] {
            let (c, parts) = score(&s, method, Parts::Contour);
            let (sep, _) = score(&s, method, Parts::Separate);
            let (gap, _) = score(&s, method, Parts::Gap);
            assert_eq!(parts, if specks { 14 } else { 2 });
            assert!(c < 0.5 && c < sep / 2.0, "contour {c:.3} separate {sep:.3}");
            assert!(gap < 0.6 && gap < sep, "gap {gap:.3} separate {sep:.3}");
            println!(
                "erode {erode} specks {specks} {}: contour {c:.3} separate {sep:.3} gap {gap:.3} mm",
                method.name()
            );
        }
    }
}
