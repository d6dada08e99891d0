//! The sweeps of the multigrid cycle and of conjugate gradients over row bands, run in
//! parallel.
//!
//! A level is cut into at most [`MAX_BANDS`] bands of rows (each starting at an even
//! row, so that every coarse row belongs to one band); how many depends on the level's
//! size only, never on the number of threads, so results do not depend on the machine.
//! Within a band the smoother is Gauss–Seidel as in the module documentation of
//! [`super`]; across a band boundary it is Jacobi: the forward sweep from zero solves
//! (D + L_B) x = b, with L_B the strictly lower part of A restricted to pairs of cells
//! in the same band, and the backward sweep is x ← x + (D + U_B)⁻¹ (b − A x) with
//! U_B = L_Bᵀ, reading the neighbours across a boundary from a copy taken before the
//! sweep. The cycle therefore stays symmetric (and positive definite: D − C, C the
//! couplings across boundaries, is diagonally dominant), a valid preconditioner for CG.
//! With one band this is exactly the sequential sweep.
//!
//! After the forward sweep the residual b − A x of a cell is its coupling to the
//! neighbours not in L_B: right and below, and above on a band's first row; it is
//! restricted inside the band where the band holds both rows, and at the two rows next
//! to each boundary after the bands have joined.
//!
//! CG's passes are fused with the cycle's: the update r ← r − α A p runs row by row just
//! ahead of the forward sweep that reads r, and the updates x ← x + α p, p ← z + β p run
//! one row ahead of the product A p of the next iteration (see `System::cg`). These
//! change nothing but the number of passes over memory.

use super::sweep::dot4;
use super::{Level, System};
use rayon::prelude::*;

/// Cells of a level per band, at least.
const BAND_CELLS: usize = 1 << 16;
/// Most bands of one level.
const MAX_BANDS: usize = 4;
/// Rows of a band, at least.
const BAND_ROWS: usize = 32;

/// Rows [a, e) of each band of `v` (padded layout of stride `s`), as disjoint slices.
fn split<'a>(v: &'a mut [f64], bands: &[(usize, usize)], s: usize) -> Vec<&'a mut [f64]> {
    let mut out = Vec::with_capacity(bands.len());
    let (_, mut rest) = v.split_at_mut(bands[0].0 * s);
    for &(a, e) in bands {
        let (chunk, tail) = rest.split_at_mut((e - a) * s);
        out.push(chunk);
        rest = tail;
    }
    out
}

/// f(k, item) for every band (in parallel when there are several); the sum of the
/// results in band order.
fn run<T: Send>(items: Vec<T>, f: impl Fn(usize, T) -> f64 + Sync) -> f64 {
    if items.len() == 1 {
        let item = items.into_iter().next().unwrap_or_else(|| unreachable!());
        return f(0, item);
    }
    let parts: Vec<f64> = items
        .into_par_iter()
        .enumerate()
        .map(|(k, t)| f(k, t))
        .collect();
    parts.iter().sum()
}

/// b ← b + a·x; returns ‖b‖² (four partial sums).
fn axpy_sq(b: &mut [f64], x: &[f64], a: f64) -> f64 {
    b.iter_mut().zip(x).for_each(|(bi, &xi)| *bi += a * xi);
    dot4(b, b)
}

impl Level {
    /// The bands: padded row ranges [a, e) covering 1..=h, each starting at an even row
    /// of the unpadded grid.
    pub(super) fn bands(&self) -> Vec<(usize, usize)> {
        let nb = (self.w * self.h / BAND_CELLS)
            .min(self.h / BAND_ROWS)
            .clamp(1, MAX_BANDS);
        let half = self.h.div_ceil(2);
        let mut cuts: Vec<usize> = (0..nb).map(|k| 1 + 2 * (k * half / nb)).collect();
        cuts.push(self.h + 1);
        cuts.windows(2).map(|c| (c[0], c[1])).collect()
    }

    /// The coarse rows of each band.
    fn coarse_rows(bands: &[(usize, usize)]) -> Vec<(usize, usize)> {
        bands
            .iter()
            .map(|&(a, e)| ((a - 1) / 2 + 1, (e - 1).div_ceil(2) + 1))
            .collect()
    }

    /// The forward sweep from zero, x = (D + L_B)⁻¹ b, and the restriction of its
    /// residual into `rc` (r_c = Pᵀ r). With `upd` = (α, ap), b ← b − α ap first, row by
    /// row; returns ‖b‖² then (0 otherwise).
    pub(super) fn forward(
        &self,
        upd: Option<(f64, &[f64])>,
        b: &mut [f64],
        x: &mut [f64],
        coarse: &Level,
        rc: &mut [f64],
    ) -> f64 {
        let (s, sc) = (self.stride(), coarse.stride());
        let bands = self.bands();
        let crows = Self::coarse_rows(&bands);
        let items: Vec<_> = split(b, &bands, s)
            .into_iter()
            .zip(split(x, &bands, s))
            .zip(split(rc, &crows, sc))
            .collect();
        let rr = run(items, |k, ((bb, xx), cc)| {
            self.forward_band(bands[k], crows[k].0, upd, bb, xx, coarse, cc)
        });
        // The residual next to each boundary, now that both sides are set.
        for &(a, e) in &bands {
            if e <= self.h {
                let (xr, xd) = (&x[(e - 1) * s..e * s], &x[e * s..(e + 1) * s]);
                self.restrict_row(e - 1, xr, xd, coarse, rc, 0);
            }
            if a > 1 {
                let (su, xu) = (&self.south[(a - 1) * s..a * s], &x[(a - 1) * s..a * s]);
                let inc = &self.incl[a * s..(a + 1) * s];
                let cbase = ((a - 1) / 2 + 1) * sc + 1;
                let crow = &mut rc[cbase..cbase + coarse.w];
                for c in 1..=self.w {
                    if inc[c] {
                        crow[(c - 1) / 2] += su[c] as f64 * xu[c];
                    }
                }
            }
        }
        rr
    }

    /// [`Level::forward`] on the rows [a, e) of one band (`b`, `x` hold those rows,
    /// `rc` the band's coarse rows from padded row `c0`).
    #[allow(clippy::too_many_arguments)]
    fn forward_band(
        &self,
        (a, e): (usize, usize),
        c0: usize,
        upd: Option<(f64, &[f64])>,
        b: &mut [f64],
        x: &mut [f64],
        coarse: &Level,
        rc: &mut [f64],
    ) -> f64 {
        let (w, s) = (self.w, self.stride());
        rc.iter_mut().for_each(|v| *v = 0.0);
        let zero = vec![0.0; s];
        let mut rr = 0.0;
        if let Some((alpha, ap)) = upd {
            for r in a..e {
                let br = &mut b[(r - a) * s + 1..(r - a) * s + 1 + w];
                rr += axpy_sq(br, &ap[r * s + 1..r * s + 1 + w], -alpha);
            }
        }
        let mut r = a;
        while r < e {
            let k = (r - a) * s;
            let (done, rest) = x.split_at_mut(k);
            let above = if r > a { &done[k - s..] } else { &zero[..] };
            if r + 1 < e {
                let (cur0, cur1) = rest[..2 * s].split_at_mut(s);
                self.fwd_pair(r, (&b[k..k + s], &b[k + s..k + 2 * s]), above, cur0, cur1);
                if r > a {
                    self.restrict_row(r - 1, &x[k - s..k], &x[k..k + s], coarse, rc, c0);
                }
                self.restrict_row(r, &x[k..k + s], &x[k + s..k + 2 * s], coarse, rc, c0);
                r += 2;
            } else {
                self.fwd_row(r, &b[k..k + s], above, &mut rest[..s]);
                if r > a {
                    self.restrict_row(r - 1, &x[k - s..k], &x[k..k + s], coarse, rc, c0);
                }
                r += 1;
            }
        }
        if e > self.h {
            let last = &x[(e - 1 - a) * s..(e - a) * s];
            self.restrict_row(e - 1, last, &zero, coarse, rc, c0);
        }
        rr
    }

    /// Adds the forward residual of row r, east_i x_{i+1} + south_i x_{i+s} (`xr`, `xd`:
    /// rows r and r + 1), to its block sums in `rc` (coarse rows from padded row `c0`).
    fn restrict_row(
        &self,
        r: usize,
        xr: &[f64],
        xd: &[f64],
        coarse: &Level,
        rc: &mut [f64],
        c0: usize,
    ) {
        let (w, s) = (self.w, self.stride());
        let (e, so) = (
            &self.east[r * s..(r + 1) * s],
            &self.south[r * s..(r + 1) * s],
        );
        let inc = &self.incl[r * s..(r + 1) * s];
        let (xr, xd) = (&xr[..s], &xd[..s]);
        let cbase = ((r - 1) / 2 + 1 - c0) * coarse.stride() + 1;
        let crow = &mut rc[cbase..cbase + coarse.w];
        let res = |c: usize| {
            let v = e[c] as f64 * xr[c + 1] + so[c] as f64 * xd[c];
            if inc[c] {
                v
            } else {
                0.0
            }
        };
        for (j, out) in crow[..w / 2].iter_mut().enumerate() {
            let c = 2 * j + 1;
            *out += res(c) + res(c + 1);
        }
        if w % 2 == 1 {
            crow[w / 2] += res(w);
        }
    }

    /// row += (P x_c) on row r.
    fn prolong_row(&self, xc: &[f64], coarse: &Level, row: &mut [f64], r: usize) {
        let s = self.stride();
        let cbase = ((r - 1) / 2 + 1) * coarse.stride() + 1;
        let crow = &xc[cbase..cbase + coarse.w];
        // Cells 2j + 1, 2j + 2 of block j (the last may be the border: never included).
        let n = 2 * coarse.w;
        let inc = &self.incl[r * s + 1..r * s + 1 + n];
        for ((pair, m), &v) in row[1..1 + n]
            .chunks_exact_mut(2)
            .zip(inc.chunks_exact(2))
            .zip(crow)
        {
            pair[0] += if m[0] { v } else { 0.0 };
            pair[1] += if m[1] { v } else { 0.0 };
        }
    }

    /// Row r of x + P x_c (zeros for the border rows).
    fn prolonged(&self, r: usize, x: &[f64], xc: &[f64], coarse: &Level) -> Vec<f64> {
        let s = self.stride();
        let mut row = x[r * s..(r + 1) * s].to_vec();
        if (1..=self.h).contains(&r) {
            self.prolong_row(xc, coarse, &mut row, r);
        }
        row
    }

    /// x ← x + P x_c, then the backward sweep x ← x + (D + U_B)⁻¹ (b − A x); each row is
    /// prolonged just before the sweep reads it. Returns Σ b_i x_i of the result.
    pub(super) fn backward(&self, b: &[f64], xc: &[f64], coarse: &Level, x: &mut [f64]) -> f64 {
        let s = self.stride();
        let bands = self.bands();
        // The rows across each boundary as the sweeps find them (prolonged, not swept).
        let halos: Vec<(Vec<f64>, Vec<f64>)> = bands
            .iter()
            .map(|&(a, e)| {
                (
                    self.prolonged(a - 1, x, xc, coarse),
                    self.prolonged(e, x, xc, coarse),
                )
            })
            .collect();
        let items: Vec<_> = split(x, &bands, s).into_iter().zip(&halos).collect();
        run(items, |k, (xx, (up, dn))| {
            self.backward_band(bands[k], b, xc, coarse, xx, up, dn)
        })
    }

    /// [`Level::backward`] on the rows [a, e) of one band (`x` holds those rows; `up`,
    /// `dn`: the rows above and below it).
    #[allow(clippy::too_many_arguments)]
    fn backward_band(
        &self,
        (a, e): (usize, usize),
        b: &[f64],
        xc: &[f64],
        coarse: &Level,
        x: &mut [f64],
        up: &[f64],
        dn: &[f64],
    ) -> f64 {
        let s = self.stride();
        self.prolong_row(xc, coarse, &mut x[(e - 1 - a) * s..(e - a) * s], e - 1);
        let mut dot = 0.0;
        // Rows r (and r − 1 with it) from the bottom of the band up.
        let mut r = e - 1;
        loop {
            let pair = r > a;
            let top = if pair { r - 1 } else { r };
            if top < r {
                let k = (top - a) * s;
                self.prolong_row(xc, coarse, &mut x[k..k + s], top);
            }
            if top > a {
                let k = (top - 1 - a) * s;
                self.prolong_row(xc, coarse, &mut x[k..k + s], top - 1);
            }
            let k = (top - a) * s;
            let (head, tail) = x.split_at_mut(k);
            let above = if top > a { &head[k - s..] } else { up };
            let br = |q: usize| &b[q * s..(q + 1) * s];
            if pair {
                let (t, rest) = tail.split_at_mut(s);
                let (bt, below) = rest.split_at_mut(s);
                let below = if r + 1 < e { &below[..s] } else { dn };
                dot += self.bwd_pair(r, (br(r - 1), br(r)), above, t, bt, below);
            } else {
                let (cur, below) = tail.split_at_mut(s);
                let below = if r + 1 < e { &below[..s] } else { dn };
                dot += self.bwd_row(r, br(r), above, cur, below);
            }
            if top == a {
                break;
            }
            r = top - 1;
        }
        dot
    }

    /// y = A x on row r (Laplacian form, without the masses; `xu`, `xr`, `xd`: rows
    /// r − 1, r, r + 1); returns Σ x_i y_i over the row.
    #[inline(always)]
    fn apply_row(&self, r: usize, xu: &[f64], xr: &[f64], xd: &[f64], y: &mut [f64]) -> f64 {
        let s = self.stride();
        let (e, sd, su) = (
            &self.east[r * s..(r + 1) * s],
            &self.south[r * s..(r + 1) * s],
            &self.south[(r - 1) * s..r * s],
        );
        let w = self.w;
        for c in 1..=w {
            let xi = xr[c];
            y[c] = e[c] as f64 * (xi - xr[c + 1])
                + e[c - 1] as f64 * (xi - xr[c - 1])
                + sd[c] as f64 * (xi - xd[c])
                + su[c] as f64 * (xi - xu[c]);
        }
        dot4(&xr[1..=w], &y[1..=w])
    }

    /// [`System::update`] on the rows [a, e) of one band (`x`, `p`, `ap` hold those
    /// rows). The product on a row next to a boundary is left to the caller.
    #[allow(clippy::too_many_arguments)]
    fn update_band(
        &self,
        (a, e): (usize, usize),
        alpha: f64,
        beta: f64,
        x: &mut [f64],
        p: &mut [f64],
        z: &[f64],
        ap: &mut [f64],
    ) -> f64 {
        let (w, s) = (self.w, self.stride());
        let zero = vec![0.0; s];
        let defer = |j: usize| (j == a && a > 1) || (j + 1 == e && e <= self.h);
        let mut dot = 0.0;
        for r in a..e {
            let k = (r - a) * s;
            let zr = &z[r * s..(r + 1) * s];
            for ((xi, pi), &zi) in x[k + 1..=k + w]
                .iter_mut()
                .zip(&mut p[k + 1..=k + w])
                .zip(&zr[1..=w])
            {
                *xi += alpha * *pi;
                *pi = zi + beta * *pi;
            }
            if r > a && !defer(r - 1) {
                let above = if r - 1 > a {
                    &p[k - 2 * s..k - s]
                } else {
                    &zero[..]
                };
                let (pr, pd) = (&p[k - s..k], &p[k..k + s]);
                dot += self.apply_row(r - 1, above, pr, pd, &mut ap[k - s..k]);
            }
        }
        if !defer(e - 1) {
            let k = (e - 1 - a) * s;
            let above = if e - 1 > a { &p[k - s..k] } else { &zero[..] };
            dot += self.apply_row(e - 1, above, &p[k..k + s], &zero, &mut ap[k..k + s]);
        }
        dot
    }
}

impl System {
    /// x ← x + α p, p ← z + β p, ap = A p; returns p·ap (of the new p).
    pub(super) fn update(
        &self,
        alpha: f64,
        beta: f64,
        x: &mut [f64],
        p: &mut [f64],
        z: &[f64],
        ap: &mut [f64],
    ) -> f64 {
        let fine = self.fine();
        let s = fine.stride();
        let bands = fine.bands();
        let items: Vec<_> = split(x, &bands, s)
            .into_iter()
            .zip(split(p, &bands, s))
            .zip(split(ap, &bands, s))
            .collect();
        let mut dot = run(items, |k, ((xx, pp), aa)| {
            fine.update_band(bands[k], alpha, beta, xx, pp, z, aa)
        });
        // The rows next to each boundary.
        let mut edge = |r: usize, dot: &mut f64| {
            let (pu, pr, pd) = super::rows(p, s, r);
            *dot += fine.apply_row(r, pu, pr, pd, &mut ap[r * s..(r + 1) * s]);
        };
        for &(a, e) in &bands {
            if a > 1 {
                edge(a, &mut dot);
            }
            if e <= fine.h && !(e - 1 == a && a > 1) {
                edge(e - 1, &mut dot);
            }
        }
        for &(i, m) in &self.pins {
            ap[i] += m * p[i];
            dot += m * p[i] * p[i];
        }
        dot
    }
}
