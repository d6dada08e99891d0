//! The per-pixel pipeline: candidate search, re-ranking, refinement, cast shadows and
//! confidence (see the parent module for the method).

use super::fit::fused::{self, Buf, Single, Start};
use super::fit::generic::{Fit, Model, Scratch};
use super::fit::rim::{Rim, RimBuf};
use super::options::{Method, Options};
use super::output::PixelOut;
use super::table::Table;
use std::sync::atomic::AtomicU32;

mod certify;
mod global;
pub mod index;
mod mixture;
mod prep;
mod shadows;
use index::Index;
pub(crate) use prep::Prep;

/// Target number of points of the coarse grid used by the exhaustive searches.
const COARSE_POINTS: usize = 1500;
/// Coarse candidates kept for the local descent.
const COARSE_KEEP: usize = 3;

/// Distance (grid pixels) within which the tree's best candidate counts as lying in the
/// basin of the coherence shortcut's fit (module docs, step 1).
const SAME_BASIN: f64 = 1.5;
/// Largest step (grid pixels) between neighbouring pixels that the warm start
/// extrapolates.
const MAX_EXTRAPOLATION: f64 = 2.0;
/// Relative residual always accepted by the coherence tests.
const WARM_FLOOR: f32 = 0.003;
/// A fit within this many grid pixels of the table's edge is always refitted on the rim
/// model (further in, beyond `Rim::tried_below`, only a fit worse than [`WARM_FLOOR`]).
const RIM_TRIGGER: f64 = 1.0;

/// The previous pixel's solution, for the coherence shortcut.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Warm {
    pub gx: f64,
    pub gy: f64,
    /// Step from the pixel before (the start is extrapolated by it).
    pub dgx: f64,
    pub dgy: f64,
    /// The solution had lights dropped as cast-shadowed (they are in `Work::prev_w`).
    pub masked: bool,
}

impl Warm {
    fn at(gx: f64, gy: f64) -> Self {
        Warm {
            gx,
            gy,
            dgx: 0.0,
            dgy: 0.0,
            masked: false,
        }
    }
}

/// The rim model with what its trigger (`Solver::rim_fit`) tests at every pixel,
/// computed once per target rather than per pixel (a cosine and a square root).
struct RimGate<'a> {
    rim: &'a Rim,
    /// `Rim::tried_below`: the cosine of the polar angle below which fits are refitted.
    tried_below: f64,
    /// Table 0's circle centre on its window grid.
    centre: (f64, f64),
    /// Squared grid distance from the centre inside which every fit's normal has
    /// n_z > `tried_below` with a margin (1e-6 on n_z, against f32 rounding of the
    /// normal), so that the exact test can be skipped.
    clear2: f64,
}

impl<'a> RimGate<'a> {
    fn new(rim: &'a Rim, t0: &Table) -> Self {
        let tried_below = rim.tried_below();
        let c = tried_below + 1e-6;
        let clear2 = if c < 1.0 {
            t0.circle.radius.powi(2) * (1.0 - c * c)
        } else {
            -1.0
        };
        RimGate {
            rim,
            tried_below,
            centre: t0.to_grid(t0.circle.cx, t0.circle.cy),
            clear2,
        }
    }
}

/// The two fits lie within [`SAME_BASIN`] grid pixels of each other.
fn same_basin(a: &Fit, b: &Fit) -> bool {
    (a.gx - b.gx).powi(2) + (a.gy - b.gy).powi(2) <= SAME_BASIN * SAME_BASIN
}

/// ‖t‖² of a tuple padded with zeros to a multiple of 8 (eight partial sums, which the
/// compiler vectorises).
fn norm2(t: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    for chunk in t.chunks_exact(8) {
        for (a, v) in acc.iter_mut().zip(chunk) {
            *a += v * v;
        }
    }
    ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]))
}

/// √cost / ‖t‖ from a precomputed ‖t‖.
fn relative_to(norm: f32, cost: f32) -> f32 {
    if norm > 0.0 {
        cost.max(0.0).sqrt() / norm
    } else {
        f32::INFINITY
    }
}

/// The coarse grid of the exhaustive searches: positions on table 0's grid (about
/// [`COARSE_POINTS`] inside the search disc), the tables' tuples there, and the spacing.
fn coarse_grid(model: &Model<'_>) -> (Vec<(f64, f64)>, [Vec<f32>; 2], f64) {
    let t0 = &model.tables[0];
    let area = std::f64::consts::PI * t0.search_radius().powi(2);
    let coarse_step = (area / COARSE_POINTS as f64).sqrt().max(1.0).floor();
    let mut s = Scratch::new(model.k);
    let (mut coarse_pos, mut coarse_basis) = (Vec::new(), [Vec::new(), Vec::new()]);
    let (cgx, cgy) = t0.to_grid(t0.circle.cx, t0.circle.cy);
    let steps = (t0.search_radius() / coarse_step).ceil() as i64;
    for i in -steps..=steps {
        for j in -steps..=steps {
            let (gx, gy) = (cgx + j as f64 * coarse_step, cgy + i as f64 * coarse_step);
            if ((gx - cgx).powi(2) + (gy - cgy).powi(2)).sqrt() > t0.search_radius() {
                continue;
            }
            model.sample(gx, gy, &mut s, false);
            coarse_pos.push((gx, gy));
            coarse_basis[0].extend_from_slice(&s.basis[0]);
            coarse_basis[1].extend_from_slice(&s.basis[1]);
        }
    }
    (coarse_pos, coarse_basis, coarse_step)
}

/// Buffers of one worker: the target tuple and weights (padded to the fast path's lane
/// width, zeros beyond K), the generic model's scratch and the fast path's buffers.
pub(crate) struct Work {
    /// Target tuple of the current pixel (first K values; the rest stay 0).
    pub t: Vec<f32>,
    w: Vec<f32>,
    /// Weights of the previous pixel (when it had lights dropped).
    prev_w: Vec<f32>,
    q: Vec<f32>,
    pub s: Scratch,
    /// Table entries to seed the next tree search with (the last pixel's candidates).
    pub seeds: Vec<u32>,
    /// The previous pixel's solution (coherence shortcut); reset at row starts and gaps.
    pub warm: Option<Warm>,
    b: Buf,
    rim: RimBuf,
    /// ‖t‖ of the current pixel.
    norm: f32,
    /// `q` holds the current pixel's projected query.
    projected: bool,
    /// `seeds` holds the current pixel's tree candidates (the `candidates` entries
    /// nearest to its query: the same whichever search found them).
    candidates: bool,
    /// The fast path's buffer holds the current fit's tuple.
    fresh: bool,
    /// The last fast refinement's result position and its final step not taken
    /// (`fused::Point::step`): the warm start extrapolates from position + step.
    settled: (f64, f64, [f64; 2]),
    /// The window pixel of the certificate's corner of the last fast refinement's result
    /// and the squared distance of the current pixel's tuple to it (`fused::Point`);
    /// `u32::MAX` when there is none for this pixel.
    corner: (u32, f32),
}

impl Work {
    pub fn new(k: usize) -> Self {
        let kp = fused::padded(k);
        Work {
            t: vec![0.0; kp],
            w: vec![0.0; kp],
            prev_w: vec![0.0; kp],
            q: vec![0.0; k + 8],
            s: Scratch::new(k),
            seeds: Vec::with_capacity(index::MAX_CANDIDATES),
            warm: None,
            b: Buf::new(k),
            rim: RimBuf::new(k),
            norm: 0.0,
            projected: false,
            candidates: false,
            fresh: false,
            settled: (f64::NAN, f64::NAN, [0.0; 2]),
            corner: (u32::MAX, f32::INFINITY),
        }
    }
}

/// Everything shared by the workers of one target: the model, the options and the
/// target-independent [`Prep`] they borrow.
pub(crate) struct Solver<'a> {
    pub model: Model<'a>,
    pub opts: &'a Options,
    /// Index over table 0's entries (single table only).
    index: Option<&'a Index>,
    /// Fused refinement (single table only).
    single: Option<Single<'a>>,
    /// Weights 1 for the K lights, 0 for the padding.
    ones: Vec<f32>,
    /// Table 0's entry at each window pixel (row-major), `u32::MAX` where none.
    entries_at: &'a [u32],
    /// Coarse grid: positions and the tables' tuples there.
    coarse_pos: &'a [(f64, f64)],
    coarse_basis: &'a [Vec<f32>; 2],
    coarse_step: f64,
    /// Brightness scale of each table (largest sample).
    peaks: [f32; 2],
    /// Each light's floor (black level), padded with zeros: "dark" is measured above it,
    /// and the outline's coverage divides the light above it (`lut::coverage_refit`).
    pub floors: &'a [f32],
    /// The table's extension past its last clean ring (one table, refined lookup).
    rim: Option<RimGate<'a>>,
    /// Isolation radius of each entry as f32 bits, computed when first needed
    /// (`certify::UNSET` before; see `certified`; one table, refined lookup).
    isolation: &'a [AtomicU32],
    /// The coarse grid in the mixture's scan layout (two tables only).
    mixture: Option<&'a mixture::Scan>,
    /// The mixture runs its exhaustive search at every pixel (no warm start; tests).
    exhaustive_only: bool,
}

impl<'a> Solver<'a> {
    /// The solver of one target on the prepared `prep` (built from the same model and
    /// options).
    pub fn with(model: Model<'a>, opts: &'a Options, prep: &'a Prep) -> Self {
        let k = model.k;
        let single = (!model.is_mix()).then(|| Single::new(&model.tables[0], opts.normalize));
        let mut ones = vec![0.0; fused::padded(k)];
        ones[..k].fill(1.0);
        let rim = prep
            .rim
            .as_ref()
            .map(|rim| RimGate::new(rim, &model.tables[0]));
        Solver {
            model,
            opts,
            index: prep.index.as_ref(),
            single,
            ones,
            entries_at: &prep.entries_at,
            coarse_pos: &prep.coarse_pos,
            coarse_basis: &prep.coarse_basis,
            coarse_step: prep.coarse_step,
            peaks: prep.peaks,
            floors: &prep.floors,
            rim,
            isolation: &prep.isolation,
            mixture: prep.mixture.as_ref(),
            exhaustive_only: false,
        }
    }

    /// Table 0's entry at window pixel (r, c), `u32::MAX` where none.
    fn entry_at(&self, r: usize, c: usize) -> u32 {
        let w = self.model.tables[0].window.stack.width;
        if c < w {
            self.entries_at.get(r * w + c).copied().unwrap_or(u32::MAX)
        } else {
            u32::MAX
        }
    }

    /// Grid position of table entry `e`.
    fn entry_grid(&self, e: u32) -> (f64, f64) {
        let t0 = &self.model.tables[0];
        let [r, c] = t0.entries.pixels[e as usize];
        (
            c as f64 - t0.window.col0 as f64,
            r as f64 - t0.window.row0 as f64,
        )
    }

    /// Solve the pixel whose samples are in `wk.t`; `wk.seeds` holds the previous
    /// pixel's candidates and `wk.warm` its solution.
    pub fn pixel(&self, wk: &mut Work) -> PixelOut {
        let k = self.model.k;
        wk.norm = norm2(&wk.t).sqrt();
        wk.fresh = false;
        wk.projected = false;
        wk.corner.0 = u32::MAX;
        wk.candidates = false;
        if let (Some(index), Method::InverseDistance { neighbours }) =
            (&self.index, self.opts.method)
        {
            return self.inverse_distance(index, neighbours, wk);
        }
        let (fit, shadowed) = match self.shadowed_warm_start(wk) {
            Some(found) => found,
            None => {
                let fit = self.first_fit(wk);
                wk.w[..k].fill(1.0);
                if self.opts.method == Method::Refined {
                    self.drop_shadowed(fit, wk)
                } else {
                    (fit, 0)
                }
            }
        };
        self.update_warm(&fit, shadowed, wk);
        let fit = self.rim_fit(fit, wk);
        let mut out = self.finish(&wk.t[..k], &wk.w[..k], fit, shadowed, wk.norm);
        if self.model.is_mix() {
            let sigma = self
                .model
                .weight_sigma(&wk.t[..k], &wk.w[..k], &fit, &mut wk.s);
            out.weight_sigma = sigma;
            // the split's specular weight is unidentifiable away from highlights, which
            // says nothing about the normal
            let sigma = if self.opts.split_specular { 0.0 } else { sigma };
            let factor = 1.0 / (1.0 + (sigma / self.opts.weight_scale).powi(2));
            out.confidence *= if factor.is_finite() { factor } else { 0.0 };
        }
        out
    }

    /// The fit on all lights: coherence shortcut under the global check (one table), or
    /// the exhaustive search (two tables).
    fn first_fit(&self, wk: &mut Work) -> Fit {
        match (&self.index, self.opts.method) {
            (Some(index), Method::Refined) => self.checked_fit(index, wk),
            (Some(index), _) => self.tree_match(index, None, false, wk),
            (None, _) => self.mixture_first_fit(wk),
        }
    }

    /// Coherence shortcut under the global check (module docs, step 1): Gauss–Newton
    /// from the previous pixel's solution extrapolated by its step, kept with the
    /// certificate, or when a branch and bound over the index finds no table entry that
    /// fits better. Otherwise (or when that search runs over its budget) the tree's
    /// candidates for this pixel are re-ranked on the full cost: the shortcut is kept
    /// when it fits at least as well as the best candidate and that candidate lies within
    /// [`SAME_BASIN`] of it; otherwise the refinement from the best entry found runs and
    /// the better of the two fits is kept. Every pixel therefore fits at least as well as
    /// its own tree search, whatever its neighbours did.
    fn checked_fit(&self, index: &Index, wk: &mut Work) -> Fit {
        let warm = wk.warm.map(|w| {
            let start = Fit {
                gx: w.gx + w.dgx,
                gy: w.gy + w.dgy,
                coef: [1.0, 0.0],
                cost: f32::INFINITY,
            };
            self.refine(false, start, wk)
        });
        if let Some(f) = warm.filter(|f| self.certified(index, f, wk)) {
            wk.s.rel_ref = relative_to(wk.norm, f.cost);
            return f;
        }
        // without the certificate, a bounded search for any entry that fits better
        let tree = match warm.map(|f| (f, self.better_entry(index, &f, wk))) {
            Some((f, Some(None))) => {
                wk.s.rel_ref = relative_to(wk.norm, f.cost);
                return f;
            }
            Some((_, Some(Some(e)))) => e,
            _ => self.tree_match(index, warm.as_ref(), false, wk),
        };
        if let Some(f) = warm {
            if f.cost <= tree.cost && same_basin(&f, &tree) {
                wk.s.rel_ref = relative_to(wk.norm, f.cost);
                return f;
            }
        }
        let g = self.refine(false, tree, wk);
        let fit = match warm {
            Some(f) if f.cost < g.cost => {
                wk.fresh = false;
                f
            }
            _ => g,
        };
        wk.s.rel_ref = relative_to(wk.norm, fit.cost);
        if wk.warm.is_none() {
            wk.warm = Some(Warm::at(fit.gx, fit.gy));
        }
        fit
    }

    /// A fit beyond `Rim::tried_below` refitted on the rim model (see `fit/rim.rs`), with
    /// the same lights, when it lies at the table's edge or is worse than [`WARM_FLOOR`];
    /// kept when its residual is lower.
    fn rim_fit(&self, fit: Fit, wk: &mut Work) -> Fit {
        let Some(gate) = &self.rim else {
            return fit;
        };
        let (cgx, cgy) = gate.centre;
        let d2 = (fit.gx - cgx).powi(2) + (fit.gy - cgy).powi(2);
        if d2 < gate.clear2 {
            return fit;
        }
        let t0 = &self.model.tables[0];
        let n0 = t0.grid_normal(fit.gx, fit.gy);
        if f64::from(n0[2]) > gate.tried_below {
            return fit;
        }
        // inside the table's edge, a fit already within the coherence tests' floor is
        // left alone: the refit could not improve it measurably, and a third of a
        // sphere's pixels lie beyond `tried_below` (refitting them all slowed the
        // prepared lookup of `benches/sklearn_lookup.py` by a quarter)
        let at_edge = d2.sqrt() >= t0.search_radius() - RIM_TRIGGER;
        if !at_edge && relative_to(wk.norm, fit.cost) <= WARM_FLOOR {
            return fit;
        }
        let k = self.model.k;
        let (t, w) = (&wk.t[..k], &wk.w[..k]);
        let (theta, phi, c, cost) = gate.rim.solve(t, w, n0, self.opts.normalize, &mut wk.rim);
        if cost < fit.cost {
            wk.fresh = false;
            Rim::to_fit(t0, theta, phi, c, cost)
        } else {
            fit
        }
    }

    /// Remember this pixel's solution for the next one.
    fn update_warm(&self, fit: &Fit, shadowed: u16, wk: &mut Work) {
        let Some(warm) = wk.warm.as_mut() else {
            return;
        };
        let (sx, sy, step) = wk.settled;
        // the refinement's estimate of the minimum, when `fit` is its result
        let (gx, gy) = if sx == fit.gx && sy == fit.gy {
            (fit.gx + step[0], fit.gy + step[1])
        } else {
            (fit.gx, fit.gy)
        };
        if shadowed == 0 {
            let (dx, dy) = (gx - warm.gx, gy - warm.gy);
            // extrapolate only small, smooth steps (and not out of a shadow)
            let smooth = !warm.masked && dx * dx + dy * dy <= MAX_EXTRAPOLATION.powi(2);
            (warm.dgx, warm.dgy) = if smooth { (dx, dy) } else { (0.0, 0.0) };
            warm.masked = false;
        } else if self.single.is_some() {
            (warm.dgx, warm.dgy) = (0.0, 0.0);
            warm.masked = true;
            wk.prev_w.copy_from_slice(&wk.w);
        } else {
            // the mixture: its search checks any start, so only the step is forgotten
            (warm.dgx, warm.dgy) = (0.0, 0.0);
            warm.masked = false;
        }
        (warm.gx, warm.gy) = (gx, gy);
    }

    /// The model tuple of `fit` into `wk.s.pred` (from the fast path's buffer when it
    /// holds that fit).
    fn predict(&self, fit: &Fit, wk: &mut Work) {
        match (&self.single, wk.fresh) {
            (Some(single), true) => single.prediction(fit.coef[0], &wk.b, &mut wk.s.pred),
            _ => self.model.predict(fit, &mut wk.s),
        }
    }

    /// Gauss–Newton refinement from `start` with the weights in `wk.w` (`weighted`) or
    /// all lights, by the
    /// fused single-table path when there is one table; returns `start` when its cost is
    /// lower than that of the refinement.
    fn refine(&self, weighted: bool, start: Fit, wk: &mut Work) -> Fit {
        self.refine_after_pattern(weighted, start, 0.0, wk)
    }

    /// [`Solver::refine`] after a pattern search from `start` with a first step of
    /// `pattern` px ([`Model::descend`]; 0: none).
    fn refine_after_pattern(&self, weighted: bool, start: Fit, pattern: f64, wk: &mut Work) -> Fit {
        let k = self.model.k;
        let iters = self.opts.max_iterations;
        let Some(single) = &self.single else {
            wk.fresh = false;
            let (t, s) = (&wk.t[..k], &mut wk.s);
            let w = weighted.then_some(&wk.w[..k]);
            let start = if pattern > 0.0 {
                let at = self.model.eval(t, w, start.gx, start.gy, s);
                self.model.descend(t, w, at, pattern, s)
            } else {
                start
            };
            return self.model.refine(t, w, start, iters, s);
        };
        let weights = weighted.then_some(&wk.w[..]);
        let from = Start {
            gx: start.gx,
            gy: start.gy,
            pattern,
        };
        let (p, fresh) = single.refine(&wk.t, weights, from, iters, &mut wk.b);
        if p.cost > start.cost {
            wk.fresh = false;
            return start;
        }
        wk.fresh = fresh;
        wk.settled = (p.gx, p.gy, p.step);
        wk.corner = (p.corner, p.corner_d2);
        p.fit()
    }

    /// Brightness below which a target sample counts as dark, for a fit.
    fn level(&self, fit: &Fit) -> f32 {
        let reference = fit.coef[0] * self.peaks[0] + fit.coef[1] * self.peaks[1];
        self.opts.shadow_level * reference
    }

    /// Normal, residual and confidence of a final fit; `norm` is ‖t‖ (the weights are all 1 when no light is `shadowed`).
    fn finish(&self, t: &[f32], w: &[f32], fit: Fit, shadowed: u16, norm: f32) -> PixelOut {
        let (used, energy) = if shadowed == 0 {
            (t.len().max(1) as f32, norm * norm)
        } else {
            let energy: f32 = t.iter().zip(w).map(|(t, w)| w * t * t).sum();
            (w.iter().sum::<f32>().max(1.0), energy)
        };
        let rms_r = (fit.cost.max(0.0) / used).sqrt();
        let rms_t = (energy / used).sqrt();
        let level = self.level(&fit);
        // branch-free, so that the count over the lights is vectorised
        let lit: u32 = (t.iter().zip(self.floors))
            .map(|(&v, &floor)| u32::from((v - floor >= level) & (v > floor)))
            .sum();
        let lit = lit as usize;
        let rel = if rms_t > 0.0 {
            rms_r / rms_t
        } else {
            f32::INFINITY
        };
        let mut conf = 1.0 / (1.0 + (rel / self.opts.residual_scale).powi(2));
        if lit < self.opts.min_lit_lights {
            conf *= 0.25 * lit as f32 / self.opts.min_lit_lights as f32;
        }
        let mut normal = self.model.tables[0].grid_normal(fit.gx, fit.gy);
        if normal.iter().any(|v| !v.is_finite()) {
            normal = [0.0, 0.0, 1.0];
            conf = 0.0;
        }
        PixelOut {
            normal,
            confidence: if conf.is_finite() { conf } else { 0.0 },
            residual: rms_r,
            coef: fit.coef,
            weight_sigma: 0.0,
            shadowed,
            lit: lit as u16,
        }
    }
}
