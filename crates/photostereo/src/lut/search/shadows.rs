//! Cast shadows (step 4 of the method in [`crate::lut`]): lights where the target is
//! dark but its match is lit are dropped and the match is redone on the others; next to
//! a pixel with dropped lights the fit starts from its solution with the same lights
//! dropped.

use super::{same_basin, Fit, Solver, Work, WARM_FLOOR};

impl Solver<'_> {
    /// Cast shadows (module docs, step 4): drop the lights where the target is dark but
    /// the model of `fit` is lit and search again, up to 3 rounds. Returns the fit and the
    /// number of dropped lights (weights in `wk.w`).
    pub(super) fn drop_shadowed(&self, mut fit: Fit, wk: &mut Work) -> (Fit, u16) {
        let k = self.model.k;
        if let (Some(single), true) = (&self.single, wk.fresh) {
            // the first round's test on the fast path's buffer: usually nothing to drop
            let level = self.level(&fit);
            if !single.any_dark_lit(&wk.t, self.floors, fit.coef[0], level, &wk.b) {
                return (fit, 0);
            }
        }
        let mut shadowed = 0u16;
        for _round in 0..3 {
            self.predict(&fit, wk);
            let level = self.dark_level(&fit, wk);
            let mut new = false;
            let (t, w, pred) = (&wk.t[..k], &mut wk.w[..k], &wk.s.pred[..k]);
            for i in 0..k {
                if w[i] > 0.0 && self.dark_lit(i, t[i], pred[i], level) {
                    w[i] = 0.0;
                    shadowed += 1;
                    new = true;
                }
            }
            if !new || (k as u16 - shadowed) < 2 {
                break;
            }
            fit = self.masked_search(fit, wk);
        }
        (fit, shadowed)
    }

    /// Light `i` is cast-shadowed: the target's sample `t` is within `level` of the
    /// light's floor (black level) while the model's `pred` is lit above it.
    #[inline]
    fn dark_lit(&self, i: usize, t: f32, pred: f32, level: f32) -> bool {
        crate::lut::cast_shadowed(t, self.floors[i], pred, level)
    }

    /// Dark level of `fit` whose model tuple is in `wk.s.pred`.
    pub(super) fn dark_level(&self, fit: &Fit, wk: &Work) -> f32 {
        if self.model.is_mix() {
            self.model.mix_dark_level(self.opts.shadow_level, &wk.s)
        } else {
            self.level(fit)
        }
    }

    /// Coherence for cast shadows (one table): when the previous pixel had lights
    /// dropped, fit this one from its solution with the same lights dropped, then
    /// re-derive the dropped set at the new fit (a light is dropped when the target is
    /// dark there and the model lit, as in step 4) and refit until the set is stable (up
    /// to 3 fits). Accepted when the relative residual on the lights kept passes the
    /// coherence test; otherwise `None` and the full search runs.
    pub(super) fn shadowed_warm_start(&self, wk: &mut Work) -> Option<(Fit, u16)> {
        let k = self.model.k;
        let warm = wk.warm.filter(|w| w.masked && self.single.is_some())?;
        let (kp, w) = (wk.w.len(), &mut wk.w);
        w.copy_from_slice(&wk.prev_w[..kp]);
        let mut fit = Fit {
            gx: warm.gx,
            gy: warm.gy,
            coef: [1.0, 0.0],
            cost: f32::INFINITY,
        };
        for _ in 0..3 {
            fit = self.refine(true, fit, wk);
            let (t, w) = (&wk.t[..k], &wk.w[..k]);
            let energy: f32 = t.iter().zip(w).map(|(t, w)| w * t * t).sum();
            if energy <= 0.0
                || fit.cost.max(0.0) > energy * (1.5 * wk.s.rel_ref).max(WARM_FLOOR).powi(2)
            {
                return None;
            }
            self.predict(&fit, wk);
            let level = self.dark_level(&fit, wk);
            let (t, w, pred) = (&wk.t[..k], &mut wk.w[..k], &wk.s.pred[..k]);
            let (mut changed, mut shadowed) = (false, 0u16);
            for i in 0..k {
                let lit = !self.dark_lit(i, t[i], pred[i], level);
                changed |= lit != (w[i] > 0.0);
                w[i] = if lit { 1.0 } else { 0.0 };
                shadowed += (!lit) as u16;
            }
            if (k as u16 - shadowed) < 2 {
                return None;
            }
            if !changed {
                // the global check, on the lights kept (module docs, step 4)
                let index = self.index.as_ref()?;
                let best = self.tree_match(index, Some(&fit), true, wk);
                if fit.cost > best.cost {
                    return None;
                }
                if same_basin(&fit, &best) {
                    return Some((fit, shadowed));
                }
                // a basin elsewhere whose best entry fits worse than `fit` is refined,
                // as in step 1: `fit` is kept when it still fits at least as well
                let other = self.refine(true, best, wk);
                wk.fresh = false;
                return (other.cost >= fit.cost).then_some((fit, shadowed));
            }
            fit.cost = f32::INFINITY;
        }
        None
    }

    /// Search with the lights of weight 0 in `wk.w` dropped: first locally from `from`
    /// (pattern descent from 4 px, Gauss–Newton), accepted when its relative residual
    /// passes the coherence test; otherwise the exhaustive search, keeping the better of
    /// the two.
    pub(super) fn masked_search(&self, from: Fit, wk: &mut Work) -> Fit {
        if self.model.is_mix() {
            return self.mixture_fit(true, Some(from), wk);
        }
        let k = self.model.k;
        // `from`'s cost is on all lights: not a bound for the search on fewer
        let start = Fit {
            cost: f32::INFINITY,
            ..from
        };
        let local = self.refine_after_pattern(true, start, 4.0, wk);
        let (t, w) = (&wk.t[..k], &wk.w[..k]);
        let energy: f32 = t.iter().zip(w).map(|(t, w)| w * t * t).sum();
        let rel = if energy > 0.0 {
            (local.cost.max(0.0) / energy).sqrt()
        } else {
            f32::INFINITY
        };
        if !self.model.is_mix()
            && rel <= (1.5 * wk.s.rel_ref).max(WARM_FLOOR)
            && local.cost <= self.best_of_seeds(true, wk).cost
        {
            return local;
        }
        let global = self.exhaustive(true, wk);
        if global.cost < local.cost {
            global
        } else {
            wk.fresh = false;
            local
        }
    }
}
