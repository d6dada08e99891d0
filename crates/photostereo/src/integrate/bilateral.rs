//! Bilateral normal integration (BiNI): depth with discontinuities, orthographic or
//! perspective.
//!
//! X. Cao, H. Santo, B. Shi, F. Okura, Y. Matsushita, "Bilateral Normal Integration",
//! ECCV 2022.
//!
//! # Equations
//!
//! Every mask pixel i has a target gradient per column step g_h and per row step g_v of
//! the unknown v, and a scale a_h, a_v (the "n_z" of the paper's equations):
//!
//! * orthographic: v = z (pixel units, larger = closer), g_h = p = −n_x/n_z,
//!   g_v = −q = n_y/n_z, a_h = a_v = n_z;
//! * perspective ([`Camera`]): v = f_x · ln t with t the distance along the optical
//!   axis. With n' the normal in the intrinsics frame and d the pixel's ray
//!   (see [`super::camera`]), ñ_c = f_x (n'·d), ñ_r = f_y (n'·d), and tangency of the
//!   surface point t·d gives ∂(ln t)/∂c = −n'_x/ñ_c, ∂(ln t)/∂r = −n'_y/ñ_r; so
//!   g_h = −f_x n'_x/ñ_c, g_v = −f_x n'_y/ñ_r, a_h = ñ_c/f_x, a_v = ñ_r/f_x.
//!
//! Each pixel writes one-sided equations to its four neighbours (where they are in the
//! mask), e.g. a_h (v_right − v_i − g_h) = 0 and a_h (v_i − v_left − g_h) = 0, and
//! minimises
//!
//! E(v) = Σ_i c_i [ w_i a_h² (v_right − v_i − g_h)² + (1 − w_i) a_h² (v_i − v_left − g_h)²
//!               + u_i a_v² (v_down − v_i − g_v)² + (1 − u_i) a_v² (v_i − v_up − g_v)² ]
//!
//! with c_i the optional per-pixel confidence (with a confidence map, plus the membrane
//! prior ε (1 − max(c_i, c_j)) (v_j − v_i)² of module `trust` on every edge, so that a
//! region of untrusted pixels is filled smoothly; with min instead of max the rim of the
//! hemisphere of `tests/integrate_trust.rs` flattens, error 0.641 px instead of 0.284). The bilateral weights come from the
//! sigmoid σ_k(x) = 1/(1 + e^(−kx)) of the squared one-sided differences,
//! w_i = σ_k((a_h(v_i − v_left))² − (a_h(v_right − v_i))²) and likewise u_i: where the
//! depth jumps on one side, that side's equation is switched off and the surface is
//! free to break there. Iteratively reweighted least squares: start from w = u = 1/2
//! (which is plain least squares), solve for v with the weights fixed (a weighted graph
//! Laplacian, [`super::multigrid`], warm-started from the previous v, to a relative
//! residual of 1e-3 as in the paper's implementation), update the weights, stop when
//! |E_new − E_old| / E_old < `tol` or after `max_iter` iterations (a solve whose warm
//! start already meets its tolerance leaves v and the weights as they are, E_new = E_old:
//! a fixed point, so the iteration stops).
//! Weights are kept in [1e-6, 1 − 1e-6] so that no part of the grid is ever cut loose
//! numerically. A missing neighbour counts as a zero difference in the weights, as in
//! the paper's implementation.
//!
//! An edge (i, j) is reported as a discontinuity (and the mesh leaves it out) when the
//! solved step disagrees with the gradients of both ends by more than [`CUT`] (in the
//! scaled units of the equations, about pixels): |a_i (v_j − v_i − g_i)| > CUT and
//! |a_j (v_j − v_i − g_j)| > CUT, both ends with a confidence of at least [`TRUSTED`]
//! (when there is a confidence map).

use super::camera::Camera;
use super::lsq::{Assembled, PRIOR};
use super::support::Components;
use super::window::Window;
use crate::error::Result;
use crate::image::{Mask, NormalMap};
use crate::progress::Progress;

/// Scaled step residual (about pixels) above which an edge counts as a discontinuity.
pub const CUT: f64 = 1.0;
/// Relative residual of the inner solves while reweighting (warm-started), and of a
/// single solve (perspective [`super::Method::Lsq`], where a loose solve would leave
/// smooth errors). BiNI's energy is not convex and the reweighting follows the path of
/// its solves: on DiLiGenT's true normals (`tests/integrate_diligent.rs`, MADE after the
/// median scale) 1e-3 gives bear 0.426 mm and harvest 1.69 mm (1.69–1.87 with the
/// principal point moved by half a pixel), against 0.454 / 2.71 (2.71–2.73) at 1e-4,
/// 2.63 at 3e-4, 1.79–1.87 at 3e-3 and 3.52 at 1e-2 (harvest); it also needs a quarter
/// of the CG iterations of 1e-4 (harvest 760 against 3091). The paper's implementation
/// stops its Jacobi-preconditioned CG at a relative residual of 1e-3 too.
const INNER_TOL: (f64, f64) = (1e-3, 1e-6);
/// Confidence from which a pixel's gradient can mark a discontinuity (with a map).
pub(crate) const TRUSTED: f64 = 0.5;
/// Smallest bilateral weight.
const WEIGHT_FLOOR: f64 = 1e-6;
/// Smallest |n'·d| of the perspective equations, whatever the smaller
/// [`super::Options::min_nz`]: slopes are limited to 10 (84°). Near an outline a pixel's
/// normal says little about the depth step to its neighbour (the surface turns within
/// the pixel), and the steepest slopes set the size of depth jumps that the solution
/// integrates. Measured on DiLiGenT's true normals (BiNI, MADE in mm, bear / harvest):
/// no clamp 0.464 / 3.19 (harvest at inner tolerance 1e-4, where 0.05 gives 2.71),
/// 0.05: 0.426 / 1.69 (1.69–1.87 with
/// the principal point moved by half a pixel), 0.08: 0.352 / –, 0.1: 0.309 / 1.69
/// (1.68–1.70), 0.12: 0.204 / –, 0.15: 0.067 / 2.03, 0.2: 0.66 / 3.23. Bear's error is
/// the offset of its head from its body, which this bound moves; 0.1 is the value that
/// improves bear without costing harvest; it was chosen on these two objects.
pub(crate) const PERSPECTIVE_MIN_NZ: f32 = 0.1;

/// Per-pixel targets and scales (0 outside the mask); see the module documentation.
#[derive(Clone, Debug)]
pub(crate) struct Field {
    pub g_h: Vec<f64>,
    pub g_v: Vec<f64>,
    pub a_h: Vec<f64>,
    pub a_v: Vec<f64>,
}

impl Field {
    fn zeros(n: usize) -> Self {
        Field {
            g_h: vec![0.0; n],
            g_v: vec![0.0; n],
            a_h: vec![0.0; n],
            a_v: vec![0.0; n],
        }
    }

    /// Orthographic field from gradients p, q (0 outside the mask, already clean).
    pub fn orthographic(p: &[f32], q: &[f32], mask: &Mask) -> Self {
        let mut f = Field::zeros(mask.len());
        for i in (0..mask.len()).filter(|&i| mask.data[i]) {
            let (pi, qi) = (p[i] as f64, q[i] as f64);
            let nz = 1.0 / (1.0 + pi * pi + qi * qi).sqrt();
            f.g_h[i] = pi;
            f.g_v[i] = -qi;
            f.a_h[i] = nz;
            f.a_v[i] = nz;
        }
        f
    }

    /// Perspective field from normals; returns the field and the clamped count (n'·d
    /// above −max(`min_nz`, [`PERSPECTIVE_MIN_NZ`]), or a NaN component).
    pub fn perspective(
        normals: &NormalMap,
        mask: &Mask,
        cam: &Camera,
        min_nz: f32,
    ) -> (Self, usize) {
        let min_nz = min_nz.max(PERSPECTIVE_MIN_NZ);
        let w = mask.width;
        let mut f = Field::zeros(mask.len());
        let mut clamped = 0;
        for i in (0..mask.len()).filter(|&i| mask.data[i]) {
            let n = normals.data[i];
            if n.iter().any(|v| !v.is_finite()) {
                clamped += 1;
                f.a_h[i] = min_nz as f64;
                f.a_v[i] = min_nz as f64;
                continue;
            }
            let len = ((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) as f64)
                .sqrt()
                .max(1e-12);
            let np = [n[0] as f64 / len, -n[1] as f64 / len, -n[2] as f64 / len];
            let d = cam.ray(i / w, i % w);
            let mut nd = np[0] * d[0] + np[1] * d[1] + np[2] * d[2];
            if nd > -(min_nz as f64) {
                clamped += 1;
                nd = -(min_nz as f64).max(1e-6);
            }
            f.g_h[i] = -np[0] / nd;
            f.g_v[i] = -cam.fx * np[1] / (cam.fy * nd);
            f.a_h[i] = nd;
            f.a_v[i] = cam.fy / cam.fx * nd;
        }
        (f, clamped)
    }
}

/// Parameters of the iteration.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Params {
    pub k: f64,
    pub max_iter: usize,
    pub tol: f64,
    /// Add the membrane prior of module `trust` (with a weight map): an edge between
    /// two untrusted pixels is filled smoothly.
    pub prior: bool,
}

/// Result of [`integrate`].
#[derive(Clone, Debug)]
pub(crate) struct Solution {
    /// v on the whole grid (0 outside the mask).
    pub v: Vec<f64>,
    /// IRLS iterations.
    pub iterations: usize,
    /// Conjugate-gradient iterations, all inner solves together.
    pub cg_iterations: usize,
    /// Final relative energy change.
    pub relative_energy: f64,
    /// Cut flags of the edges to the right and down.
    pub cut_east: Vec<bool>,
    pub cut_south: Vec<bool>,
}

/// The neighbour flags of pixel i: right, left, down, up inside the mask.
#[inline]
fn neighbours(mask: &Mask, i: usize) -> [bool; 4] {
    let (w, h) = (mask.width, mask.height);
    let (r, c) = (i / w, i % w);
    [
        c + 1 < w && mask.data[i + 1],
        c > 0 && mask.data[i - 1],
        r + 1 < h && mask.data[i + w],
        r > 0 && mask.data[i - w],
    ]
}

fn sigmoid(x: f64, k: f64) -> f64 {
    (1.0 / (1.0 + (-k * x).exp())).clamp(WEIGHT_FLOOR, 1.0 - WEIGHT_FLOOR)
}

/// Assemble the normal equations for fixed weights (`wr`: right, `wd`: down).
fn assemble(
    f: &Field,
    conf: &[f64],
    mask: &Mask,
    (wr, wd): (&[f64], &[f64]),
    prior: bool,
) -> Assembled {
    let w = mask.width;
    let mut sys = Assembled::new(w, mask.height);
    // Membrane prior on edges whose two ends are both untrusted.
    let membrane = |i: usize, j: usize| PRIOR * (1.0 - conf[i].max(conf[j])).max(0.0);
    for i in (0..mask.len()).filter(|&i| mask.data[i]) {
        let [right, _, down, _] = neighbours(mask, i);
        if prior && right {
            sys.add_edge(i, true, membrane(i, i + 1), 0.0);
        }
        if prior && down {
            sys.add_edge(i, false, membrane(i, i + w), 0.0);
        }
        if right {
            let j = i + 1;
            sys.add_edge(i, true, conf[i] * wr[i] * f.a_h[i] * f.a_h[i], f.g_h[i]);
            sys.add_edge(
                i,
                true,
                conf[j] * (1.0 - wr[j]) * f.a_h[j] * f.a_h[j],
                f.g_h[j],
            );
        }
        if down {
            let j = i + w;
            sys.add_edge(i, false, conf[i] * wd[i] * f.a_v[i] * f.a_v[i], f.g_v[i]);
            sys.add_edge(
                i,
                false,
                conf[j] * (1.0 - wd[j]) * f.a_v[j] * f.a_v[j],
                f.g_v[j],
            );
        }
    }
    sys
}

/// Update the weights from v and return the energy with the new weights.
fn reweight(
    f: &Field,
    conf: &[f64],
    mask: &Mask,
    v: &[f64],
    k: f64,
    wr: &mut [f64],
    wd: &mut [f64],
) -> f64 {
    let w = mask.width;
    let mut energy = 0.0;
    for i in (0..mask.len()).filter(|&i| mask.data[i]) {
        let [right, left, down, up] = neighbours(mask, i);
        let d = |ok: bool, a: usize, b: usize| if ok { v[a] - v[b] } else { 0.0 };
        let (dr, dl) = (d(right, i + 1, i), d(left, i, i.wrapping_sub(1)));
        let (dd, du) = (d(down, i + w, i), d(up, i, i.wrapping_sub(w)));
        let (ah, av) = (f.a_h[i], f.a_v[i]);
        wr[i] = sigmoid(ah * ah * (dl * dl - dr * dr), k);
        wd[i] = sigmoid(av * av * (du * du - dd * dd), k);
        let sq = |ok: bool, x: f64, g: f64| if ok { (x - g) * (x - g) } else { 0.0 };
        let e =
            ah * ah * (wr[i] * sq(right, dr, f.g_h[i]) + (1.0 - wr[i]) * sq(left, dl, f.g_h[i]))
                + av * av * (wd[i] * sq(down, dd, f.g_v[i]) + (1.0 - wd[i]) * sq(up, du, f.g_v[i]));
        energy += conf[i] * e;
    }
    energy
}

/// Run BiNI on a field; `conf` holds the per-pixel confidences (1 without a map).
/// The iteration runs on the mask's bounding box (module `window`): pixels outside
/// the mask take no part in it, and every sweep costs per cell of the grid.
pub(crate) fn integrate(
    f: &Field,
    conf: &[f64],
    mask: &Mask,
    comps: &Components,
    params: Params,
    progress: &dyn Progress,
) -> Result<Solution> {
    let Some(win) = Window::of(mask) else {
        return integrate_grid(f, conf, mask, comps, params, progress);
    };
    let field = Field {
        g_h: win.take(&f.g_h),
        g_v: win.take(&f.g_v),
        a_h: win.take(&f.a_h),
        a_v: win.take(&f.a_v),
    };
    // Labels keep their numbers: the box holds every pixel of every part, in the same
    // raster order.
    let parts = Components {
        labels: win.take(&comps.labels),
        count: comps.count,
    };
    let (boxed, conf) = (win.mask(mask), win.take(conf));
    let sol = integrate_grid(&field, &conf, &boxed, &parts, params, progress)?;
    Ok(Solution {
        v: win.put(&sol.v, 0.0),
        cut_east: win.put(&sol.cut_east, false),
        cut_south: win.put(&sol.cut_south, false),
        ..sol
    })
}

/// [`integrate`] on the whole grid of `mask`.
fn integrate_grid(
    f: &Field,
    conf: &[f64],
    mask: &Mask,
    comps: &Components,
    params: Params,
    progress: &dyn Progress,
) -> Result<Solution> {
    let n = mask.len();
    let (mut wr, mut wd) = (vec![0.5; n], vec![0.5; n]);
    let mut v = vec![0.0; n];
    let mut energy = f64::INFINITY;
    let mut out = Solution {
        v: Vec::new(),
        iterations: 0,
        cg_iterations: 0,
        relative_energy: f64::NAN,
        cut_east: Vec::new(),
        cut_south: Vec::new(),
    };
    progress.start("bini: reweighted least squares", params.max_iter as u64);
    while out.iterations < params.max_iter.max(1) {
        let mut sys = assemble(f, conf, mask, (&wr, &wd), params.prior);
        sys.pin(comps);
        let tol = if params.max_iter <= 1 {
            INNER_TOL.1
        } else {
            INNER_TOL.0
        };
        out.cg_iterations += sys.solve(&mut v, tol, mask)?;
        out.iterations += 1;
        progress.advance(1);
        let new = reweight(f, conf, mask, &v, params.k, &mut wr, &mut wd);
        out.relative_energy = (new - energy).abs() / energy;
        energy = new;
        if out.relative_energy < params.tol || energy == 0.0 {
            break;
        }
    }
    progress.finish();
    let w = mask.width;
    // A discontinuity: the solved step disagrees with both ends' own gradients.
    // Only between trusted pixels (with a confidence map): an untrusted pixel's own
    // gradient says nothing about a jump.
    let trusted = |i: usize| !params.prior || conf[i] >= TRUSTED;
    let off = |i: usize, j: usize, g: &[f64], a: &[f64]| {
        if !(trusted(i) && trusted(j)) {
            return false;
        }
        let dv = v[j] - v[i];
        (a[i] * (dv - g[i])).abs() > CUT && (a[j] * (dv - g[j])).abs() > CUT
    };
    out.cut_east = (0..n)
        .map(|i| mask.data[i] && neighbours(mask, i)[0] && off(i, i + 1, &f.g_h, &f.a_h))
        .collect();
    out.cut_south = (0..n)
        .map(|i| mask.data[i] && neighbours(mask, i)[2] && off(i, i + w, &f.g_v, &f.a_v))
        .collect();
    out.v = v;
    Ok(out)
}
