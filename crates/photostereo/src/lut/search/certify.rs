//! The coherence shortcut's global check (parent module docs, step 1): the certificate
//! from the entries' isolation radii, and the branch and bound over the index when it
//! fails.

use super::{Fit, Index, Solver, Work};
use crate::lut::fit::fused::{even, nearest};
use std::sync::atomic::Ordering;

/// Grid distance (pixels) from an entry beyond which other entries count as lying
/// outside its basin, for the entries' isolation radii (see `certified`).
const ISOLATION_BASIN: f64 = 3.0;
/// Grid offsets (rows, columns) just outside [`ISOLATION_BASIN`] (3.2–3.6 px): their
/// entries seed the search for an isolation radius.
const RING: [(i64, i64); 16] = [
    (1, 3),
    (2, 3),
    (3, 1),
    (3, 2),
    (-1, 3),
    (-2, 3),
    (-3, 1),
    (-3, 2),
    (1, -3),
    (2, -3),
    (3, -1),
    (3, -2),
    (-1, -3),
    (-2, -3),
    (-3, -1),
    (-3, -2),
];
/// Bits of an isolation radius not computed yet (a NaN that `isolation_of` never stores).
pub(super) const UNSET: u32 = u32::MAX;
/// Leaves that the branch and bound of an uncertified shortcut may visit: when its
/// initial search ball meets more, the pixel goes through the plain tree search instead.
const BOUND_LEAVES: usize = 48;

impl Solver<'_> {
    /// The isolation radius of entry `e`: the projected distance to the nearest entry
    /// more than [`ISOLATION_BASIN`] px away on the grid (an exact nearest-neighbour
    /// search that skips the entries within it).
    /// Computed on first use and cached: only the entries that certify some pixel's fit
    /// are ever searched (racing workers store the same value).
    fn isolation_of(&self, index: &Index, e: u32) -> f32 {
        let slot = &self.isolation[e as usize];
        let bits = slot.load(Ordering::Relaxed);
        if bits != UNSET {
            return f32::from_bits(bits);
        }
        let (gx, gy) = self.entry_grid(e);
        let rho = match index.point(e) {
            None => 0.0,
            Some(p) => {
                let far = |id: u32| {
                    let (x, y) = self.entry_grid(id);
                    (x - gx).powi(2) + (y - gy).powi(2) > ISOLATION_BASIN * ISOLATION_BASIN
                };
                // infinite when every indexed entry is within the basin; the entries on
                // a ring just outside it seed the search (they only speed it up)
                let (r, c) = (gy as i64, gx as i64);
                let seeds = RING.iter().filter_map(|&(dr, dc)| {
                    let (r, c) = (r + dr, c + dc);
                    let inside = r >= 0 && c >= 0;
                    inside.then(|| self.entry_at(r as usize, c as usize))
                });
                index.nearest_where(p, seeds, far).0.max(0.0).sqrt()
            }
        };
        slot.store(rho.to_bits(), Ordering::Relaxed);
        rho
    }

    /// Compute the isolation radius of every entry at an even grid point (even row and
    /// column: the first anchors of [`Solver::certified`]), in parallel. The second
    /// anchors (any grid point) are needed by few pixels and are computed when first
    /// needed: filling them all here made four times as many searches.
    pub(super) fn fill_isolation(&self) {
        use rayon::prelude::*;
        let Some(index) = self.index else {
            return;
        };
        let pixels = &self.model.tables[0].entries.pixels;
        (0..pixels.len() as u32)
            .into_par_iter()
            .with_min_len(256)
            .filter(|&e| {
                let (gx, gy) = self.entry_grid(e);
                (gx as i64) % 2 == 0 && (gy as i64) % 2 == 0
            })
            .for_each(|e| {
                self.isolation_of(index, e);
            });
    }

    /// The certificate of the coherence shortcut (module docs, step 1): no table entry
    /// more than [`ISOLATION_BASIN`] + 1.5 px from `f` fits the target better. With e₀
    /// an anchor entry at a grid point next to `f` and ρ(e₀) its isolation radius (the
    /// projected distance to the nearest entry more than [`ISOLATION_BASIN`] px away on
    /// the grid), every such entry lies at least ρ(e₀) − ‖q − e₀‖ from the query q in
    /// the projected space, and the projected distance d bounds the cost from below
    /// (raw matching: cost ≥ d²; normalised: cost ≥ ‖t‖²·min(1, d²/2)). The anchor is
    /// first the even grid point (even row and column) nearest to `f`, whose distance
    /// the refinement measured with its cell; then, where the table's tuples change
    /// much faster one way than the other (around highlights: ρ small for the even
    /// point's offset of up to √2 px), the grid point nearest to `f` (at most 0.71 px).
    pub(super) fn certified(&self, index: &Index, f: &Fit, wk: &mut Work) -> bool {
        // cheap test first: with ρ = ∞ the bound is the largest it can be
        if self.lower_bound(wk.norm, f32::INFINITY) < f.cost {
            return false;
        }
        let even_anchor = (even(f.gy), even(f.gx));
        let near = (nearest(f.gy), nearest(f.gx));
        self.certified_at(index, f, even_anchor, wk)
            || (near != even_anchor && self.certified_at(index, f, near, wk))
    }

    /// The certificate of `f` with the entry at window pixel (r0, c0) as anchor.
    fn certified_at(
        &self,
        index: &Index,
        f: &Fit,
        (r0, c0): (usize, usize),
        wk: &mut Work,
    ) -> bool {
        let e0 = self.entry_at(r0, c0);
        if e0 == u32::MAX {
            return false;
        }
        let rho = self.isolation_of(index, e0);
        // the projection is orthogonal, so the full K-dimensional distance bounds the
        // projected one from above: a cheaper test first (no projection of the query)
        if self.lower_bound(wk.norm, rho - self.corner_distance(wk, r0, c0)) >= f.cost {
            return true;
        }
        let d = index.distance(self.query(index, wk), e0).sqrt();
        self.lower_bound(wk.norm, rho - d) >= f.cost
    }

    /// [`Solver::full_distance`], taken from the refinement's evaluation when it computed
    /// it for that window pixel and this pixel's tuple (raw matching).
    fn corner_distance(&self, wk: &Work, r: usize, c: usize) -> f32 {
        let w = self.model.tables[0].window.stack.width;
        if c < w && wk.corner.0 as usize == r * w + c {
            wk.corner.1.max(0.0).sqrt()
        } else {
            self.full_distance(wk, r, c)
        }
    }

    /// Distance in the index's full K-dimensional space (tuples normalised when
    /// matching is) from the current pixel's tuple to that of the entry at window pixel
    /// (r, c): ≥ the projected one. The tuple is read from the window (the same values
    /// as the entry's, next to those the refinement just read).
    fn full_distance(&self, wk: &Work, r: usize, c: usize) -> f32 {
        let k = self.model.k;
        let t = &wk.t[..k];
        let tuple = self.model.tables[0].window.stack.pixel(r, c);
        let (st, se) = if self.opts.normalize {
            let ne = tuple.iter().map(|v| v * v).sum::<f32>().sqrt();
            (1.0 / wk.norm.max(1e-12), 1.0 / ne.max(1e-6))
        } else {
            (1.0, 1.0)
        };
        // eight partial sums, which the compiler vectorises
        let mut acc = [0.0f32; 8];
        let (tc, ec) = (t.chunks_exact(8), tuple.chunks_exact(8));
        let tail = tc.remainder().iter().zip(ec.remainder());
        for (a8, b8) in tc.zip(ec) {
            for ((acc, a), b) in acc.iter_mut().zip(a8).zip(b8) {
                *acc += (a * st - b * se) * (a * st - b * se);
            }
        }
        let head =
            ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
        let rest: f32 = tail
            .map(|(a, b)| (a * st - b * se) * (a * st - b * se))
            .sum();
        (head + rest).sqrt()
    }

    /// Branch and bound over the index for a table entry that fits the target better
    /// than `f` (all lights; module docs, step 1): `Some(None)` when none does,
    /// `Some(Some(fit))` at the best one, `None` when its initial ball (from `f`'s cost)
    /// meets more than [`BOUND_LEAVES`] leaves.
    pub(super) fn better_entry(
        &self,
        index: &Index,
        f: &Fit,
        wk: &mut Work,
    ) -> Option<Option<Fit>> {
        let k = self.model.k;
        self.query(index, wk);
        let (norm2, normalize) = (wk.norm * wk.norm, self.opts.normalize);
        // the squared distance (full K-dimensional space of the index, normalised tuples
        // when matching is) beyond which every entry costs at least b
        let reach = |b: f32| {
            if !normalize {
                b
            } else if b >= norm2 {
                f32::INFINITY
            } else {
                2.0 * b / norm2
            }
        };
        let (t, (q, rest)) = (&wk.t[..k], wk.q.split_at(index.dims()));
        // the tuple that was projected (normalised by `query` when matching is)
        let q_off = index.off_subspace(if normalize { &rest[..k] } else { t });
        let tuples = &self.model.tables[0].entries.tuples;
        let tuple = |e: u32| &tuples[e as usize * k..(e as usize + 1) * k];
        let cost = |e: u32| self.model.fit_with(t, None, tuple(e), tuple(e)).1;
        let (_, e) = index.least(q, q_off, f.cost, reach, cost, BOUND_LEAVES)?;
        if e == u32::MAX {
            return Some(None);
        }
        let (coef, cost) = self.model.fit_with(t, None, tuple(e), tuple(e));
        let (gx, gy) = self.entry_grid(e);
        wk.seeds.clear();
        wk.seeds.push(e);
        wk.candidates = false;
        Some(Some(Fit { gx, gy, coef, cost }))
    }

    /// Lower bound of the cost of an entry at projected distance `d` (≤ 0: none) from
    /// the query of a target of norm `norm`.
    fn lower_bound(&self, norm: f32, d: f32) -> f32 {
        if d <= 0.0 {
            0.0
        } else if self.opts.normalize {
            norm * norm * (0.5 * d * d).min(1.0)
        } else {
            d * d
        }
    }
}
