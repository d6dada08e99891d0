//! Bilateral normal integration on a scene with closed-form depth and normals: a
//! sphere standing in front of a tilted plane, seen through a pinhole. The sphere's
//! occluding contour is a depth discontinuity; the plane and the sphere are each smooth.
//! (With a cap cut at 53° instead of the occluding contour, BiNI finds almost none of
//! the rim — 3 of 258 edges, piece errors 2.4% / 1.1% — and the paper's own
//! implementation, run side by side on that scene, gives the same 2.5% / 1.3%.)
//!
//! Normals from depth alone cannot tell how far the cap stands in front of the plane
//! (the jump's height), so each smooth piece is scored on its own, after its own median
//! scale (the perspective analogue of the per-part offset): relative mean absolute
//! depth error over the pixels more than 2 px from the rim.

use photostereo::integrate::{solve, Camera, Method, Options, Output};
use photostereo::mesh::{from_depth_with, MeshOptions};
use photostereo::{Image, Mask, NormalMap};

const W: usize = 120;
const H: usize = 100;
const F: f64 = 110.0;

/// Sphere centre (intrinsics frame: x right, y down, z away from the camera), radius.
const C: [f64; 3] = [8.0, -4.0, 300.0];
const R: f64 = 60.0;

struct Scene {
    cam: Camera,
    depth: Vec<f64>,
    normals: NormalMap,
    /// 1 on the cap, 0 on the plane.
    on_cap: Vec<bool>,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The nearest visible surface along pixel (r, c)'s ray: (t, normal in the intrinsics
/// frame, on the cap).
fn trace(cam: &Camera, r: usize, c: usize) -> (f64, [f64; 3], bool) {
    let d = cam.ray(r, c);
    // Plane n·X = k with n = (0.25, −0.15, −1)/|·| facing the camera, through (0, 0, 420).
    let len = (0.25f64 * 0.25 + 0.15 * 0.15 + 1.0).sqrt();
    let n = [0.25 / len, -0.15 / len, -1.0 / len];
    let k = dot(n, [0.0, 0.0, 420.0]);
    let t_plane = k / dot(n, d);
    // Sphere |t d − C|² = R², nearest root.
    let (a, b) = (dot(d, d), -2.0 * dot(d, C));
    let cc = dot(C, C) - R * R;
    let disc = b * b - 4.0 * a * cc;
    if disc > 0.0 {
        let t = (-b - disc.sqrt()) / (2.0 * a);
        if t > 0.0 && t < t_plane {
            let p = [t * d[0], t * d[1], t * d[2]];
            let nn = [(p[0] - C[0]) / R, (p[1] - C[1]) / R, (p[2] - C[2]) / R];
            return (t, nn, true);
        }
    }
    (t_plane, n, false)
}

fn scene() -> Scene {
    let cam = Camera::centred(F, W, H).unwrap();
    let mut depth = vec![0.0; W * H];
    let mut on_cap = vec![false; W * H];
    let normals = Image::from_fn(W, H, |r, c| {
        let (t, n, cap) = trace(&cam, r, c);
        depth[r * W + c] = t;
        on_cap[r * W + c] = cap;
        // Intrinsics frame → crate frame (x right, y up, z toward the camera).
        [n[0] as f32, -n[1] as f32, -n[2] as f32]
    });
    Scene {
        cam,
        depth,
        normals,
        on_cap,
    }
}

/// Whether pixel i is within `d` pixels (Chebyshev) of the rim.
fn near_rim(s: &Scene, i: usize, d: usize) -> bool {
    let (r, c) = ((i / W) as isize, (i % W) as isize);
    let d = d as isize;
    (-d..=d).any(|dr| {
        (-d..=d).any(|dc| {
            let (rr, cc) = (r + dr, c + dc);
            rr >= 0
                && cc >= 0
                && (rr as usize) < H
                && (cc as usize) < W
                && s.on_cap[rr as usize * W + cc as usize] != s.on_cap[i]
        })
    })
}

/// Relative mean absolute depth error of one piece after its own median scale.
fn piece_error(s: &Scene, out: &Output, cap: bool) -> f64 {
    let px: Vec<usize> = (0..W * H)
        .filter(|&i| s.on_cap[i] == cap && !near_rim(s, i, 2))
        .collect();
    let mut ratio: Vec<f64> = px
        .iter()
        .map(|&i| s.depth[i] / out.depth.data[i] as f64)
        .collect();
    ratio.sort_by(f64::total_cmp);
    let k = ratio[ratio.len() / 2];
    let mean = px.iter().map(|&i| s.depth[i]).sum::<f64>() / px.len() as f64;
    px.iter()
        .map(|&i| (k * out.depth.data[i] as f64 - s.depth[i]).abs())
        .sum::<f64>()
        / px.len() as f64
        / mean
}

fn integrate(s: &Scene, method: Method) -> Output {
    let opts = Options {
        method,
        camera: Some(s.cam),
        ..Options::default()
    };
    solve(&s.normals, &Mask::full(W, H), &opts).unwrap()
}

#[test]
fn bini_gets_sphere_and_plane_right_lsq_smears_the_jump() {
    let s = scene();
    let cap_px = s.on_cap.iter().filter(|&&b| b).count();
    assert!(cap_px > 1200 && cap_px < W * H / 2, "sphere {cap_px} px");
    let bini = integrate(&s, Method::bini());
    let lsq = integrate(&s, Method::Lsq);
    let (bp, bc) = (piece_error(&s, &bini, false), piece_error(&s, &bini, true));
    let (lp, lc) = (piece_error(&s, &lsq, false), piece_error(&s, &lsq, true));
    println!(
        "plane / cap relative MAE: bini {:.5} / {:.5}, lsq {:.5} / {:.5}; bini {} iterations",
        bp, bc, lp, lc, bini.info.iterations
    );
    // Measured: bini 0.00112 / 0.00121 (0.00103 / 0.00115 before perspective slopes were
    // limited to 10), lsq 0.0115 / 0.0097 (the paper's implementation
    // on this scene: 0.0011 / 0.0041).
    assert!(bp < 3e-3 && bc < 3e-3, "bini {bp} {bc}");
    assert!(lp > 5.0 * bp && lc > 4.0 * bc, "lsq {lp} {lc}");
    // The cut edges lie on the rim: every cut edge joins cap and plane (within 1 px),
    // and most rim edges are cut.
    let disc = bini.discontinuities.as_ref().unwrap();
    let rim_edges: Vec<(usize, usize)> = (0..W * H)
        .flat_map(|i| [(i, i + 1), (i, i + W)])
        .filter(|&(i, j)| j < W * H && (j != i + 1 || i % W + 1 < W) && s.on_cap[i] != s.on_cap[j])
        .collect();
    let cut_on_rim = rim_edges
        .iter()
        .filter(|&&(i, j)| {
            if j == i + 1 {
                disc.east[i]
            } else {
                disc.south[i]
            }
        })
        .count();
    let stray = (0..W * H)
        .filter(|&i| (disc.east[i] || disc.south[i]) && !near_rim(&s, i, 1))
        .count();
    println!(
        "rim edges {}, cut {cut_on_rim}, stray cuts {stray}",
        rim_edges.len()
    );
    // Measured: 12 of the 180 rim edges flagged, 11 flags more than 1 px from the rim:
    // the pieces come out right (above) but the reported discontinuity map is coarse.
    assert!(cut_on_rim >= 6, "{cut_on_rim} of {}", rim_edges.len());
    assert!(stray <= 30, "{stray} stray cuts");
    let mask = Mask::full(W, H);
    let mesh_opts = MeshOptions {
        camera: bini.camera.as_ref(),
        cuts: Some(disc),
        ..Default::default()
    };
    let mesh = from_depth_with(&bini.depth, &mask, Some(&s.normals), None, &mesh_opts).unwrap();
    // Back-projection: vertices are the true points up to the plane's scale.
    let i = (H / 2 + 30) * W + 10; // a plane pixel
    assert!(!s.on_cap[i]);
    let (r, c) = (i / W, i % W);
    let v = mesh.vertices[i];
    let t = bini.depth.data[i] as f64;
    let truth = s.cam.back_project(r, c, t);
    assert!((v[0] as f64 - truth[0]).abs() < 1e-3 * t && (v[2] as f64 + t).abs() < 1e-3 * t);
}
