//! The per-pixel pipeline: candidate search, re-ranking, refinement, cast shadows and
//! confidence (see the parent module for the method).

use super::index::Index;
use super::model::{Fit, Model, Scratch};
use super::{Method, Options};
use crate::image::normalize;

/// Target number of points of the coarse grid used by the exhaustive searches.
const COARSE_POINTS: usize = 1500;
/// Coarse candidates kept for the local descent.
const COARSE_KEEP: usize = 3;

/// Longest run of pixels matched by the coherence shortcut between two tree searches.
const WARM_RUN: u32 = 16;
/// Relative residual always accepted by the coherence tests.
const WARM_FLOOR: f32 = 0.003;

/// The previous pixel's solution, for the coherence shortcut.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Warm {
    pub gx: f64,
    pub gy: f64,
    /// Pixels matched by the shortcut since.
    pub since_tree: u32,
}

/// √cost / ‖t‖.
fn relative(t: &[f32], cost: f32) -> f32 {
    let norm = t.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm > 0.0 {
        cost.max(0.0).sqrt() / norm
    } else {
        f32::INFINITY
    }
}

/// Result at one pixel.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PixelOut {
    pub normal: [f32; 3],
    pub confidence: f32,
    pub residual: f32,
    pub coef: [f32; 2],
    /// Standard error of the mixture weights (two tables only).
    pub weight_sigma: f32,
    pub shadowed: u16,
    pub lit: u16,
}

/// Everything shared by the workers.
pub(crate) struct Solver<'a> {
    pub model: Model<'a>,
    pub opts: &'a Options,
    /// Index over table 0's entries (single table only).
    index: Option<Index>,
    /// Coarse grid: positions and the tables' tuples there.
    coarse_pos: Vec<(f64, f64)>,
    coarse_basis: [Vec<f32>; 2],
    coarse_step: f64,
    /// Brightness scale of each table (largest sample).
    peaks: [f32; 2],
}

impl<'a> Solver<'a> {
    pub fn new(model: Model<'a>, opts: &'a Options) -> Self {
        let t0 = &model.tables[0];
        let k = model.k;
        let n = t0.entries.len();
        let mut ranked = t0.entries.tuples.clone();
        let mut keep = vec![true; n];
        if opts.normalize {
            for (e, tuple) in ranked.chunks_exact_mut(k).enumerate() {
                let norm = tuple.iter().map(|v| v * v).sum::<f32>().sqrt();
                keep[e] = norm > 1e-6;
                tuple.iter_mut().for_each(|v| *v /= norm.max(1e-6));
            }
        }
        let index = (!model.is_mix()).then(|| {
            let dims = match opts.method {
                Method::InverseDistance { .. } => k,
                _ => opts.pca_dims,
            };
            Index::build(&ranked, k, &keep, dims)
        });
        let area = std::f64::consts::PI * t0.search_radius().powi(2);
        let coarse_step = (area / COARSE_POINTS as f64).sqrt().max(1.0).floor();
        let mut s = Scratch::new(k);
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
        let peaks = [t0.peak(), model.tables.get(1).map_or(0.0, |t| t.peak())];
        Solver {
            model,
            opts,
            index,
            coarse_pos,
            coarse_basis,
            coarse_step,
            peaks,
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

    /// Solve one pixel with samples `t`; `s.seeds` holds the previous pixel's candidates.
    /// `q` needs K + 8 values and `w` K values of scratch space.
    pub fn pixel(&self, t: &[f32], s: &mut Scratch, q: &mut [f32], w: &mut [f32]) -> PixelOut {
        let k = self.model.k;
        let mut fit = match (&self.index, self.opts.method) {
            (Some(index), Method::InverseDistance { neighbours }) => {
                return self.inverse_distance(t, index, neighbours, q, s);
            }
            (Some(index), Method::Refined) => match self.warm_start(t, s) {
                Some(fit) => fit,
                None => {
                    let fit = self.tree_match(t, index, q, s);
                    let fit = self.model.refine(t, None, fit, self.opts.max_iterations, s);
                    s.rel_ref = relative(t, fit.cost);
                    s.warm = Some(Warm {
                        gx: fit.gx,
                        gy: fit.gy,
                        since_tree: 0,
                    });
                    fit
                }
            },
            (Some(index), _) => self.tree_match(t, index, q, s),
            (None, _) => self.exhaustive(t, None, s),
        };
        w.fill(1.0);
        let mut shadowed = 0u16;
        if self.opts.method == Method::Refined {
            for _round in 0..3 {
                self.model.predict(&fit, s);
                let level = if self.model.is_mix() {
                    self.model.mix_dark_level(self.opts.shadow_level, s)
                } else {
                    self.level(&fit)
                };
                let mut new = false;
                for i in 0..k {
                    if w[i] > 0.0 && t[i] < level && s.pred[i] > t[i] + level {
                        w[i] = 0.0;
                        shadowed += 1;
                        new = true;
                    }
                }
                if !new || (k as u16 - shadowed) < 2 {
                    break;
                }
                fit = self.masked_search(t, w, fit, s);
            }
        }
        match (&mut s.warm, shadowed) {
            (Some(warm), 0) => (warm.gx, warm.gy) = (fit.gx, fit.gy),
            _ => s.warm = None,
        }
        let mut out = self.finish(t, w, fit, shadowed);
        if self.model.is_mix() {
            let sigma = self.model.weight_sigma(t, w, &fit, s);
            out.weight_sigma = sigma;
            let factor = 1.0 / (1.0 + (sigma / self.opts.weight_scale).powi(2));
            out.confidence *= if factor.is_finite() { factor } else { 0.0 };
        }
        out
    }

    /// Coherence shortcut: Gauss–Newton from the previous pixel's solution, accepted
    /// when its relative residual is at most 1.5 × that of the last pixel matched through
    /// the tree (or 0.3%), and at most 16 pixels after that tree search.
    fn warm_start(&self, t: &[f32], s: &mut Scratch) -> Option<Fit> {
        let warm = s.warm?;
        if warm.since_tree >= WARM_RUN {
            return None;
        }
        let start = Fit {
            gx: warm.gx,
            gy: warm.gy,
            coef: [1.0, 0.0],
            cost: f32::INFINITY,
        };
        let fit = self
            .model
            .refine(t, None, start, self.opts.max_iterations, s);
        if relative(t, fit.cost) <= (1.5 * s.rel_ref).max(WARM_FLOOR) {
            if let Some(w) = s.warm.as_mut() {
                w.since_tree += 1;
            }
            Some(fit)
        } else {
            None
        }
    }

    /// Brightness below which a target sample counts as dark, for a fit.
    fn level(&self, fit: &Fit) -> f32 {
        let reference = fit.coef[0] * self.peaks[0] + fit.coef[1] * self.peaks[1];
        self.opts.shadow_level * reference
    }

    /// Nearest entries in the index, re-ranked on the full K-dimensional cost.
    fn tree_match(&self, t: &[f32], index: &Index, q: &mut [f32], s: &mut Scratch) -> Fit {
        let k = self.model.k;
        let query = self.query(t, index, q);
        let cands = index.nearest(query, self.opts.candidates, &s.seeds);
        s.seeds.clear();
        s.seeds.extend_from_slice(&cands.ids[..cands.len]);
        let mut best = (f32::INFINITY, [1.0, 0.0], u32::MAX);
        for &e in &cands.ids[..cands.len] {
            let tuple = &self.model.tables[0].entries.tuples[e as usize * k..(e as usize + 1) * k];
            let (coef, cost) = self.model.fit_with(t, None, tuple, tuple);
            if cost < best.0 {
                best = (cost, coef, e);
            }
        }
        let e = if best.2 == u32::MAX { 0 } else { best.2 };
        let (gx, gy) = self.entry_grid(e);
        Fit {
            gx,
            gy,
            coef: best.1,
            cost: best.0,
        }
    }

    /// Project the (normalised when asked) tuple into the index's space.
    fn query<'q>(&self, t: &[f32], index: &Index, q: &'q mut [f32]) -> &'q [f32] {
        let d = index.dims();
        let (qd, rest) = q.split_at_mut(d);
        if self.opts.normalize {
            let norm = t.iter().map(|v| v * v).sum::<f32>().sqrt().max(1e-12);
            for (r, v) in rest.iter_mut().zip(t) {
                *r = v / norm;
            }
            index.project(&rest[..t.len()], qd);
        } else {
            index.project(t, qd);
        }
        qd
    }

    /// Search with some lights dropped (weights `w`): first locally from `from` (pattern
    /// descent from 4 px, Gauss–Newton), accepted when its relative residual passes the
    /// coherence test; otherwise the exhaustive search, keeping the better of the two.
    fn masked_search(&self, t: &[f32], w: &[f32], from: Fit, s: &mut Scratch) -> Fit {
        let start = self.model.eval(t, Some(w), from.gx, from.gy, s);
        let local = self.model.descend(t, Some(w), start, 4.0, s);
        let local = self
            .model
            .refine(t, Some(w), local, self.opts.max_iterations, s);
        let energy: f32 = t.iter().zip(w).map(|(t, w)| w * t * t).sum();
        let rel = if energy > 0.0 {
            (local.cost.max(0.0) / energy).sqrt()
        } else {
            f32::INFINITY
        };
        if !self.model.is_mix() && rel <= (1.5 * s.rel_ref).max(WARM_FLOOR) {
            return local;
        }
        let global = self.exhaustive(t, Some(w), s);
        if global.cost < local.cost {
            global
        } else {
            local
        }
    }

    /// Exhaustive search on the coarse grid with weights `w`, then pattern descent from
    /// the best few and Gauss–Newton from the best of those.
    fn exhaustive(&self, t: &[f32], w: Option<&[f32]>, s: &mut Scratch) -> Fit {
        let k = self.model.k;
        let mut keep: [(f32, usize); COARSE_KEEP] = [(f32::INFINITY, 0); COARSE_KEEP];
        for (j, _) in self.coarse_pos.iter().enumerate() {
            let a = &self.coarse_basis[0][j * k..(j + 1) * k];
            let b = if self.model.is_mix() {
                &self.coarse_basis[1][j * k..(j + 1) * k]
            } else {
                a
            };
            let (_, cost) = self.model.fit_with(t, w, a, b);
            if cost < keep[COARSE_KEEP - 1].0 {
                keep[COARSE_KEEP - 1] = (cost, j);
                keep.sort_by(|x, y| x.0.total_cmp(&y.0));
            }
        }
        let mut best: Option<Fit> = None;
        for &(cost, j) in keep.iter().filter(|c| c.0.is_finite()) {
            let _ = cost;
            let (gx, gy) = self.coarse_pos[j];
            let start = self.model.eval(t, w, gx, gy, s);
            let f = self.model.descend(t, w, start, self.coarse_step / 2.0, s);
            if best.is_none_or(|b| f.cost < b.cost) {
                best = Some(f);
            }
        }
        let start = best.unwrap_or_else(|| {
            let (gx, gy) = self.coarse_pos[0];
            self.model.eval(t, w, gx, gy, s)
        });
        self.model.refine(t, w, start, self.opts.max_iterations, s)
    }

    /// The baseline: normals of the m nearest entries averaged with weights 1/distance.
    fn inverse_distance(
        &self,
        t: &[f32],
        index: &Index,
        m: usize,
        q: &mut [f32],
        s: &mut Scratch,
    ) -> PixelOut {
        let query = self.query(t, index, q);
        let cands = index.nearest(query, m, &s.seeds);
        s.seeds.clear();
        s.seeds.extend_from_slice(&cands.ids[..cands.len]);
        let t0 = &self.model.tables[0];
        let mut acc = [0.0f32; 3];
        for c in 0..cands.len {
            let d = cands.dist[c].sqrt();
            let n = t0.entries.normals[cands.ids[c] as usize];
            if d <= 1e-9 {
                acc = n;
                break;
            }
            (0..3).for_each(|i| acc[i] += n[i] / d);
        }
        let e = cands.ids[0];
        let (gx, gy) = self.entry_grid(e);
        let fit = self.model.eval(t, None, gx, gy, s);
        let ones = vec![1.0; t.len()];
        let mut out = self.finish(t, &ones, fit, 0);
        out.normal = normalize(acc);
        out
    }

    /// Normal, residual and confidence of a final fit.
    fn finish(&self, t: &[f32], w: &[f32], fit: Fit, shadowed: u16) -> PixelOut {
        let used: f32 = w.iter().sum::<f32>().max(1.0);
        let energy: f32 = t.iter().zip(w).map(|(t, w)| w * t * t).sum();
        let rms_r = (fit.cost.max(0.0) / used).sqrt();
        let rms_t = (energy / used).sqrt();
        let level = self.level(&fit);
        let lit = t.iter().filter(|&&v| v >= level && v > 0.0).count();
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
