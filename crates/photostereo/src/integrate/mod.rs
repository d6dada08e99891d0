//! Integration of a normal field into depth.
//!
//! # The problem
//!
//! A normal n = (n_x, n_y, n_z) gives the surface gradient (see the crate conventions)
//! p = ∂z/∂x = −n_x/n_z and q = ∂z/∂y = −n_y/n_z. Because rows grow downward
//! (y up), along the pixel grid
//!
//! * z(r, c+1) − z(r, c) ≈ (p(r, c) + p(r, c+1)) / 2        (horizontal edge),
//! * z(r+1, c) − z(r, c) ≈ −(q(r, c) + q(r+1, c)) / 2       (vertical edge, ∂z/∂row = −q).
//!
//! Each target is the trapezoidal mean of the two end gradients, which makes every
//! solver second-order accurate on smooth surfaces. Measured gradients are noisy and
//! not exactly integrable, so every method except [`Method::Path`] minimises
//!
//! E(z) = Σ over edges e = (i, j) of w_e · (z_j − z_i − g_e)²,
//!
//! over a different set of edges (the boundary assumption):
//!
//! | method | edges | boundary | cost |
//! |---|---|---|---|
//! | [`Method::Path`] | two spanning trees | none | O(N) |
//! | [`Method::FrankotChellappa`] | whole grid, wrapping around | periodic | 2 FFTs |
//! | FC with `reflect` | mirrored grid (2W × 2H) | mirror = Neumann | 2 FFTs of 4N |
//! | [`Method::Dct`] | whole rectangle | Neumann (free edge) | 2 DCTs |
//! | [`Method::Lsq`] | only between mask pixels | free edge of the mask | multigrid CG, O(N) |
//! | [`Method::Bilateral`] | one-sided, between mask pixels | free edge, breaks at jumps | reweighted multigrid CG |
//!
//! The normal equations of E are a graph Laplacian system L z = div g.
//!
//! # Offsets
//!
//! Depth from gradients is known up to one constant per connected part of the mask
//! (4-connectivity; with a camera, one scale of the distance per part). The relative
//! heights of separate parts cannot be measured from normals: [`Options::parts`] says
//! which assumption places them ([`Parts`], module `parts`; default: their occluding
//! contours at a common depth, right for bodies of revolution about an axis parallel
//! to the image plane such as a goblet's cup and foot). The depth then has mean 0 over
//! the whole mask; with [`Parts::Separate`] (the behaviour before the option) every
//! part has mean 0 on its own. A mask of one part is not affected. Outside the mask the
//! depth is NaN.
//!
//! # Bad normals
//!
//! Inside the mask, normals with n_z ≤ [`Options::min_nz`] (including the zero vector
//! that marks "unknown") or with a NaN component are clamped and counted in
//! [`Output::clamped`]: NaN gives a flat gradient (0, 0); a finite normal gets
//! n_z := `min_nz`, i.e. its slope is limited to 1/`min_nz`. No NaN ever reaches the
//! depth inside the mask.
//!
//! # References
//!
//! * R. T. Frankot, R. Chellappa, "A method for enforcing integrability in shape from
//!   shading algorithms", IEEE PAMI 10(4), 1988.
//! * T. Simchony, R. Chellappa, M. Shao, "Direct analytical methods for solving Poisson
//!   equations in computer vision problems", IEEE PAMI 12(5), 1990.
//! * Y. Quéau, J.-D. Durou, J.-F. Aujol, "Normal integration: a survey", JMIV 60, 2018.

mod bilateral;
mod camera;
mod dct;
mod fft2;
mod fourier;
mod lsq;
mod multigrid;
mod pages;
mod parts;
pub mod path;
mod spectrum;
mod support;
mod trust;
mod window;

use crate::error::{Error, Result};
use crate::image::{DepthMap, GrayImage, Mask, NormalMap};
use crate::progress::{NoProgress, Progress};
use std::borrow::Cow;

pub use camera::Camera;
pub use fft2::fft_floor;
pub use parts::Parts;
pub use support::{gradients, label_components, Components};
pub use trust::{trust_weights, TrustOptions};

/// How to turn gradients into depth. Each variant states its equation and its
/// boundary assumption; see the module documentation for the common notation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Path integration: cumulative trapezoidal sums from a reference pixel (the mask
    /// pixel nearest the image centre), once along its row then down/up every column,
    /// once along its column then along every row; the result is the average of the
    /// two, and [`Output::path_disagreement`] is their RMS difference over the mask.
    /// No boundary assumption, but noise accumulates along the path (random walk) and
    /// the result depends on the path. Pixels outside the mask count as flat.
    Path,
    /// Frankot–Chellappa: least squares over the whole grid in the Fourier domain,
    /// Z(ω_c, ω_r) = (−iω_c·P + iω_r·Q) / (ω_c² + ω_r²) with Z(0,0) := 0 (our signs:
    /// ∂/∂col ↔ iω_c acts on p, ∂/∂row ↔ iω_r acts on −q). Implemented with the
    /// finite-difference symbols of the pixel grid (divergence of the trapezoidal edge
    /// gradients, eigenvalues 2cos ω_c + 2cos ω_r − 4 of the periodic Laplacian), which is
    /// the exact least-squares solution on the periodic grid and tends to the formula
    /// above for small ω. **Boundary: periodic** — the grid wraps around, so a surface
    /// whose gradient differs between opposite edges gets a boundary error. With
    /// `reflect: true` the gradient field is mirrored to 2W × 2H first (across a
    /// vertical edge p changes sign, q does not; across a horizontal edge the reverse),
    /// which makes it periodic and equals the Neumann solution of [`Method::Dct`] at four
    /// times the cost. Pixels outside the mask count as flat.
    FrankotChellappa {
        /// Mirror the gradient field before the FFT (removes the periodic-boundary bias).
        reflect: bool,
    },
    /// DCT Poisson solver (Simchony et al. 1990): Δz = ∂p/∂x + ∂q/∂y discretised as the
    /// Neumann graph Laplacian of the full rectangle, diagonalised by the 2-D DCT-II with
    /// eigenvalues 2cos(πk/W) + 2cos(πl/H) − 4. **Boundary: Neumann** (no edge crosses
    /// the image border), so no periodicity artefacts on a rectangle. Pixels outside the
    /// mask count as flat, which is wrong for objects on a background: use `Lsq` there.
    Dct,
    /// Masked least squares: E(z) over the edges whose two ends are both inside the
    /// mask, with optional per-pixel weights (edge weight = the smaller of its two
    /// pixels' weights, plus a membrane prior that fills untrusted regions smoothly:
    /// [`trust_weights`]). The normal equations L z = b (a weighted graph Laplacian) are
    /// solved by conjugate gradients with a multigrid preconditioner (relative residual
    /// 1e-5, 1e-6 with a camera; sparse Cholesky as a fallback should CG not converge),
    /// with one pixel per connected part pinned to 0 (then each part is shifted to mean
    /// 0). **Boundary: the mask's own edge**; holes and several parts are handled
    /// exactly. With a camera it solves the perspective equations of
    /// [`Method::Bilateral`] with all bilateral weights 1/2.
    Lsq,
    /// Bilateral normal integration (Cao et al., ECCV 2022): one-sided differences to the
    /// four neighbours, each weighted by a sigmoid of the squared difference of the two
    /// sides, by iteratively reweighted least squares; depth discontinuities come out as
    /// jumps (reported in [`Output::discontinuities`]). Orthographic, or perspective with
    /// [`Options::camera`]. Equations: module `bilateral` (see [`Method::bini`]).
    Bilateral {
        /// Sharpness of the sigmoid (unitless, default 2; larger breaks more easily).
        k: f32,
        /// Most reweighting iterations (default 150).
        max_iter: u32,
        /// Stop when the relative energy change falls below this (default 1e-4).
        tol: f32,
    },
}

impl Method {
    /// Short name used on the command line (`path`, `fc`, `fc-reflect`, `dct`, `lsq`).
    pub fn name(&self) -> &'static str {
        match self {
            Method::Path => "path",
            Method::FrankotChellappa { reflect: false } => "fc",
            Method::FrankotChellappa { reflect: true } => "fc-reflect",
            Method::Dct => "dct",
            Method::Lsq => "lsq",
            Method::Bilateral { .. } => "bini",
        }
    }

    /// [`Method::Bilateral`] with the paper's defaults: k = 2, 150 iterations, tol 1e-4.
    pub fn bini() -> Self {
        Method::Bilateral {
            k: 2.0,
            max_iter: 150,
            tol: 1e-4,
        }
    }

    /// Parse a name produced by [`Method::name`].
    pub fn from_name(name: &str) -> Result<Self> {
        Ok(match name {
            "path" => Method::Path,
            "fc" => Method::FrankotChellappa { reflect: false },
            "fc-reflect" => Method::FrankotChellappa { reflect: true },
            "dct" => Method::Dct,
            "lsq" => Method::Lsq,
            "bini" => Method::bini(),
            other => {
                return Err(Error::invalid(
                    format!("integration method `{other}`"),
                    "use one of path, fc, fc-reflect, dct, lsq, bini",
                ))
            }
        })
    }
}

/// Options of [`solve`] and [`integrate_gradients`].
#[derive(Clone, Debug)]
pub struct Options {
    /// The integrator (default [`Method::Lsq`]; [`choose_method`] picks one from the mask).
    pub method: Method,
    /// Per-pixel confidence (≥ 0, same size as the mask) weighting the least-squares
    /// edges; only [`Method::Lsq`] and [`Method::Bilateral`] use it (an error otherwise).
    /// NaN or negative values count as 0; weights are scaled to a maximum of 1 and
    /// floored at 1e-4. With weights, an edge of trust t also gets the membrane prior
    /// 0.1 (1 − t) Δz², so that untrusted pixels are filled smoothly from their
    /// neighbours instead of integrating noise ([`trust_weights`] makes such a map).
    pub weights: Option<GrayImage>,
    /// Smallest accepted n_z (unitless, default 0.05, i.e. slopes up to 20 pixel/pixel,
    /// 87°); normals below it are clamped and counted. With a [`Options::camera`] the
    /// bound is at least 0.1 (slopes up to 10, 84°; measured on DiLiGenT, module
    /// `bilateral`).
    pub min_nz: f32,
    /// Pinhole camera: integrate in perspective (only [`Method::Lsq`] and
    /// [`Method::Bilateral`], from normals). The depth is then the distance along the
    /// optical axis (see [`Output::depth`]). `None` (default): orthographic.
    pub camera: Option<Camera>,
    /// How separate parts of the mask are placed relative to each other (default
    /// [`Parts::Contour`]: their occluding contours at a common depth; module `parts`).
    pub parts: Parts,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            method: Method::Lsq,
            weights: None,
            min_nz: 0.05,
            camera: None,
            parts: Parts::default(),
        }
    }
}

/// Edges across which the surface breaks (found by [`Method::Bilateral`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Discontinuities {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Per pixel (row-major): the edge to its right neighbour is cut.
    pub east: Vec<bool>,
    /// Per pixel: the edge to the pixel below is cut.
    pub south: Vec<bool>,
}

impl Discontinuities {
    /// Number of cut edges.
    pub fn count(&self) -> usize {
        self.east.iter().chain(&self.south).filter(|&&b| b).count()
    }
}

/// Solver diagnostics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolverInfo {
    /// Iterations: conjugate-gradient iterations of [`Method::Lsq`] (0 after the Cholesky
    /// fallback), reweighting iterations of [`Method::Bilateral`], 0 for direct methods.
    pub iterations: usize,
    /// Conjugate-gradient iterations of all inner solves of [`Method::Bilateral`].
    pub inner_iterations: usize,
    /// RMS over the in-mask edges of z_j − z_i − g_e (depth units per pixel step): how
    /// far the gradients are from being integrable plus the method's own error.
    pub residual: f32,
}

/// Result of an integration.
#[derive(Clone, Debug)]
pub struct Output {
    /// Orthographic: depth in pixel units (larger = closer), mean 0 over the mask (over
    /// each connected part with [`Parts::Separate`]). With a camera: the distance along
    /// the optical axis (positive, larger = farther), known up to scale, scaled so that
    /// its geometric mean over the mask (each part's, with [`Parts::Separate`]) is f_x
    /// (then the mesh's lateral units are about pixels). Separate parts are placed by
    /// [`Options::parts`]. NaN outside the mask.
    pub depth: DepthMap,
    /// The method that was used.
    pub method: Method,
    /// Normals inside the mask with n_z ≤ `min_nz` or a NaN component, clamped.
    pub clamped: usize,
    /// [`Method::Path`] only: RMS over the mask of the difference between the
    /// row-first and the column-first path (pixel units).
    pub path_disagreement: Option<f32>,
    /// Number of 4-connected parts of the mask (each has its own offset, placed by
    /// [`Options::parts`]).
    pub components: usize,
    /// Solver diagnostics.
    pub info: SolverInfo,
    /// [`Method::Bilateral`] only: the edges where the surface breaks.
    pub discontinuities: Option<Discontinuities>,
    /// The camera of a perspective integration.
    pub camera: Option<Camera>,
}

/// The method to use when the user names none: [`Method::Dct`] when the mask covers
/// the whole rectangle, [`Method::Lsq`] otherwise.
pub fn choose_method(mask: &Mask) -> Method {
    if mask.data.iter().all(|&b| b) {
        Method::Dct
    } else {
        Method::Lsq
    }
}

/// Edges inside the mask across which an orthographic depth map jumps: the step
/// z_j − z_i disagrees with the gradients of both ends by more than
/// `bilateral::CUT` (1 px) once scaled by their n_z (BiNI's own test for a discontinuity,
/// |n_z (Δz − g)| > 1 px at both ends). Least squares smears a depth jump over a few
/// pixels but leaves such edges along it; on a smooth surface with noisy normals there
/// are almost none. With a `trust` map ([`trust_weights`]) only edges between pixels
/// of trust ≥ 0.5 count. Used to choose [`Method::Bilateral`] ([`choose_method_for`]).
pub fn jump_edges(
    depth: &DepthMap,
    normals: &NormalMap,
    mask: &Mask,
    trust: Option<&GrayImage>,
    min_nz: f32,
) -> usize {
    let (w, h) = (mask.width, mask.height);
    let (p, q, _) = gradients(normals, mask, min_nz);
    let nz = |i: usize| normals.data[i][2].max(min_nz) as f64;
    let trusted = |i: usize| trust.is_none_or(|t| t.data[i] as f64 >= bilateral::TRUSTED);
    let off = |i: usize, j: usize, gi: f64, gj: f64| {
        if !(trusted(i) && trusted(j)) {
            return false;
        }
        let dz = (depth.data[j] - depth.data[i]) as f64;
        (nz(i) * (dz - gi)).abs() > bilateral::CUT && (nz(j) * (dz - gj)).abs() > bilateral::CUT
    };
    let mut count = 0;
    for i in (0..w * h).filter(|&i| mask.data[i]) {
        let (r, c) = (i / w, i % w);
        if c + 1 < w && mask.data[i + 1] && off(i, i + 1, p.data[i] as f64, p.data[i + 1] as f64) {
            count += 1;
        }
        let j = i + w;
        if r + 1 < h && mask.data[j] && off(i, j, -q.data[i] as f64, -q.data[j] as f64) {
            count += 1;
        }
    }
    count
}

/// The integrator for normals on a mask when the user names none, given a first
/// least-squares depth: [`Method::Bilateral`] when that depth has at least
/// [`JUMP_EDGES`] jump edges ([`jump_edges`]), else [`choose_method`]'s choice.
/// Returns the method and the number of jump edges.
pub fn choose_method_for(
    depth: &DepthMap,
    normals: &NormalMap,
    mask: &Mask,
    trust: Option<&GrayImage>,
) -> (Method, usize) {
    let jumps = jump_edges(depth, normals, mask, trust, Options::default().min_nz);
    if jumps >= JUMP_EDGES {
        (Method::bini(), jumps)
    } else {
        (choose_method(mask), jumps)
    }
}

/// Jump edges ([`jump_edges`]) from which [`choose_method_for`] picks BiNI.
pub const JUMP_EDGES: usize = 20;

/// Integrate a normal map inside a mask.
pub fn solve(normals: &NormalMap, mask: &Mask, opts: &Options) -> Result<Output> {
    solve_with_progress(normals, mask, opts, &NoProgress)
}

/// [`solve`] reporting progress (used for the slow [`Method::Lsq`]).
pub fn solve_with_progress(
    normals: &NormalMap,
    mask: &Mask,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Output> {
    mask.check_size(normals.width, normals.height, "integration mask")?;
    if let Some(cam) = opts.camera {
        return perspective(normals, mask, &cam, opts, progress);
    }
    let (p, q, clamped) = gradients(normals, mask, opts.min_nz);
    check_inputs(&p, &q, mask, opts)?;
    // handed over, so that cleaning them needs no second copy, and made again from the
    // normals where the solver frees them
    let full = support::all_set_par(&mask.data);
    let remake = || {
        let (p, q, _) = gradients(normals, mask, opts.min_nz);
        let (p, q, _) = support::sanitize_cow(Cow::Owned(p.data), Cow::Owned(q.data), mask, full);
        (p.into_owned(), q.into_owned())
    };
    let (p, q) = (Cow::Owned(p.data), Cow::Owned(q.data));
    let mut out = integrate_checked(p, q, mask, opts, Some(&remake), progress)?;
    out.clamped = clamped;
    Ok(out)
}

/// BiNI parameters of a method ([`Method::Lsq`]: one solve with all weights 1/2).
fn bini_params(opts: &Options) -> bilateral::Params {
    let prior = opts.weights.is_some();
    match opts.method {
        Method::Bilateral { k, max_iter, tol } => bilateral::Params {
            k: k as f64,
            max_iter: max_iter.max(1) as usize,
            tol: tol as f64,
            prior,
        },
        _ => bilateral::Params {
            k: 0.0,
            max_iter: 1,
            tol: 0.0,
            prior,
        },
    }
}

/// Perspective integration (module `bilateral`): v = f_x ln t, then t = f_x e^(v/f_x)
/// with v centred per part.
fn perspective(
    normals: &NormalMap,
    mask: &Mask,
    cam: &Camera,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Output> {
    let (w, h) = (mask.width, mask.height);
    if !matches!(opts.method, Method::Lsq | Method::Bilateral { .. }) {
        return Err(Error::invalid(
            format!("a camera with method {}", opts.method.name()),
            "perspective integration needs method lsq or bini",
        ));
    }
    check_common(w, h, mask, opts)?;
    let comps = label_components(mask);
    let (field, clamped) = bilateral::Field::perspective(normals, mask, cam, opts.min_nz);
    let conf = lsq::pixel_weights(opts.weights.as_ref(), mask);
    let sol = bilateral::integrate(&field, &conf, mask, &comps, bini_params(opts), progress)?;
    let z: Vec<f32> = sol.v.iter().map(|&v| v as f32).collect();
    let p: Vec<f32> = field.g_h.iter().map(|&g| g as f32).collect();
    let q: Vec<f32> = field.g_v.iter().map(|&g| -g as f32).collect();
    let measured = support::edge_residual(&z, &p, &q, mask);
    let slant = |i: usize| {
        let d = cam.ray(i / w, i % w);
        field.a_h[i].abs() / (d[0] * d[0] + d[1] * d[1] + 1.0).sqrt()
    };
    let cues = parts::Cues { slant: &slant };
    let placed = place_parts(opts.parts, &z, Some(&comps), mask, &cues);
    let (mut depth, parts) = center(z, Some(&comps), measured.depth_sum, w, h, placed, mask)?;
    let f = cam.fx as f32;
    depth.data.iter_mut().for_each(|v| *v = f * (*v / f).exp());
    Ok(Output {
        depth,
        method: opts.method,
        clamped,
        path_disagreement: None,
        components: parts,
        info: bini_info(opts.method, &sol, measured.rms as f32),
        discontinuities: discontinuities(opts.method, sol, w, h),
        camera: Some(*cam),
    })
}

fn bini_info(method: Method, sol: &bilateral::Solution, residual: f32) -> SolverInfo {
    match method {
        Method::Bilateral { .. } => SolverInfo {
            iterations: sol.iterations,
            inner_iterations: sol.cg_iterations,
            residual,
        },
        _ => SolverInfo {
            iterations: sol.cg_iterations,
            inner_iterations: 0,
            residual,
        },
    }
}

fn discontinuities(
    method: Method,
    sol: bilateral::Solution,
    width: usize,
    height: usize,
) -> Option<Discontinuities> {
    matches!(method, Method::Bilateral { .. }).then_some(Discontinuities {
        width,
        height,
        east: sol.cut_east,
        south: sol.cut_south,
    })
}

/// Integrate gradients p = ∂z/∂x, q = ∂z/∂y inside a mask. Non-finite gradients inside
/// the mask are counted in [`Output::clamped`] and treated as 0.
pub fn integrate_gradients(
    p: &GrayImage,
    q: &GrayImage,
    mask: &Mask,
    opts: &Options,
) -> Result<Output> {
    integrate_gradients_with_progress(p, q, mask, opts, &NoProgress)
}

/// [`integrate_gradients`] reporting progress.
pub fn integrate_gradients_with_progress(
    p: &GrayImage,
    q: &GrayImage,
    mask: &Mask,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Output> {
    check_inputs(p, q, mask, opts)?;
    let (p, q) = (Cow::Borrowed(&p.data[..]), Cow::Borrowed(&q.data[..]));
    integrate_checked(p, q, mask, opts, None, progress)
}

/// [`integrate_gradients_with_progress`] after its checks, on gradients borrowed or
/// handed over; with `remake`, handed-over planes that the solver may free.
fn integrate_checked(
    p: Cow<'_, [f32]>,
    q: Cow<'_, [f32]>,
    mask: &Mask,
    opts: &Options,
    remake: Option<lsq::Remake<'_>>,
    progress: &dyn Progress,
) -> Result<Output> {
    let (w, h) = (mask.width, mask.height);
    let full = support::all_set_par(&mask.data);
    let (mut p, mut q, clamped) = support::sanitize_cow(p, q, mask, full);
    // A full mask is one part; the lsq solver needs the labels in every case.
    let iterative = matches!(opts.method, Method::Lsq | Method::Bilateral { .. });
    let comps = (!full || iterative).then(|| label_components(mask));
    let mut path_disagreement = None;
    let mut info = SolverInfo::default();
    let mut disc = None;
    let z: Vec<f32> = match opts.method {
        Method::Path => {
            let (z, dis) = path::integrate(&p, &q, mask);
            path_disagreement = Some(dis);
            z
        }
        Method::FrankotChellappa { reflect } => fourier::integrate(&p, &q, w, h, reflect)?,
        Method::Dct => dct::integrate(&p, &q, w, h),
        Method::Lsq => {
            let comps = comps
                .as_ref()
                .unwrap_or_else(|| unreachable!("labelled for lsq"));
            let weights = opts.weights.as_ref();
            let planes = (&mut p, &mut q, remake);
            let (z, it) = lsq::integrate_planes(planes, mask, weights, comps, progress)?;
            info.iterations = it;
            z
        }
        Method::Bilateral { .. } => {
            let comps = comps
                .as_ref()
                .unwrap_or_else(|| unreachable!("labelled for bini"));
            let field = bilateral::Field::orthographic(&p, &q, mask);
            let conf = lsq::pixel_weights(opts.weights.as_ref(), mask);
            let sol =
                bilateral::integrate(&field, &conf, mask, comps, bini_params(opts), progress)?;
            info = bini_info(opts.method, &sol, 0.0);
            let z = sol.v.iter().map(|&v| v as f32).collect();
            disc = discontinuities(opts.method, sol, w, h);
            z
        }
    };
    let measured = support::edge_residual(&z, &p, &q, mask);
    info.residual = measured.rms as f32;
    let slant = |i: usize| {
        let (a, b) = (p[i] as f64, q[i] as f64);
        1.0 / (1.0 + a * a + b * b).sqrt()
    };
    let cues = parts::Cues { slant: &slant };
    let placed = place_parts(opts.parts, &z, comps.as_ref(), mask, &cues);
    let (depth, parts) = center(z, comps.as_ref(), measured.depth_sum, w, h, placed, mask)?;
    Ok(Output {
        depth,
        method: opts.method,
        clamped,
        path_disagreement,
        components: parts,
        info,
        discontinuities: disc,
        camera: None,
    })
}

/// Per-part offsets of `rule` when the mask has several parts and the rule is not
/// [`Parts::Separate`] (`None`: centre each part on its own).
fn place_parts(
    rule: Parts,
    z: &[f32],
    comps: Option<&Components>,
    mask: &Mask,
    cues: &parts::Cues,
) -> Option<Vec<f64>> {
    let comps = comps.filter(|c| c.count > 1 && rule != Parts::Separate)?;
    support::all_finite_par(z).then(|| parts::offsets(rule, z, comps, mask, cues))
}

/// The solved depth with every connected part shifted to mean 0, or with the parts
/// shifted by `placed` and the whole mask to mean 0 (NaN outside the mask), and the
/// number of parts; an error if the solver produced non-finite values.
fn center(
    z: Vec<f32>,
    comps: Option<&Components>,
    depth_sum: f64,
    w: usize,
    h: usize,
    placed: Option<Vec<f64>>,
    mask: &Mask,
) -> Result<(DepthMap, usize)> {
    let non_finite = || {
        Error::invalid(
            "integration",
            "the solver produced non-finite depth; check the gradients for huge values",
        )
    };
    match comps {
        Some(c) => {
            if !support::all_finite_par(&z) {
                return Err(non_finite());
            }
            if let Some(off) = placed {
                let data = parts::apply(&z, c, &off, mask);
                return Ok((
                    crate::image::Image {
                        width: w,
                        height: h,
                        data,
                    },
                    c.count,
                ));
            }
            Ok((support::center_components(&z, c, w, h), c.count))
        }
        None => Ok((
            support::center_full(z, w, h, depth_sum).ok_or_else(non_finite)?,
            1,
        )),
    }
}

fn check_inputs(p: &GrayImage, q: &GrayImage, mask: &Mask, opts: &Options) -> Result<()> {
    let (w, h) = (p.width, p.height);
    if !q.same_size(p) {
        return Err(Error::SizeMismatch {
            what: "gradient q".into(),
            expected_w: w,
            expected_h: h,
            found_w: q.width,
            found_h: q.height,
            fix: "p and q must have the same size".into(),
        });
    }
    if opts.camera.is_some() {
        return Err(Error::invalid(
            "a camera with gradients",
            "perspective integration works from normals: use solve() with the normal map",
        ));
    }
    check_common(w, h, mask, opts)
}

/// Checks shared by the orthographic and the perspective paths.
fn check_common(w: usize, h: usize, mask: &Mask, opts: &Options) -> Result<()> {
    mask.check_size(w, h, "integration mask")?;
    if w < 2 || h < 2 {
        return Err(Error::invalid(
            format!("{w}x{h} normal map"),
            "integration needs an image of at least 2x2 pixels",
        ));
    }
    if !support::any_set_par(&mask.data) {
        return Err(Error::EmptyMask {
            what: "integration mask".into(),
            fix: "use a mask with non-zero pixels over the object".into(),
        });
    }
    if let Some(weights) = &opts.weights {
        if !matches!(opts.method, Method::Lsq | Method::Bilateral { .. }) {
            return Err(Error::invalid(
                format!("weights with method {}", opts.method.name()),
                "per-pixel weights are only used by lsq and bini; choose one or drop the weights",
            ));
        }
        if weights.width != w || weights.height != h {
            return Err(Error::SizeMismatch {
                what: "integration weights".into(),
                expected_w: w,
                expected_h: h,
                found_w: weights.width,
                found_h: weights.height,
                fix: "use a confidence map of the same size as the normals".into(),
            });
        }
    }
    if let Method::Bilateral { k, tol, .. } = opts.method {
        if !(k.is_finite() && k > 0.0 && tol.is_finite() && tol >= 0.0) {
            return Err(Error::invalid(
                format!("bini parameters k = {k}, tol = {tol}"),
                "k must be positive (default 2) and tol non-negative (default 1e-4)",
            ));
        }
    }
    Ok(())
}
