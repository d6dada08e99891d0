//! One level of the hierarchy: the weighted graph Laplacian on a padded grid, and its
//! coarsening into 2 × 2 blocks (see the parent module's docs).

use super::super::pages::{sparse, Buf};

/// Coarse-operator scaling γ (see the module documentation).
const GAMMA: f32 = 2.0;

/// Relative strength below which an edge does not join two cells of a block.
const STRONG: f32 = 0.05;

/// The rows 1..=h of a padded grid of stride s: (row above, row, row below) of each.
#[inline(always)]
pub(super) fn rows<T>(v: &[T], s: usize, r: usize) -> (&[T], &[T], &[T]) {
    (
        &v[(r - 1) * s..r * s],
        &v[r * s..(r + 1) * s],
        &v[(r + 1) * s..(r + 2) * s],
    )
}

/// A weighted 5-point graph Laplacian on a `w` × `h` grid stored with a one-cell border
/// of zeros (padded index (r + 1)·(w + 2) + c + 1), so that no stencil needs a bounds
/// check. The finest level's weights also define the operator of [`System`].
#[derive(Clone, Debug)]
pub(crate) struct Level {
    pub(super) w: usize,
    pub(super) h: usize,
    /// Weight of the edge from a cell to its right neighbour (padded layout).
    pub(super) east: Buf<f32>,
    /// Weight of the edge from a cell to the one below.
    pub(super) south: Buf<f32>,
    /// Extra diagonal (pins), ≥ 0.
    pub(super) mass: Buf<f32>,
    /// 1 / (Σ incident weights + mass); 0 for cells without unknown.
    pub(super) inv_diag: Buf<f32>,
    /// Per cell: part of its block's coarse cell (set by [`Level::coarsen`]).
    pub(super) incl: Vec<bool>,
    /// Per padded row: every cell with an unknown is included (set by
    /// [`Level::coarsen`]). The transfers skip the per-cell test on such rows: a cell
    /// without unknown has no edges, so its restricted residual is 0, and the
    /// correction it gets is overwritten by the backward sweep (its value is 0).
    pub(super) clean: Vec<bool>,
}

impl Level {
    pub(super) fn stride(&self) -> usize {
        self.w + 2
    }

    pub(super) fn len(&self) -> usize {
        (self.w + 2) * (self.h + 2)
    }

    pub(super) fn new(w: usize, h: usize, east: Buf<f32>, south: Buf<f32>, mass: Buf<f32>) -> Self {
        let s = w + 2;
        let mut inv_diag = sparse(s * (h + 2));
        for r in 1..=h {
            let (_, ec, _) = rows(&east, s, r);
            let (su, sc, _) = rows(&south, s, r);
            let m = &mass[r * s..(r + 1) * s];
            let out = &mut inv_diag[r * s..(r + 1) * s];
            for c in 1..=w {
                let d = m[c] as f64 + ec[c] as f64 + ec[c - 1] as f64 + sc[c] as f64 + su[c] as f64;
                out[c] = if d > 0.0 { (1.0 / d) as f32 } else { 0.0 };
            }
        }
        Level {
            w,
            h,
            east,
            south,
            mass,
            inv_diag,
            incl: Vec::new(),
            clean: Vec::new(),
        }
    }

    /// y = b − A x.
    pub(super) fn residual(&self, b: &[f64], x: &[f64], y: &mut [f64]) {
        let (w, s) = (self.w, self.stride());
        for r in 1..=self.h {
            let (xu, xr, xd) = rows(x, s, r);
            let (e, sd, su) = (
                &self.east[r * s..(r + 1) * s],
                &self.south[r * s..(r + 1) * s],
                &self.south[(r - 1) * s..r * s],
            );
            let (m, br) = (&self.mass[r * s..(r + 1) * s], &b[r * s..(r + 1) * s]);
            let yr = &mut y[r * s..(r + 1) * s];
            for c in 1..=w {
                let xi = xr[c];
                yr[c] = br[c]
                    - (e[c] as f64 * (xi - xr[c + 1])
                        + e[c - 1] as f64 * (xi - xr[c - 1])
                        + sd[c] as f64 * (xi - xd[c])
                        + su[c] as f64 * (xi - xu[c])
                        + m[c] as f64 * xi);
            }
        }
    }

    pub(super) fn has(&self, i: usize) -> bool {
        self.inv_diag[i] > 0.0
    }

    pub(super) fn unknowns(&self) -> usize {
        self.inv_diag.iter().filter(|&&d| d > 0.0).count()
    }

    /// Whether the edge of weight `wt` between cells i and j is strong: at least
    /// [`STRONG`] times the strongest edge at either end.
    pub(super) fn strong(&self, wt: f32, i: usize, j: usize) -> bool {
        wt > 0.0 && wt >= STRONG * self.max_edge(i).max(self.max_edge(j))
    }

    pub(super) fn max_edge(&self, i: usize) -> f32 {
        let s = self.stride();
        self.east[i]
            .max(self.east[i - 1])
            .max(self.south[i])
            .max(self.south[i - s])
    }

    /// The included cells of one 2 × 2 block (cells a b / c d at padded index `a`,
    /// `on` flags which exist): the largest group joined by strong edges.
    pub(super) fn block_included(&self, a: usize, on: [bool; 4]) -> [bool; 4] {
        let s = self.stride();
        let cells = [a, a + 1, a + s, a + s + 1];
        // Union-find over 4 cells: edges a-b, c-d (east), a-c, b-d (south).
        let mut root = [0usize, 1, 2, 3];
        let find = |root: &[usize; 4], mut k: usize| {
            while root[k] != k {
                k = root[k];
            }
            k
        };
        for (x, y, wt) in [
            (0, 1, self.east[a]),
            (2, 3, self.east[a + s]),
            (0, 2, self.south[a]),
            (1, 3, self.south[a + 1]),
        ] {
            if on[x] && on[y] && self.strong(wt, cells[x], cells[y]) {
                let (rx, ry) = (find(&root, x), find(&root, y));
                root[rx.max(ry)] = rx.min(ry);
            }
        }
        let size = |r: usize| (0..4).filter(|&k| on[k] && find(&root, k) == r).count();
        let best = (0..4)
            .filter(|&k| on[k])
            .max_by_key(|&k| (size(find(&root, k)), 4 - k));
        let mut out = [false; 4];
        if let Some(b) = best {
            let rb = find(&root, b);
            for k in (0..4).filter(|&k| on[k] && find(&root, k) == rb) {
                out[k] = true;
            }
        }
        out
    }

    /// Per cell: whether it takes part in its block's coarse cell. Within each 2 × 2
    /// block only the largest group of cells joined by strong edges does; a cell cut
    /// off by a weak edge (a depth discontinuity of BiNI) gets no coarse correction
    /// (its row of f64 is 0) and is left to the smoother.
    pub(super) fn included(&self) -> Vec<bool> {
        let s = self.stride();
        let mut incl = vec![false; self.len()];
        for br in (0..self.h).step_by(2) {
            for bc in (0..self.w).step_by(2) {
                let a = (br + 1) * s + bc + 1;
                let cells = [a, a + 1, a + s, a + s + 1];
                let on: [bool; 4] = std::array::from_fn(|k| {
                    let (dr, dc) = (k / 2, k % 2);
                    br + dr < self.h && bc + dc < self.w && self.has(cells[k])
                });
                // Fast path: a full block of four equal edges (all strong).
                let inner = [
                    self.east[a],
                    self.east[a + s],
                    self.south[a],
                    self.south[a + 1],
                ];
                let uniform = on.iter().all(|&o| o)
                    && inner.iter().all(|&v| v > 0.0 && v == inner[0])
                    && cells.iter().all(|&i| self.max_edge(i) <= inner[0] / STRONG);
                let inc = if uniform {
                    [true; 4]
                } else {
                    self.block_included(a, on)
                };
                for k in 0..4 {
                    incl[cells[k]] = inc[k];
                }
            }
        }
        incl
    }

    /// The Galerkin coarse level PᵀAP / γ over 2 × 2 blocks (f64 restricted to the
    /// included cells): coarse edges sum the fine edges between included cells of two
    /// blocks; edges from an included cell to an excluded one add to the coarse mass.
    pub(super) fn coarsen(&mut self) -> Level {
        self.incl = self.included();
        let (w, h, s) = (self.w, self.h, self.stride());
        self.clean = (0..h + 2)
            .map(|r| {
                let row = r * s..(r + 1) * s;
                self.incl[row.clone()]
                    .iter()
                    .zip(&self.inv_diag[row])
                    .all(|(&inc, &d)| inc || d == 0.0)
            })
            .collect();
        let (wc, hc) = (w.div_ceil(2), h.div_ceil(2));
        let sc = wc + 2;
        let n = sc * (hc + 2);
        // Coarse levels on ordinary pages (see `pages::MAX_BYTES`).
        let (mut east, mut south, mut mass) = (sparse(n), sparse(n), sparse(n));
        for r in 0..h {
            if self.clean[r..r + 3].iter().all(|&c| c) {
                self.coarsen_clean_row(r, &mut east, &mut south, &mut mass, sc);
                continue;
            }
            for c in 0..w {
                let i = (r + 1) * s + c + 1;
                if !self.incl[i] {
                    continue;
                }
                let ic = (r / 2 + 1) * sc + c / 2 + 1;
                let mut m = self.mass[i];
                for (j, wt) in [
                    (i + 1, self.east[i]),
                    (i - 1, self.east[i - 1]),
                    (i + s, self.south[i]),
                    (i - s, self.south[i - s]),
                ] {
                    if wt != 0.0 && !self.incl[j] {
                        m += wt;
                    }
                }
                mass[ic] += m / GAMMA;
                // Edges leaving the block to the right / below cross to the next block.
                if c % 2 == 1 && c + 1 < w && self.incl[i + 1] {
                    east[ic] += self.east[i] / GAMMA;
                }
                if r % 2 == 1 && r + 1 < h && self.incl[i + s] {
                    south[ic] += self.south[i] / GAMMA;
                }
            }
        }
        Level::new(wc, hc, east, south, mass)
    }

    /// [`Level::coarsen`] on row r when it and the rows next to it are clean: every
    /// edge of non-zero weight joins two included cells, so no edge adds to a mass and
    /// no test is needed (a cell without unknown has no mass and no edges). The same
    /// sums in the same order as the general loop, less its additions of zero.
    pub(super) fn coarsen_clean_row(
        &self,
        r: usize,
        east: &mut [f32],
        south: &mut [f32],
        mass: &mut [f32],
        sc: usize,
    ) {
        let (w, h, s) = (self.w, self.h, self.stride());
        let fine = (r + 1) * s + 1..(r + 1) * s + 1 + w;
        let crow = (r / 2 + 1) * sc + 1;
        for (c, &m) in self.mass[fine.clone()].iter().enumerate() {
            if m != 0.0 {
                mass[crow + c / 2] += m / GAMMA;
            }
        }
        // Edges leaving a block to the right: cells 2j + 1 (0-based), 2j + 2 < w.
        let (fe, ce) = (&self.east[fine.clone()], &mut east[crow..crow + w / 2]);
        for (j, out) in ce.iter_mut().enumerate().take((w - 1) / 2) {
            *out += fe[2 * j + 1] / GAMMA;
        }
        if r % 2 == 1 && r + 1 < h {
            let (fs, cs) = (&self.south[fine], &mut south[crow..crow + w.div_ceil(2)]);
            for (c, &v) in fs.iter().enumerate() {
                cs[c / 2] += v / GAMMA;
            }
        }
    }
}
