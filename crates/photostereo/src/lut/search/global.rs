//! The searches over the whole table: the tree's nearest entries re-ranked on the full
//! cost (steps 1 and 4 of the method in [`crate::lut`]), the exhaustive search on the
//! coarse grid, and the inverse-distance baseline.

use super::{Fit, Index, Solver, Work, COARSE_KEEP};
use crate::image::normalize;
use crate::lut::output::PixelOut;

impl Solver<'_> {
    /// Nearest entries in the index (the `candidates` nearest in the projected space),
    /// re-ranked on the full K-dimensional cost with the weights in `wk.w` (`weighted`)
    /// or all lights; the best one as a fit. The search is seeded with the previous pixel's
    /// candidates, or with the entries around `near` when checking a fit (seeds only
    /// speed the search up: the candidates are the same); it is not run again when this
    /// pixel's candidates are known already (the masked shortcut's check found them).
    pub(super) fn tree_match(
        &self,
        index: &Index,
        near: Option<&Fit>,
        weighted: bool,
        wk: &mut Work,
    ) -> Fit {
        if wk.candidates {
            return self.best_of_seeds(weighted, wk);
        }
        self.query(index, wk);
        if let Some(f) = near {
            wk.seeds.clear();
            let (c0, r0) = (
                f.gx.floor().max(0.0) as usize,
                f.gy.floor().max(0.0) as usize,
            );
            for (dr, dc) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let e = self.entry_at(r0 + dr, c0 + dc);
                if e != u32::MAX {
                    wk.seeds.push(e);
                }
            }
        }
        let cands = index.nearest(&wk.q[..index.dims()], self.opts.candidates, &wk.seeds);
        wk.seeds.clear();
        wk.seeds.extend_from_slice(&cands.ids[..cands.len]);
        wk.candidates = true;
        self.best_of_seeds(weighted, wk)
    }

    /// The entry of `wk.seeds` (the last tree search's candidates) that fits the target
    /// best with the weights in `wk.w` (`weighted`) or all lights, as a fit.
    pub(super) fn best_of_seeds(&self, weighted: bool, wk: &Work) -> Fit {
        let k = self.model.k;
        let t = &wk.t[..k];
        let w = weighted.then_some(&wk.w[..k]);
        let mut best = (f32::INFINITY, [1.0, 0.0], u32::MAX);
        for &e in &wk.seeds {
            let tuple = &self.model.tables[0].entries.tuples[e as usize * k..(e as usize + 1) * k];
            let (coef, cost) = self.model.fit_with(t, w, tuple, tuple);
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

    /// The current pixel's (normalised when asked) tuple projected into the index's
    /// space (computed once per pixel, kept in `wk.q`).
    pub(super) fn query<'q>(&self, index: &Index, wk: &'q mut Work) -> &'q [f32] {
        let d = index.dims();
        if wk.projected {
            return &wk.q[..d];
        }
        wk.projected = true;
        let t = &wk.t[..self.model.k];
        let (qd, rest) = wk.q.split_at_mut(d);
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

    /// Exhaustive search on the coarse grid with the weights in `wk.w` (`weighted`) or
    /// all lights, then pattern descent from the best few and Gauss–Newton from the best of
    /// those.
    pub(super) fn exhaustive(&self, weighted: bool, wk: &mut Work) -> Fit {
        let k = self.model.k;
        let t = &wk.t[..k];
        let w = weighted.then_some(&wk.w[..k]);
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
        let start = self.best_descent(weighted, &keep, wk);
        self.refine(weighted, start, wk)
    }

    /// Pattern descent from each kept coarse point (finite cost) down to half a pixel;
    /// the best of those, or the first coarse point when none is kept: the start of the
    /// refinement, for the single table's and the mixture's exhaustive searches.
    pub(super) fn best_descent(&self, weighted: bool, keep: &[(f32, usize)], wk: &mut Work) -> Fit {
        let k = self.model.k;
        let (t, s) = (&wk.t[..k], &mut wk.s);
        let w = weighted.then_some(&wk.w[..k]);
        let mut best: Option<Fit> = None;
        for &(_, j) in keep.iter().filter(|c| c.0.is_finite()) {
            let (gx, gy) = self.coarse_pos[j];
            let start = self.model.eval(t, w, gx, gy, s);
            let f = self.model.descend(t, w, start, self.coarse_step / 2.0, s);
            if best.is_none_or(|b| f.cost < b.cost) {
                best = Some(f);
            }
        }
        best.unwrap_or_else(|| {
            let (gx, gy) = self.coarse_pos[0];
            self.model.eval(t, w, gx, gy, s)
        })
    }

    /// The baseline: normals of the m nearest entries averaged with weights 1/distance.
    pub(super) fn inverse_distance(&self, index: &Index, m: usize, wk: &mut Work) -> PixelOut {
        let k = self.model.k;
        self.query(index, wk);
        let cands = index.nearest(&wk.q[..index.dims()], m, &wk.seeds);
        wk.seeds.clear();
        wk.seeds.extend_from_slice(&cands.ids[..cands.len]);
        let (t, s) = (&wk.t[..k], &mut wk.s);
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
        let mut out = self.finish(t, &self.ones[..k], fit, 0, wk.norm);
        out.normal = normalize(acc);
        out
    }
}
