//! What the per-pixel search needs that depends only on the tables and the options, not
//! on the target: the index over table 0's entries, the rim model, the coarse grid, the
//! entry at each window pixel and the entries' isolation radii. Built once per
//! [`crate::lut::Lookup`] (the analogue of a KD-tree library's tree build), and borrowed
//! by the [`Solver`] of each target.

use super::certify::UNSET;
use super::index::Index;
use super::{coarse_grid, mixture, Solver};
use crate::lut::fit::generic::Model;
use crate::lut::fit::rim::Rim;
use crate::lut::options::{Method, Options};
use std::sync::atomic::AtomicU32;

/// The target-independent part of a [`Solver`] (see the module docs).
pub(crate) struct Prep {
    pub(super) index: Option<Index>,
    pub(super) rim: Option<Rim>,
    pub(super) entries_at: Vec<u32>,
    pub(super) coarse_pos: Vec<(f64, f64)>,
    pub(super) coarse_basis: [Vec<f32>; 2],
    pub(super) coarse_step: f64,
    pub(super) peaks: [f32; 2],
    /// Each light's floor (`Table::floors`; the smaller of two tables'), padded with
    /// zeros to the fast path's lane width.
    pub(super) floors: Vec<f32>,
    /// Isolation radius of each entry as f32 bits, [`UNSET`] until computed (lazily by
    /// the certificate, or all at once by [`Prep::fill_isolation`]).
    pub(super) isolation: Vec<AtomicU32>,
    pub(super) mixture: Option<mixture::Scan>,
}

impl Prep {
    /// Build everything but the isolation radii (those are computed when first needed).
    pub fn new(model: &Model<'_>, opts: &Options) -> Prep {
        let t0 = &model.tables[0];
        let k = model.k;
        let n = t0.entries.len();
        let mut ranked = std::borrow::Cow::Borrowed(&t0.entries.tuples[..]);
        let mut keep = vec![true; n];
        if opts.normalize {
            for (e, tuple) in ranked.to_mut().chunks_exact_mut(k).enumerate() {
                let norm = tuple.iter().map(|v| v * v).sum::<f32>().sqrt();
                keep[e] = norm > 1e-6;
                tuple.iter_mut().for_each(|v| *v /= norm.max(1e-6));
            }
        }
        let dims = match opts.method {
            Method::InverseDistance { .. } => k,
            _ => opts.pca_dims,
        };
        // the index on one worker, the coarse grid and the rim model on the other
        let (index, ((coarse_pos, coarse_basis, coarse_step), rim)) = rayon::join(
            || (!model.is_mix()).then(|| Index::build(&ranked, k, &keep, dims)),
            || {
                let rim = (!model.is_mix() && opts.method == Method::Refined)
                    .then(|| Rim::fit(t0))
                    .flatten();
                (coarse_grid(model), rim)
            },
        );
        let peaks = [t0.peak(), model.tables.get(1).map_or(0.0, |t| t.peak())];
        let mut floors = t0.floors();
        if let Some(t1) = model.tables.get(1) {
            floors
                .iter_mut()
                .zip(t1.floors())
                .for_each(|(a, b)| *a = a.min(b));
        }
        floors.resize(super::fused::padded(k), 0.0);
        let ws = &t0.window.stack;
        let mut entries_at = vec![u32::MAX; ws.width * ws.height];
        for (e, [r, c]) in t0.entries.pixels.iter().enumerate() {
            let (r, c) = (*r as usize - t0.window.row0, *c as usize - t0.window.col0);
            entries_at[r * ws.width + c] = e as u32;
        }
        let mixture = model.is_mix().then(|| mixture::Scan::new(&coarse_basis, k));
        Prep {
            index,
            rim,
            entries_at,
            coarse_pos,
            coarse_basis,
            coarse_step,
            peaks,
            floors,
            isolation: (0..n).map(|_| AtomicU32::new(UNSET)).collect(),
            mixture,
        }
    }

    /// Compute the isolation radius of every entry at an even grid point, the first
    /// anchor of every certificate (one table, refined lookup; in parallel), so that no
    /// target pays for them; the second anchors are computed when first needed.
    pub fn fill_isolation(&self, model: Model<'_>, opts: &Options) {
        if self.index.is_some() && opts.method == Method::Refined {
            Solver::with(model, opts, self).fill_isolation();
        }
    }
}
