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
//! CG's passes are fused with the cycle's: the updates x ← x + α p, p ← z + β p run one
//! row ahead of the product A p and p·A p, A p going into z's rows (no longer needed);
//! the update r ← r − α A p runs row by row just ahead of the forward sweep that reads
//! r, reading A p from the rows of z it is about to overwrite (see `System::cg`).
//! These change nothing but the number of passes over memory (and the rounding).

use super::level::Level;
use super::sweep::dot4;
use super::System;
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
#[inline(always)]
fn axpy_sq(b: &mut [f64], x: &[f64], a: f64) -> f64 {
    b.iter_mut().zip(x).for_each(|(bi, &xi)| *bi += a * xi);
    dot4(b, b)
}

/// A method `$name(&self, args) -> f64` that runs `$imp` compiled for AVX2 (as
/// `$avx`) where the processor has it, checked at run time, and compiled for the x86-64
/// baseline (SSE2) otherwise. `$imp` and every kernel it calls are `inline(always)`, so
/// all of them are compiled both ways. Both builds do the same operations in the same
/// order (Rust never fuses a multiply and an add, nor reorders a sum), so their results
/// are identical: AVX2 only widens the vectorised loops from two lanes to four.
macro_rules! dispatch {
    ($name:ident, $avx:ident, $imp:ident, ($($arg:ident: $ty:ty),*)) => {
        #[allow(clippy::too_many_arguments)]
        fn $name(&self, $($arg: $ty),*) -> f64 {
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: the processor has AVX2 (checked just above), the only
                // requirement of `$avx`.
                return unsafe { self.$avx($($arg),*) };
            }
            self.$imp($($arg),*)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        #[allow(clippy::too_many_arguments)]
        fn $avx(&self, $($arg: $ty),*) -> f64 {
            self.$imp($($arg),*)
        }
    };
}

impl Level {
    dispatch!(
        forward_band,
        forward_band_avx2,
        forward_band_impl,
        (
            rows: (usize, usize),
            c0: usize,
            upd: Option<f64>,
            b: &mut [f64],
            x: &mut [f64],
            coarse: &Level,
            rc: &mut [f64]
        )
    );
    dispatch!(
        backward_band,
        backward_band_avx2,
        backward_band_impl,
        (
            rows: (usize, usize),
            b: &[f64],
            xc: &[f64],
            coarse: &Level,
            x: &mut [f64],
            up: &[f64],
            dn: &[f64]
        )
    );
    dispatch!(
        update_band,
        update_band_avx2,
        update_band_impl,
        (
            rows: (usize, usize),
            step: Option<(f64, f64)>,
            x: &mut [f64],
            p: &mut [f64],
            z: &mut [f64]
        )
    );
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
    /// residual into `rc` (r_c = Pᵀ r). With `upd` = α, b ← b − α A p first (A
    /// without its masses: the caller applies those), each row just before the sweep
    /// reads it, A p read from x (where [`System::update`] left it; the sweep then
    /// overwrites it); returns ‖b‖² then (0 otherwise).
    pub(super) fn forward(
        &self,
        upd: Option<f64>,
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
    #[inline(always)]
    fn forward_band_impl(
        &self,
        (a, e): (usize, usize),
        c0: usize,
        upd: Option<f64>,
        b: &mut [f64],
        x: &mut [f64],
        coarse: &Level,
        rc: &mut [f64],
    ) -> f64 {
        let s = self.stride();
        rc.iter_mut().for_each(|v| *v = 0.0);
        let zero = vec![0.0; s];
        let mut rr = 0.0;
        let mut r = a;
        while r < e {
            let k = (r - a) * s;
            let pair = r + 1 < e;
            if let Some(alpha) = upd {
                // x's rows hold A p (stored there by `System::update`) until the sweep
                // below overwrites them.
                let w = self.w;
                for q in r..if pair { r + 2 } else { r + 1 } {
                    let kq = (q - a) * s;
                    rr += axpy_sq(&mut b[kq + 1..=kq + w], &x[kq + 1..=kq + w], -alpha);
                }
            }
            let (done, rest) = x.split_at_mut(k);
            let above = if r > a { &done[k - s..] } else { &zero[..] };
            if pair {
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
    #[inline(always)]
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
        let (xr, xd) = (&xr[..s], &xd[..s]);
        let cbase = ((r - 1) / 2 + 1 - c0) * coarse.stride() + 1;
        let crow = &mut rc[cbase..cbase + coarse.w];
        if self.clean[r] {
            // Pairs of cells 2j + 1, 2j + 2 (slices of one length: no bounds checks).
            let n = 2 * (w / 2);
            let (ep, sp, xn, xdp) = (&e[1..=n], &so[1..=n], &xr[2..n + 2], &xd[1..=n]);
            for (j, out) in crow[..w / 2].iter_mut().enumerate() {
                let (a, b) = (2 * j, 2 * j + 1);
                *out += (ep[a] as f64 * xn[a] + sp[a] as f64 * xdp[a])
                    + (ep[b] as f64 * xn[b] + sp[b] as f64 * xdp[b]);
            }
            if w % 2 == 1 {
                crow[w / 2] += e[w] as f64 * xr[w + 1] + so[w] as f64 * xd[w];
            }
            return;
        }
        let inc = &self.incl[r * s..(r + 1) * s];
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
    #[inline(always)]
    fn prolong_row(&self, xc: &[f64], coarse: &Level, row: &mut [f64], r: usize) {
        let s = self.stride();
        let cbase = ((r - 1) / 2 + 1) * coarse.stride() + 1;
        let crow = &xc[cbase..cbase + coarse.w];
        if self.clean[r] {
            let w = self.w;
            for (pair, &v) in row[1..1 + 2 * (w / 2)].chunks_exact_mut(2).zip(crow) {
                pair[0] += v;
                pair[1] += v;
            }
            if w % 2 == 1 {
                row[w] += crow[w / 2];
            }
            return;
        }
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
    #[inline(always)]
    fn backward_band_impl(
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
    /// r − 1, r, r + 1).
    #[inline(always)]
    fn apply_into(&self, r: usize, xu: &[f64], xr: &[f64], xd: &[f64], y: &mut [f64]) {
        let (w, s) = (self.w, self.stride());
        // Slices of one length w (cells 1..=w and their neighbours), so that the loop
        // has no bounds checks and vectorises.
        let (e, el) = (
            &self.east[r * s + 1..=r * s + w],
            &self.east[r * s..r * s + w],
        );
        let sd = &self.south[r * s + 1..=r * s + w];
        let su = &self.south[(r - 1) * s + 1..=(r - 1) * s + w];
        let (xc, xl, xn) = (&xr[1..=w], &xr[..w], &xr[2..w + 2]);
        let (xu, xd, y) = (&xu[1..=w], &xd[1..=w], &mut y[1..=w]);
        for i in 0..w {
            let xi = xc[i];
            y[i] = e[i] as f64 * (xi - xn[i])
                + el[i] as f64 * (xi - xl[i])
                + sd[i] as f64 * (xi - xd[i])
                + su[i] as f64 * (xi - xu[i]);
        }
    }

    /// Σ x_i (A x)_i over row r (`y`: scratch row).
    #[inline(always)]
    fn apply_dot_row(&self, r: usize, xu: &[f64], xr: &[f64], xd: &[f64], y: &mut [f64]) -> f64 {
        self.apply_into(r, xu, xr, xd, y);
        dot4(&xr[1..=self.w], &y[1..=self.w])
    }

    /// [`System::update`] on the rows [a, e) of one band (`x`, `p` hold those rows).
    /// The product on a row next to a boundary is left to the caller.
    #[inline(always)]
    fn update_band_impl(
        &self,
        (a, e): (usize, usize),
        step: Option<(f64, f64)>,
        x: &mut [f64],
        p: &mut [f64],
        z: &mut [f64],
    ) -> f64 {
        let (w, s) = (self.w, self.stride());
        let zero = vec![0.0; s];
        let defer = |j: usize| (j == a && a > 1) || (j + 1 == e && e <= self.h);
        let mut dot = 0.0;
        for r in a..e {
            let k = (r - a) * s;
            let zr = &z[k + 1..=k + w];
            match step {
                Some((alpha, beta)) => {
                    for ((xi, pi), &zi) in x[k + 1..=k + w]
                        .iter_mut()
                        .zip(&mut p[k + 1..=k + w])
                        .zip(zr)
                    {
                        *xi += alpha * *pi;
                        *pi = zi + beta * *pi;
                    }
                }
                // The first direction: p = z, written without reading p or x.
                None => p[k + 1..=k + w].copy_from_slice(zr),
            }
            if r > a && !defer(r - 1) {
                let above = if r - 1 > a {
                    &p[k - 2 * s..k - s]
                } else {
                    &zero[..]
                };
                let (pr, pd) = (&p[k - s..k], &p[k..k + s]);
                // A p into z's row r − 1, no longer needed.
                dot += self.apply_dot_row(r - 1, above, pr, pd, &mut z[k - s..k]);
            }
        }
        if !defer(e - 1) {
            let k = (e - 1 - a) * s;
            let above = if e - 1 > a { &p[k - s..k] } else { &zero[..] };
            dot += self.apply_dot_row(e - 1, above, &p[k..k + s], &zero, &mut z[k..k + s]);
        }
        dot
    }
}

impl System {
    /// With `step` = (α, β): x ← x + α p, p ← z + β p; without (the first iteration):
    /// p = z. Returns p·A p of the new p, and leaves A p (without the masses) in z,
    /// whose rows are no longer needed once p's are set: the next forward sweep reads
    /// it there just before it overwrites it.
    pub(super) fn update(
        &self,
        step: Option<(f64, f64)>,
        x: &mut [f64],
        p: &mut [f64],
        z: &mut [f64],
    ) -> f64 {
        let fine = self.fine();
        let s = fine.stride();
        let bands = fine.bands();
        let items: Vec<_> = split(x, &bands, s)
            .into_iter()
            .zip(split(p, &bands, s))
            .zip(split(z, &bands, s))
            .collect();
        let mut dot = run(items, |k, ((xx, pp), zz)| {
            fine.update_band(bands[k], step, xx, pp, zz)
        });
        // The rows next to each boundary.
        let mut edge = |r: usize, dot: &mut f64| {
            let (pu, pr, pd) = super::level::rows(p, s, r);
            *dot += fine.apply_dot_row(r, pu, pr, pd, &mut z[r * s..(r + 1) * s]);
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
            dot += m * p[i] * p[i];
        }
        dot
    }
}
