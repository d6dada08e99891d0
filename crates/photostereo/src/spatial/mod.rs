//! Noise-aware evidence and a spatial stage after the per-pixel lookup: pixels that say
//! little about their normal take it from the surface around them.
//!
//! # Evidence of a pixel ([`info`])
//!
//! The noise is measured on the images ([`NoiseModel`]: σ²(I) = σ₀² + g·I, read and
//! shot noise). Around the lookup's match u = (n_x, n_y) the pixel's cost
//! ‖t − c·I(u)‖²_W (W = diag 1/σ²(I_k), cast-shadowed lights left out as the lookup does)
//! is approximated by the quadratic (u − û)ᵀ A (u − û), A = Jᵀ W J, with J = c·∂I/∂u
//! the table's intensity field differentiated in normal space (central differences on
//! the sphere images: ∂/∂n_x = R ∂/∂x, ∂/∂n_y = −R ∂/∂y). Its inverse is the covariance
//! of the normal; the angular standard error σ_θ = √tr(M A⁻¹) (M = I + u uᵀ/n_z², the
//! metric of the unit sphere in (n_x, n_y)) is returned in degrees
//! ([`Output::sigma_deg`], `normals_sigma.npy` in the CLI). This is the local Cramér–Rao
//! bound of the match (Woodham 1994 already derives a local confidence from the
//! Jacobian); with no information it is capped at 90°.
//!
//! # The spatial stage ([`solve`])
//!
//! MAP estimate of the field u over the mask:
//!
//! E(u) = Σ_i (u_i − û_i)ᵀ A_i (u_i − û_i) + λ Σ_t ω_t ‖u_a − 2u_b + u_c‖²,
//!
//! t = (a, b, c) running over consecutive mask pixels along rows and columns, λ = 1/τ²
//! with τ between [`Options::smoothest`] and [`Options::smoothness`], chosen block by
//! block from the matches' own second differences less what their noise explains
//! ([`roughness`]: smooth inside an object, free where it bends at its contour). The
//! prior penalises the *second* differences of
//! (n_x, n_y): every field linear in the image position costs nothing — in particular a
//! sphere, whose (n_x, n_y) = (x, y)/R — so it adds no bias on smoothly curved surfaces
//! and extrapolates the curvature into dark regions (the rim of a shiny object, where
//! no light gives a highlight) instead of flattening them. Where a pixel's own
//! information dominates (clean, well-lit pixels: A_i ≫ λ) it keeps its own normal.
//! **Discontinuities**: a triple is cut (ω_t = 0) when either of its pairs shows
//! evidence of a jump: both pixels know their normal to better than `jump`/3 (σ in
//! normal units) and their matches differ by more than [`Options::jump`]. Without such
//! evidence a weak pixel is continued from its neighbours. Solved by preconditioned
//! conjugate gradients, coarse to fine ([`solve`] module docs).
//!
//! # Re-linearisation ([`solve_table`])
//!
//! The quadratic at the match is only valid near the match. A dark pixel (signal-to-noise
//! 1–3 in every image) is often matched by chance where the table has structure, and
//! reports there an information A it does not have. After the first solve, every pixel
//! the solution moved outside its match's trust region ((u − û)ᵀ A (u − û) >
//! [`Options::trust`]) has its cost re-linearised at its current normal u₀ (Gauss–Newton:
//! A = JᵀWJ and g = JᵀW (t − c·I(u₀)) at u₀, right-hand side A u₀ + g), and the problem is
//! solved again from the current field on the finest level; up to [`Options::passes`]
//! times, stopping when no pixel is outside its trust region. Pixels near their match
//! keep its quadratic, so clean, well-lit pixels are not moved by the linearisation's
//! error (the table is sampled bilinearly; its slope by central differences). Measured
//! on the project's rough-metal blob with 1% noise: 5.06° after the first solve, 3.8°,
//! 2.9° and 1.97° after 1, 2 and 4 passes; with today's contour prior (2026-12-05,
//! `noise_sweep one metal 0.01`) 3.37°, 2.30°, 1.80°, 1.49°, 1.41°, 1.39° and
//! 1.38° after 0, 1, 2, 4, 6, 8 and 12, so the default is 8 (a pass costs one fine-level
//! solve; the stage stops earlier when no pixel is outside its trust region).
//!
//! **A pixel's own data may refuse** ([`Options::reject`]): the quadratic A is the
//! curvature at the match, and says nothing of a dark pixel whose samples are bounds
//! (the zeros of an 8-bit metal), although a normal that would light one of its zeros is
//! plainly wrong. After the passes, every pixel whose own data's cost (censored samples
//! as bounds, [`info::cost_increase`]) rises by more than `reject` from its match to
//! the solution keeps its match. Measured on the project's 8-bit renders (blob, sphere
//! r 100, 16 lights, exposed for the peak; `tests/camera_images.rs`), rough metal: 3.88°
//! without the rule and the censoring, 1.05° with them, the lookup alone 1.16°.
//! The pixels so returned then shape no neighbour: the field is solved once more without
//! their evidence ([`Options::refit`], [`solve_with_rejection`]).
//!
//! **Confidence afterwards**: the share of the pixel's posterior information that is its
//! own, s = tr A / tr(A + P) with P the prior's diagonal, is returned in
//! [`Output::own_share`]; the confidence is multiplied by s, so pixels decided by their
//! neighbours (s < 0.5) have a confidence below 0.5 (and `decided_by_neighbours` counts
//! them). Refs: Woodham, JOSA A 11(11), 1994 (confidence from the Jacobian);
//! Szeliski, "Fast surface interpolation using hierarchical basis functions", PAMI
//! 12(6), 1990 (thin-plate priors solved coarse to fine); Hertzmann & Seitz, PAMI 27(8),
//! 2005 (the lookup).

mod contour;
pub mod info;
pub mod levels;
pub mod noise;
mod reject;
pub mod roughness;
mod solve;

pub use info::{
    angular_sigma_deg, blurred_outline, outline_weight, Evidence, MAX_SIGMA_DEG, SHARP_OUTLINE_PX,
};
pub use levels::{Censor, Levels};
pub use noise::{NoiseModel, NoiseSampler};
pub use reject::{
    keep_own_where_rejected, solve_with_rejection, OwnData, DECIDED_BY_OWN, REFIT_MIN_SHARE,
};

use crate::error::{Error, Result};
use crate::image::{GrayImage, ImageStack, Mask, NormalMap};
use crate::lut::{self, Table};
use rayon::prelude::*;
use solve::Level;

/// Options of [`solve`] and [`solve_table`].
#[derive(Clone, Debug)]
pub struct Options {
    /// τ: typical second difference of (n_x, n_y) between consecutive pixels on a
    /// smooth surface (unit-normal components per pixel²); the prior weight is λ = 1/τ².
    /// Smaller = smoother. It is also the largest of the local scales ([`roughness`]),
    /// the one taken where the matches say too little to estimate one. Default 0.005
    /// (0.01 before 2026-12-07: measured on every camera case of the tests, noisy and
    /// 8-bit metal gained 6–20%, 1% noise Lambertian and plastic 8% and 15%, clean and
    /// 8-bit plastic and Lambertian unchanged; one case lost, the clipped 8-bit
    /// Lambertian with the circle found, 0.107° → 0.145°; docs/accuracy.md).
    pub smoothness: f32,
    /// τ_min: the prior's scale where the matches show a smooth surface (module
    /// [`roughness`]): each block's τ is estimated from the matches' own second
    /// differences and kept in [τ_min, τ]. Equal to `smoothness`: one τ everywhere.
    /// Default 0.0025.
    pub smoothest: f32,
    /// Jump of (n_x, n_y) between neighbouring pixels (unit-normal components) that is
    /// evidence of a discontinuity when both pixels know their normal well (see the
    /// module docs). Default 0.15 (about 9°).
    pub jump: f32,
    /// Conjugate-gradient iterations per level (the coarsest level gets 300). Default 40.
    pub iterations: usize,
    /// Standard error (unit-normal components) of the occluding-contour prior at the
    /// mask's edge along the contour's tangent (see the module docs; the tilt towards the
    /// outward direction has its own, 0.995 ± 0.01 of |(n_x, n_y)|); `None` = no such
    /// prior (masks that cut through a surface instead of following the object's
    /// silhouette). Default `Some(0.03)`.
    pub contour_sigma: Option<f32>,
    /// [`solve_table`]: dark level of the cast-shadow rule, as in [`lut::Options::shadow_level`].
    /// Default 0.03.
    pub shadow_level: f32,
    /// [`solve_table`]: at most this many re-linearisation (Gauss–Newton) passes after the
    /// first solve; 0 = the quadratics at the matches only. Default 8.
    pub passes: usize,
    /// [`solve_table`]: trust region of a match, as a squared Mahalanobis distance
    /// (u − û)ᵀ A (u − û) (dimensionless; 25 = 5 standard errors): a pixel the solution
    /// moved further is re-linearised at its current normal. Default 25.
    pub trust: f32,
    /// [`solve_table`]: a pixel keeps its own match where its own data reject the
    /// spatial solution: where their cost there exceeds that at the match by more than
    /// this (units of the noise variance, i.e. twice a log-likelihood ratio; censored
    /// samples as bounds, see [`info::cost_increase`]). Default 9 (about 3σ; χ² with
    /// two degrees of freedom, 1%).
    pub reject: f32,
    /// [`solve_table`]: where the rule of `reject` returned at least [`REFIT_MIN_SHARE`]
    /// of the mask's pixels to their match, solve once more without those pixels'
    /// evidence, with at most this many
    /// re-linearisation passes (module `reject`: a match its own surroundings
    /// contradict shapes no neighbour); `None` = no refit. Default `Some(4)`.
    pub refit: Option<usize>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            smoothness: 0.005,
            smoothest: 0.0025,
            jump: 0.15,
            iterations: 40,
            contour_sigma: Some(0.03),
            shadow_level: lut::Options::default().shadow_level,
            passes: 8,
            trust: 25.0,
            reject: 9.0,
            refit: Some(4),
        }
    }
}

/// Result of [`solve`]; every image has the target's size, zeros outside the mask.
#[derive(Clone, Debug)]
pub struct Output {
    /// Unit normals after the spatial stage.
    pub normals: NormalMap,
    /// Share in [0, 1] of each pixel's own data in its normal (1 = decided by its own
    /// data, 0 = by its neighbours; see the module docs).
    pub own_share: GrayImage,
    /// Angular standard error (degrees) of the normal from the pixel's own data, at the
    /// returned normal (capped at 90°).
    pub sigma_deg: GrayImage,
    /// Summary figures.
    pub stats: Stats,
}

/// Summary of a [`solve`] run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// Pixels solved.
    pub pixels: usize,
    /// Pixels whose own share is below 0.5.
    pub decided_by_neighbours: usize,
    /// Triples (row or column) of the prior cut at a discontinuity.
    pub cut_triples: usize,
    /// Pixels that kept their own match because their own data rejected the spatial
    /// solution ([`Options::reject`]; [`solve_table`] only).
    pub kept_own: usize,
    /// Levels of the coarse-to-fine solve.
    pub levels: usize,
    /// Conjugate-gradient iterations, all levels together.
    pub iterations: usize,
    /// Mean angular standard error over the mask (degrees).
    pub mean_sigma_deg: f64,
}

/// One quadratic pass over the evidence `ev` (from [`info::from_table`] or
/// [`info::from_lambertian`]): the costs stay the quadratics at the matches.
///
/// Errors: evidence of another size than the mask; a smoothness or jump that is not
/// positive and finite.
pub fn solve(ev: &Evidence, mask: &Mask, opts: &Options) -> Result<Output> {
    solve_from(ev, mask, opts, None)
}

fn solve_from(
    ev: &Evidence,
    mask: &Mask,
    opts: &Options,
    start: Option<Vec<[f32; 2]>>,
) -> Result<Output> {
    check(ev, mask, opts)?;
    let (x, fine, levels, its) = quadratic(ev, mask, opts, start);
    let out = finish(ev, mask, &x, (fine, levels), its);
    crate::io::memtrace::mark("spatial: solution's images made");
    Ok(out)
}

/// The spatial stage after a lookup with one `table` (the lookup's `normals` and, with
/// normalised matching, its `albedo`): the evidence ([`info::from_table`]), [`solve`],
/// then up to [`Options::passes`] Gauss–Newton passes that re-linearise the cost of every
/// pixel the solution moved outside its match's trust region ([`Options::trust`]) at
/// its current normal (module docs, "Re-linearisation"). The angular standard error is
/// that of the last linearisation of each pixel's own data, at the returned normal.
pub fn solve_table(
    stack: &ImageStack,
    mask: &Mask,
    table: &Table,
    lookup: &lut::Output,
    noise: &NoiseModel,
    opts: &Options,
) -> Result<Output> {
    let lookup = (&lookup.normals, lookup.albedo.as_ref());
    solve_lookup(stack, mask, table, lookup, noise, opts)
}

/// [`solve_table`] from the parts of a lookup's output it uses: its `normals` and, with
/// normalised matching, its albedo ratio (`None` otherwise).
pub fn solve_lookup(
    stack: &ImageStack,
    mask: &Mask,
    table: &Table,
    (normals, albedo): (&NormalMap, Option<&GrayImage>),
    noise: &NoiseModel,
    opts: &Options,
) -> Result<Output> {
    let level = opts.shadow_level;
    let censor = Censor::new(stack, mask, noise.step);
    let model = (noise, &censor);
    let refl = info::Reflectance::new(table, noise);
    let ev = info::from_table(stack, mask, &refl, normals, albedo, model, level);
    let mut data = HeldData {
        stack,
        mask,
        table: &refl,
        matches: (normals, albedo),
        model,
        level,
    };
    solve_with_rejection(ev, (mask, normals), noise, opts, &mut data)
}

/// The own data of a capture held whole ([`solve_lookup`]).
struct HeldData<'a> {
    stack: &'a ImageStack,
    mask: &'a Mask,
    table: &'a info::Reflectance<'a>,
    matches: (&'a NormalMap, Option<&'a GrayImage>),
    model: (&'a NoiseModel, &'a Censor),
    level: f32,
}

impl OwnData for HeldData<'_> {
    fn relinearise(&mut self, normals: &NormalMap, far: &[bool], ev: &mut Evidence) -> Result<()> {
        let (stack, mask, table, albedo) = (self.stack, self.mask, self.table, self.matches.1);
        let (model, level) = (self.model, self.level);
        let lin = info::linearise(stack, mask, table, normals, albedo, model, level, far);
        for (i, _) in far.iter().enumerate().filter(|(_, &f)| f) {
            (ev.u[i], ev.a[i], ev.g[i]) = (lin.u[i], lin.a[i], lin.g[i]);
        }
        Ok(())
    }

    fn cost_rise(&mut self, solution: &NormalMap, moved: &[bool]) -> Result<Vec<f32>> {
        let (stack, mask, table) = (self.stack, self.mask, self.table);
        let (pair, albedo) = ((self.matches.0, solution), self.matches.1);
        Ok(info::cost_increase(
            stack, mask, table, pair, albedo, self.model, self.level, moved,
        ))
    }
}

/// [`solve_lookup`] from the evidence of the lookup's matches (`ev`, from
/// [`info::from_table`]) and a `relinearise(normals, far, ev)` that writes into `ev`
/// (u, A and g) the costs of the `far` pixels linearised at `normals`
/// ([`info::linearise`]), leaving the other pixels alone; for a capture read by row
/// bands, which re-reads the bands that hold such pixels. The costs are swapped into
/// `ev` in place, and the matches' quadratics of the few re-linearised pixels kept
/// aside, so that no second H×W copy of the evidence is made. Returns the solution and
/// `ev` as it came (the matches' evidence), for [`keep_own_where_rejected`].
pub fn solve_relinearised(
    mut ev: Evidence,
    mask: &Mask,
    opts: &Options,
    mut relinearise: impl FnMut(&NormalMap, &[bool], &mut Evidence) -> Result<()>,
) -> Result<(Output, Evidence)> {
    let mut out = solve(&ev, mask, opts)?;
    let mut iterations = out.stats.iterations;
    // (pixel, u, A) of the match of every pixel re-linearised by the last pass
    let mut matches: Vec<(usize, [f32; 2], [f32; 3])> = Vec::new();
    for pass in 0..=opts.passes {
        for (i, u, a) in matches.drain(..) {
            (ev.u[i], ev.a[i], ev.g[i]) = (u, a, [0.0; 2]);
        }
        if pass == opts.passes {
            break;
        }
        let far = outside_trust(&ev, mask, &out.normals, opts.trust);
        if !far.iter().any(|&f| f) {
            break;
        }
        let far_pixels = far.iter().enumerate().filter(|(_, &f)| f);
        matches.extend(far_pixels.map(|(i, _)| (i, ev.u[i], ev.a[i])));
        if ev.g.is_empty() {
            ev.g = vec![[0.0; 2]; ev.u.len()];
        }
        relinearise(&out.normals, &far, &mut ev)?;
        drop(far);
        // the start, per mask pixel in row-major order (the solve's own order)
        let x0: Vec<[f32; 2]> = (out.normals.data.iter().zip(&mask.data))
            .filter(|(_, &m)| m)
            .map(|(n, _)| [n[0], n[1]])
            .collect();
        drop(out);
        out = solve_from(&ev, mask, opts, Some(x0))?;
        iterations += out.stats.iterations;
    }
    out.stats.iterations = iterations;
    ev.g = Vec::new();
    Ok((out, ev))
}

/// Mask pixels whose normal in `normals` lies outside the trust region of their match:
/// (u − û)ᵀ A (u − û) > `trust`.
fn outside_trust(ev: &Evidence, mask: &Mask, normals: &NormalMap, trust: f32) -> Vec<bool> {
    ev.u.par_iter()
        .zip(&ev.a)
        .zip(normals.data.par_iter().zip(&mask.data))
        .map(|((u0, a), (n, &m))| {
            let d = [n[0] - u0[0], n[1] - u0[1]];
            m && a[0] * d[0] * d[0] + 2.0 * a[1] * d[0] * d[1] + a[2] * d[1] * d[1] > trust
        })
        .collect()
}

/// Mean of `img` over the `mask` pixels.
pub fn mean_in(img: &GrayImage, mask: &Mask) -> f64 {
    let (sum, n) = img
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(_, &m)| m)
        .fold((0.0f64, 0usize), |(s, n), (v, _)| (s + *v as f64, n + 1));
    sum / n.max(1) as f64
}

/// The occluding-contour prior of each mask-edge pixel (index, its quadratic's
/// matrix terms, its linear terms); none without `opts.contour_sigma`.
fn contour_priors(mask: &Mask, opts: &Options) -> Vec<(usize, [f32; 3], [f32; 2])> {
    match opts.contour_sigma {
        Some(sc) => contour::contour_normals(mask)
            .into_iter()
            .map(|(i, u)| {
                let (da, db) = contour::prior(u, sc);
                (i, da, db)
            })
            .collect(),
        None => Vec::new(),
    }
}

/// Solve from the coarsest level down to `fine`, each level started from the one
/// below; returns the solution, the number of levels and the iterations.
fn coarse_to_fine(fine: &Level, opts: &Options) -> (Vec<[f32; 2]>, usize, usize) {
    let mut coarse: Vec<Level> = Vec::new();
    loop {
        let last = coarse.last().unwrap_or(fine);
        if !solve::has_coarser(last.w, last.h) {
            break;
        }
        let next = last.coarser();
        coarse.push(next);
    }
    let count = coarse.len() + 1;
    let coarsest = coarse.last().unwrap_or(fine);
    let mut x = coarsest.own();
    let mut iterations = coarsest.solve(&mut x, solve::coarse_iterations());
    while let Some(c) = coarse.pop() {
        // the coarser levels are dropped as soon as they have started the next one
        let next = coarse.last().unwrap_or(fine);
        x = next.start_from(&c, &x);
        drop(c);
        iterations += next.solve(&mut x, opts.iterations);
    }
    (x, count, iterations)
}

/// Solve the quadratic problem of the evidence `ev` (its matches' quadratics, plus its
/// gradient where it has one); returns the solution per mask pixel (row-major order),
/// the finest level, the number of levels and the iterations.
fn quadratic(
    ev: &Evidence,
    mask: &Mask,
    opts: &Options,
    start: Option<Vec<[f32; 2]>>,
) -> (Vec<[f32; 2]>, Level, usize, usize) {
    let (w, h) = (ev.width, ev.height);
    let jump2 = opts.jump * opts.jump;
    let known2 = jump2 / 9.0;
    let tau_min = opts.smoothest.min(opts.smoothness);
    let lambda = 1.0 / (tau_min * tau_min);
    let scale = (tau_min < opts.smoothness)
        .then(|| roughness::PriorScale::estimate(ev, mask, (tau_min, opts.smoothness), known2));
    let m = &mask.data;
    let n = m.len();
    let jumps = |i: usize, j: usize| {
        let d = [ev.u[i][0] - ev.u[j][0], ev.u[i][1] - ev.u[j][1]];
        d[0] * d[0] + d[1] * d[1] > jump2
    };
    // variance of each match in normal units (tr A⁻¹), for the discontinuity test
    let var = |i: usize| trace_inverse(ev.a[i]);
    // a discontinuity between i and j = i + step: a jump between two well-known pixels,
    // each continuing smoothly on its own side (a lone outlier is no evidence)
    let pair_ok = |i: usize, j: usize, step: usize| {
        if !(jumps(i, j) && var(i) < known2 && var(j) < known2) {
            return true;
        }
        let before = i >= step && m[i - step] && !jumps(i - step, i);
        let after = j + step < n && m[j + step] && !jumps(j, j + step);
        !(before && after)
    };
    let contour = contour_priors(mask, opts);
    let fields = (&ev.a[..], &ev.u[..], &ev.g[..]);
    let prior = (lambda, |i: usize| scale.as_ref().map_or(1.0, |s| s.at(i)));
    let fine = Level::finest((w, h), m, fields, &contour, prior, pair_ok);
    drop(contour);
    crate::io::memtrace::mark("spatial: finest level built");
    if let Some(mut x) = start {
        let its = fine.solve(&mut x, opts.iterations);
        return (x, fine, 1, its);
    }
    let (x, count, iterations) = coarse_to_fine(&fine, opts);
    crate::io::memtrace::mark("spatial: coarse to fine solved");
    (x, fine, count, iterations)
}

/// The output images and figures from the solution `x` (per mask pixel) on the `fine`
/// level of the `levels` solved (dropped before the images are made).
fn finish(
    ev: &Evidence,
    mask: &Mask,
    x: &[[f32; 2]],
    (fine, levels): (Level, usize),
    iterations: usize,
) -> Output {
    let a = &ev.a;
    let (w, h) = (ev.width, ev.height);
    let mut own = vec![0.0f32; fine.len()];
    fine.each(&mut own, |r, c, i, j| fine.own_share((r, c, i, j)));
    let cut_triples = fine.cut_triples();
    drop(fine);
    let mut normals = NormalMap::filled(w, h, [0.0; 3]);
    let mut own_share = GrayImage::filled(w, h, 0.0);
    let mut sigma_deg = GrayImage::filled(w, h, 0.0);
    // (own share, normal, σ_θ) per pixel, rows in parallel; zeros outside the mask. The
    // mask pixels of row r are x's and own's from the count of those above it.
    let starts: Vec<usize> = std::iter::once(0)
        .chain(mask.data.chunks(w.max(1)).scan(0, |n, row| {
            *n += row.iter().filter(|&&m| m).count();
            Some(*n)
        }))
        .collect();
    normals
        .data
        .par_chunks_mut(w.max(1))
        .zip(own_share.data.par_chunks_mut(w.max(1)))
        .zip(sigma_deg.data.par_chunks_mut(w.max(1)))
        .enumerate()
        .for_each(|(r, ((nrow, srow), grow))| {
            let mut j = starts[r];
            for c in 0..w {
                let i = r * w + c;
                if !mask.data[i] {
                    continue;
                }
                let n = to_normal(x[j]);
                nrow[c] = n;
                srow[c] = own[j];
                grow[c] = angular_sigma_deg([n[0], n[1]], a[i]);
                j += 1;
            }
        });
    let pixels = mask.count();
    let decided_by_neighbours = (own_share.data.iter().zip(&mask.data))
        .filter(|(&s, &m)| m && s < 0.5)
        .count();
    let stats = Stats {
        pixels,
        decided_by_neighbours,
        cut_triples,
        kept_own: 0,
        levels,
        iterations,
        mean_sigma_deg: mean_in(&sigma_deg, mask),
    };
    Output {
        normals,
        own_share,
        sigma_deg,
        stats,
    }
}

/// The lookup's confidence after the spatial stage: multiplied by the own share.
pub fn confidence_after(confidence: &GrayImage, own_share: &GrayImage) -> GrayImage {
    let mut out = confidence.clone();
    for (c, s) in out.data.iter_mut().zip(&own_share.data) {
        *c *= s;
    }
    out
}

fn check(ev: &Evidence, mask: &Mask, opts: &Options) -> Result<()> {
    mask.check_size(ev.width, ev.height, "spatial stage mask")?;
    let ok = |v: f32| v.is_finite() && v > 0.0;
    let contour_ok = opts.contour_sigma.is_none_or(ok);
    if !ok(opts.smoothness)
        || !ok(opts.smoothest)
        || !ok(opts.jump)
        || !contour_ok
        || !ok(opts.trust)
    {
        return Err(Error::invalid(
            format!(
                "spatial smoothness {} (smoothest {}) / jump {} / contour sigma {:?} / trust {}",
                opts.smoothness, opts.smoothest, opts.jump, opts.contour_sigma, opts.trust
            ),
            "use positive finite values (defaults 0.005 (0.0025), 0.15, 0.03 and 25)",
        ));
    }
    Ok(())
}

/// tr A⁻¹ (∞ when singular).
fn trace_inverse(a: [f32; 3]) -> f32 {
    let det = a[0] as f64 * a[2] as f64 - (a[1] as f64).powi(2);
    if det > 0.0 {
        ((a[0] + a[2]) as f64 / det) as f32
    } else {
        f32::INFINITY
    }
}

/// Unit normal of (n_x, n_y), pulled inside the unit disc when it left it.
fn to_normal(u: [f32; 2]) -> [f32; 3] {
    let r2 = u[0] * u[0] + u[1] * u[1];
    let max = 0.9999f32;
    let (x, y) = if r2 > max * max {
        let s = max / r2.sqrt();
        (u[0] * s, u[1] * s)
    } else {
        (u[0], u[1])
    };
    [x, y, (1.0 - x * x - y * y).max(0.0).sqrt()]
}
