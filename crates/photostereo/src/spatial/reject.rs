//! The rule that a pixel is decided by its neighbours only where its own evidence cannot
//! tell ([`keep_own_where_rejected`]), and the refit after it ([`solve_with_rejection`]).
//!
//! **Refit without the rejected pixels.** A pixel whose own data reject the spatial
//! solution gets its match back; but its match's quadratic was part of the solve and
//! shaped its neighbours. Where that match is wrong for a reason the quadratic does not
//! know (a dark pixel matched by chance among the many sphere pixels that share its
//! tuple, a cast shadow beside a crease on a metal, where a shadowed tuple is another
//! normal's tuple), the prior carries it into every weak neighbour. So, when the rule
//! returned at least [`REFIT_MIN_SHARE`] of the mask's pixels to their match
//! ([`Options::refit`]), the field is solved once more
//! with those pixels' evidence left out (A = 0: the pixel follows its neighbours and
//! shapes none), and the rule applied again, the first set's quadratics put back for
//! their standard errors.
//!
//! Measured 2026-12-06 on the project's 8-bit GGX metal renders (F₀ 0.9, 16 lights,
//! exposed for the peak, sphere r 100 or 200, circle found), mean errors before → after
//! (lookup alone): 256² blob α 0.15 0.794 → 0.733° (1.899°), sphere target 1.269 →
//! 1.240° (2.260°), vase 0.378 → 0.361° (1.166°), V-groove without cast shadows
//! 0.180 → 0.165° (0.165°: +9% → 0%), V-groove α 0.2 1.119 → 1.089° (1.042°), bowl
//! 0.152 → 0.163° (0.236°), V-groove α 0.15 1.042 → 1.055° (0.858°); each the mean over
//! the render and three copies with all light intensities set to 0.5, 1 and 2, a scale
//! the answer should not depend on but that moves it by up to 0.4° on the V-groove's
//! weak dark face (the solve there is decided by thresholds). 1024² blob α 0.15 1.545 →
//! 1.452° (2.078°), α 0.2 blurred 0.8 px with a 3% black level 0.544 → 0.529° (0.851°).
//! The refit's passes: 8 gave 0.711 / 1.218 / 0.357 / 0.165 / 1.089 / 0.167 / 1.055 and
//! 1.430° at 1024², but `normals` on the 1024² metals took 7.9 s against 4.5 s without
//! the refit; 4 passes take 6.5 s, 2 passes 5.8 s (0.776 / 1.260 / 0.374 …). Starting
//! the refit from the first solution instead of the matches was not kept (V-groove
//! without shadows 0.418°). The refit runs only where the rule runs: on
//! quantisation-limited captures.

use super::info::Evidence;
use super::{angular_sigma_deg, mean_in, solve_relinearised, NoiseModel, Options, Output};
use crate::error::Result;
use crate::image::{Mask, NormalMap};

/// The refit runs only where the rejected pixels are at least this share of the mask:
/// a few scattered ones shape a few neighbours, and the second solve costs as much as
/// the first. On 8-bit plastic (0.03–0.1% rejected) the refit moved the mean error by
/// less than 0.0001° for +32% of `normals`' time at 1024² (1.87 → 2.46 s); on the
/// 8-bit metals where it pays, 0.44% (blob, α 0.2) to 40% (V-groove) are rejected.
pub const REFIT_MIN_SHARE: f64 = 0.002;

/// A pixel's own data, as the spatial stage after a lookup reads them: the capture held
/// whole ([`super::solve_lookup`]) or read again by row bands (a capture too large to
/// hold).
pub trait OwnData {
    /// Write into `ev` (u, A and g) the costs of the `far` pixels linearised at
    /// `normals` ([`super::info::linearise`]), leaving the other pixels alone.
    fn relinearise(&mut self, normals: &NormalMap, far: &[bool], ev: &mut Evidence) -> Result<()>;
    /// For the `moved` pixels, by how much their own data's cost rises from the
    /// matches to `solution` ([`super::info::cost_increase`]); 0 elsewhere.
    fn cost_rise(&mut self, solution: &NormalMap, moved: &[bool]) -> Result<Vec<f32>>;
}

/// The spatial stage from the evidence of the lookup's matches `ev` (and the matches'
/// normals): [`solve_relinearised`], [`keep_own_where_rejected`] and, where that rule
/// returned at least [`REFIT_MIN_SHARE`] of the mask's pixels to their match and
/// [`Options::refit`] is on, the same once more
/// without those pixels' evidence (module docs). The iterations of both solves are
/// counted.
pub fn solve_with_rejection(
    ev: Evidence,
    (mask, matches): (&Mask, &NormalMap),
    noise: &NoiseModel,
    opts: &Options,
    data: &mut dyn OwnData,
) -> Result<Output> {
    let relin = |n: &NormalMap, far: &[bool], ev: &mut Evidence| data.relinearise(n, far, ev);
    let (mut out, mut ev) = solve_relinearised(ev, mask, opts, relin)?;
    let rise = |s: &NormalMap, m: &[bool]| data.cost_rise(s, m);
    let kept = keep_own_where_rejected(&mut out, (&ev, matches), mask, noise, opts, rise)?;
    let enough = !kept.is_empty() && kept.len() as f64 >= REFIT_MIN_SHARE * mask.count() as f64;
    let Some(passes) = opts.refit.filter(|_| enough) else {
        return Ok(out);
    };
    let first_iterations = out.stats.iterations;
    drop(out);
    let aside: Vec<(usize, [f32; 3])> = kept
        .iter()
        .map(|&i| (i, std::mem::replace(&mut ev.a[i], [0.0; 3])))
        .collect();
    let relin = |n: &NormalMap, far: &[bool], ev: &mut Evidence| data.relinearise(n, far, ev);
    let refit = Options {
        passes,
        ..opts.clone()
    };
    let (mut out, mut ev) = solve_relinearised(ev, mask, &refit, relin)?;
    for (i, a) in aside {
        ev.a[i] = a;
    }
    let rise = |s: &NormalMap, m: &[bool]| data.cost_rise(s, m);
    keep_own_where_rejected(&mut out, (&ev, matches), mask, noise, opts, rise)?;
    out.stats.iterations += first_iterations;
    Ok(out)
}

/// Own share at or above which [`keep_own_where_rejected`] returns a pixel's match.
pub const DECIDED_BY_OWN: f32 = 0.999;

/// Pixel `i` gets its match back, with the match's standard error (`ev`, the matches'
/// evidence).
fn take_match(out: &mut Output, (ev, matches): (&Evidence, &NormalMap), i: usize) {
    out.normals.data[i] = matches.data[i];
    out.sigma_deg.data[i] = angular_sigma_deg(ev.u[i], ev.a[i]);
}

/// Every mask pixel of own share ≥ [`DECIDED_BY_OWN`] whose normal moved gets its match
/// back; returns whether any did.
fn restore_decided_by_own(out: &mut Output, evm: (&Evidence, &NormalMap), mask: &Mask) -> bool {
    let mut changed = false;
    for i in 0..mask.data.len() {
        if mask.data[i]
            && out.own_share.data[i] >= DECIDED_BY_OWN
            && out.normals.data[i] != evm.1.data[i]
        {
            take_match(out, evm, i);
            changed = true;
        }
    }
    changed
}

/// The rule that a pixel is decided by its neighbours only where its own evidence cannot
/// tell: every pixel whose own data reject the spatial normal (their cost rises by more
/// than [`Options::reject`] from the match's, `rise(solution, moved)`: for the `moved`
/// pixels, [`super::info::cost_increase`] from the `matches` to the solution) gets back its
/// match, with own share 1 and the standard error of its match (`ev`, the matches'
/// evidence). The quadratic information A cannot make this test: it is the curvature at
/// the match, and a dark pixel whose samples are bounds (zeros of an 8-bit image) has
/// almost none, although a normal that would light one of its zeros is plainly wrong.
///
/// Applied only where the noise is quantisation-limited
/// ([`NoiseModel::quantisation_limited`]): under real Gaussian noise the match has
/// fitted part of the noise, its own cost then rises at any other normal, and the rule
/// would refuse the neighbours' good normals (measured: 1%-noise rough metal 1.90 →
/// 2.58°).
///
/// First, on any noise, a pixel whose own share is at least [`DECIDED_BY_OWN`] gets its
/// match back: the prior moves its exact solution by less than 0.1% of the way to the
/// neighbours' normal, but the f32 solve does not resolve that near the rim, where a
/// step δ of (n_x, n_y) turns the normal by δ / n_z (clean 16-bit Lambertian: pixels
/// at 85–90° with own share 0.99998 came out up to 2.4° from their match, the band's
/// error 0.0002 → 0.023°).
///
/// Returns the pixels returned to their match by the rule of `reject`.
pub fn keep_own_where_rejected(
    out: &mut Output,
    (ev, matches): (&Evidence, &NormalMap),
    mask: &Mask,
    noise: &NoiseModel,
    opts: &Options,
    rise: impl FnOnce(&NormalMap, &[bool]) -> Result<Vec<f32>>,
) -> Result<Vec<usize>> {
    out.stats.kept_own = 0;
    let mut kept = Vec::new();
    let restored = restore_decided_by_own(out, (ev, matches), mask);
    if noise.quantisation_limited() {
        let moved: Vec<bool> = (0..mask.data.len())
            .map(|i| mask.data[i] && out.normals.data[i] != matches.data[i])
            .collect();
        let rise = rise(&out.normals, &moved)?;
        for (i, _) in rise.iter().enumerate().filter(|(_, &d)| d > opts.reject) {
            take_match(out, (ev, matches), i);
            out.own_share.data[i] = 1.0;
            kept.push(i);
        }
        out.stats.kept_own = kept.len();
        out.stats.decided_by_neighbours = (0..mask.data.len())
            .filter(|&i| mask.data[i] && out.own_share.data[i] < 0.5)
            .count();
    }
    if restored || noise.quantisation_limited() {
        out.stats.mean_sigma_deg = mean_in(&out.sigma_deg, mask);
    }
    Ok(kept)
}
