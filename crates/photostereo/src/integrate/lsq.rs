//! Masked least-squares integration: multigrid-preconditioned CG, with sparse Cholesky
//! as the fallback.
//!
//! Unknowns: the depth of the N pixels inside the mask. Edges: pairs of 4-neighbours
//! both inside the mask, e = (i, j) with j right of or below i, target g_e from the
//! trapezoidal rule (module documentation of [`super`]) and weight
//! w_e = min(w_i, w_j) (with a weight map, plus the membrane prior of module `trust`,
//! see [`with_prior`]). Minimising Σ w_e (z_j − z_i − g_e)² gives
//!
//! L z = b,  L = Σ_e w_e (e_j − e_i)(e_j − e_i)ᵀ,  b = Σ_e w_e g_e (e_j − e_i),
//!
//! a weighted graph Laplacian, singular once per connected part (the free offset).
//! Adding a mass to the diagonal of one pixel per part (the first in raster order)
//! makes it positive definite without changing the edge residuals: the optimum simply
//! puts that pixel at 0.
//!
//! The system is solved by conjugate gradients preconditioned with a multigrid cycle
//! ([`super::multigrid`], O(N), relative residual [`TOL`]). Should that not converge
//! within [`MAX_ITER`] iterations (not seen on any mask or weight map we tried; a
//! safety net for extreme weight contrasts), the same matrix is factorised by `faer`'s
//! supernodal sparse Cholesky with an AMD ordering (exact, but O(N^1.5) time and much
//! more memory).

use super::multigrid::System;
use super::pages::{filled, Buf};
use super::support::Components;
use super::window::Window;
use crate::error::{Error, Result};
use crate::image::{GrayImage, Mask};
use crate::progress::Progress;
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{MatMut, Side};
use std::borrow::Cow;

/// Relative residual ‖b − Lz‖/‖b‖ at which CG stops. 1e-5 rather than 1e-6 saves one
/// or two of about ten multigrid-preconditioned iterations (a tenth of the process on a
/// 1024² disk) and moves the depth by far less than the discretisation error: at most
/// 2.6e-5 px on a 1024² disk of a smooth bumpy surface whose error against the truth is
/// up to 1.5e-3 px, 1.3e-4 / 1.1e-4 px on DiLiGenT's bear and harvest (depth ranges of
/// about 100 px); measured 2026-12-04, docs/benchmarks.md.
pub(crate) const TOL: f64 = 1e-5;
/// CG iterations before falling back to Cholesky.
pub(crate) const MAX_ITER: usize = 300;

/// Strength ε of the membrane prior ε (1 − t_e) Δz² on an edge of trust t_e (weights
/// scaled to a maximum of 1; only with a weight map): an edge of no trust is filled
/// smoothly, a fully trusted one keeps its target (module `trust` of [`super`]).
pub(crate) const PRIOR: f64 = 0.1;

/// Pixel weights: 1 without a map, otherwise sanitised, scaled to a maximum of 1 and
/// floored at 1e-4.
pub(crate) fn pixel_weights(weights: Option<&GrayImage>, mask: &Mask) -> Vec<f64> {
    let Some(wm) = weights else {
        return vec![1.0; mask.len()];
    };
    let clean = |v: f32| {
        if v.is_finite() && v > 0.0 {
            v as f64
        } else {
            0.0
        }
    };
    let max = wm
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(_, &m)| m)
        .map(|(&v, _)| clean(v))
        .fold(0.0, f64::max);
    let scale = if max > 0.0 { 1.0 / max } else { 0.0 };
    wm.data
        .iter()
        .map(|&v| (clean(v) * scale).max(1e-4))
        .collect()
}

/// The weight and target of an edge of trust `t` ∈ [0, 1] and measured step `g` once
/// the prior ε (1 − t) Δz² is added (`prior`: with a weight map): t (Δz − g)² +
/// ε (1 − t) Δz² = (t + ε(1 − t)) (Δz − t g / (t + ε(1 − t)))² + const.
#[inline]
pub(crate) fn with_prior(t: f64, g: f64, prior: bool) -> (f64, f64) {
    if !prior {
        return (t, g);
    }
    let wt = t + PRIOR * (1.0 - t).max(0.0);
    (wt, t * g / wt)
}

/// A weighted least-squares problem on the edges of a masked grid, assembled as the
/// normal equations: edge weights to the right (`east`) and down (`south`), right-hand
/// side, and the pins.
#[derive(Clone, Debug)]
pub(crate) struct Assembled {
    pub w: usize,
    pub h: usize,
    pub east: Vec<f64>,
    pub south: Vec<f64>,
    pub rhs: Vec<f64>,
    pub mass: Vec<f64>,
}

impl Assembled {
    /// An empty problem (no edges) on a w × h grid.
    pub fn new(w: usize, h: usize) -> Self {
        Assembled {
            w,
            h,
            east: vec![0.0; w * h],
            south: vec![0.0; w * h],
            rhs: vec![0.0; w * h],
            mass: vec![0.0; w * h],
        }
    }

    /// Add the term wt · (z_j − z_i − g)² for the edge from i to j = i + 1 (`east`) or
    /// j = i + w.
    #[inline]
    pub fn add_edge(&mut self, i: usize, east: bool, wt: f64, g: f64) {
        let j = if east { i + 1 } else { i + self.w };
        if east {
            self.east[i] += wt;
        } else {
            self.south[i] += wt;
        }
        self.rhs[i] -= wt * g;
        self.rhs[j] += wt * g;
    }

    /// Pin the first pixel (raster order) of every connected part with a mass equal to
    /// its edge weights (1 for an isolated pixel).
    pub fn pin(&mut self, comps: &Components) {
        let w = self.w;
        let mut pinned = vec![false; comps.count];
        for (i, &l) in comps.labels.iter().enumerate() {
            if l == u32::MAX || pinned[l as usize] {
                continue;
            }
            pinned[l as usize] = true;
            let (r, c) = (i / w, i % w);
            let mut d = self.east[i] + self.south[i];
            if c > 0 {
                d += self.east[i - 1];
            }
            if r > 0 {
                d += self.south[i - w];
            }
            self.mass[i] = if d > 0.0 { d } else { 1.0 };
        }
    }

    /// Solve by multigrid CG from `z` (a warm start, or zeros); Cholesky when CG does
    /// not converge. Returns the CG iterations (0 after the fallback).
    pub fn solve(&self, z: &mut [f64], tol: f64, mask: &Mask) -> Result<usize> {
        let sys = System::new(self.w, self.h, &self.east, &self.south, &self.mass);
        let out = sys.solve(&self.rhs, z, tol, MAX_ITER);
        if out.relative_residual <= tol.max(1e-12) * 10.0 {
            return Ok(out.iterations);
        }
        let exact = self.cholesky(mask)?;
        z.copy_from_slice(&exact);
        Ok(0)
    }

    /// Exact solve by sparse Cholesky (the fallback).
    fn cholesky(&self, mask: &Mask) -> Result<Vec<f64>> {
        let w = self.w;
        let mut index = vec![usize::MAX; mask.len()];
        let pixels: Vec<usize> = (0..mask.len()).filter(|&i| mask.data[i]).collect();
        for (k, &i) in pixels.iter().enumerate() {
            index[i] = k;
        }
        let n = pixels.len();
        let (mut col_ptr, mut row_idx, mut vals) = (vec![0usize], Vec::new(), Vec::new());
        // Lower triangle, column k: rows k, right, down (ascending in raster order).
        for &i in &pixels {
            let (r, c) = (i / w, i % w);
            let mut d = self.mass[i] + self.east[i] + self.south[i];
            if c > 0 {
                d += self.east[i - 1];
            }
            if r > 0 {
                d += self.south[i - w];
            }
            row_idx.push(index[i]);
            vals.push(d);
            for (j, wt) in [(i + 1, self.east[i]), (i + w, self.south[i])] {
                if wt != 0.0 && j < mask.len() && index[j] != usize::MAX {
                    row_idx.push(index[j]);
                    vals.push(-wt);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let a = SparseColMatRef::new(sym, &vals);
        let llt = a.sp_cholesky(Side::Lower).map_err(|e| {
            Error::invalid(
                "masked integration",
                format!("sparse Cholesky failed ({e:?}); check the weights for huge values"),
            )
        })?;
        let mut x: Vec<f64> = pixels.iter().map(|&i| self.rhs[i]).collect();
        llt.solve_in_place(MatMut::from_column_major_slice_mut(&mut x, n, 1));
        let mut z = vec![0.0; mask.len()];
        for (k, &i) in pixels.iter().enumerate() {
            z[i] = x[k];
        }
        Ok(z)
    }
}

/// The normal equations of the masked problem directly on the padded grid of
/// [`System`] (stride w + 2; f32 weights, f64 right-hand side) and the pins.
struct Padded {
    east: Buf<f32>,
    south: Buf<f32>,
    rhs: Buf<f64>,
    pins: Vec<(usize, f64)>,
}

impl Padded {
    /// Assembled on the window `win` of the grid (the mask's bounding box: the solver's
    /// cost is per cell of its grid, and pixels outside the mask have no equations).
    fn assemble(
        (p, q): (&[f32], &[f32]),
        mask: &Mask,
        weights: Option<&GrayImage>,
        win: &Window,
    ) -> Self {
        let w = mask.width;
        let s = win.w + 2;
        let n = s * (win.h + 2);
        // Pixel weights only with a map (1 everywhere otherwise).
        let wt = weights.map(|_| pixel_weights(weights, mask));
        let pair = |i: usize, j: usize| wt.as_ref().map_or(1.0, |v| v[i].min(v[j]));
        let prior = weights.is_some();
        let (mut east, mut south) = (filled(n, 0.0f32), filled(n, 0.0f32));
        // Updated in place (read, then written): zeroed by writing (see `pages::filled`).
        let mut rhs = filled(n, 0.0);
        // Neighbours past the window's right or lower side are outside the mask.
        let (c_end, r_end) = (win.c0 + win.w, win.r0 + win.h);
        for r in win.r0..r_end {
            for c in win.c0..c_end {
                let i = r * w + c;
                let k = (r - win.r0 + 1) * s + c - win.c0 + 1;
                if !mask.data[i] {
                    continue;
                }
                if c + 1 < c_end && mask.data[i + 1] {
                    let g = 0.5 * (p[i] as f64 + p[i + 1] as f64);
                    let (t, g) = with_prior(pair(i, i + 1), g, prior);
                    east[k] = t as f32;
                    rhs[k] -= t * g;
                    rhs[k + 1] += t * g;
                }
                if r + 1 < r_end && mask.data[i + w] {
                    let g = -0.5 * (q[i] as f64 + q[i + w] as f64);
                    let (t, g) = with_prior(pair(i, i + w), g, prior);
                    south[k] = t as f32;
                    rhs[k] -= t * g;
                    rhs[k + s] += t * g;
                }
            }
        }
        Padded {
            east,
            south,
            rhs,
            pins: Vec::new(),
        }
    }

    /// Pin the first pixel of every part as [`Assembled::pin`] does.
    fn pin(&mut self, comps: &Components, win: &Window) {
        let (w, s) = (win.full_w, win.w + 2);
        let mut pinned = vec![false; comps.count];
        for (i, &l) in comps.labels.iter().enumerate() {
            if l == u32::MAX || pinned[l as usize] {
                continue;
            }
            pinned[l as usize] = true;
            // Every mask pixel is inside the window.
            let k = (i / w - win.r0 + 1) * s + i % w - win.c0 + 1;
            let (e, so) = (&self.east, &self.south);
            let d = [e[k], e[k - 1], so[k], so[k - s]]
                .iter()
                .map(|&v| v as f64)
                .sum::<f64>();
            self.pins.push((k, if d > 0.0 { d } else { 1.0 }));
        }
    }

    /// The same problem on the unpadded grid (for the Cholesky fallback).
    fn unpadded(&self, w: usize, h: usize) -> Assembled {
        let s = w + 2;
        let mut a = Assembled::new(w, h);
        for r in 0..h {
            for c in 0..w {
                let (i, k) = (r * w + c, (r + 1) * s + c + 1);
                a.east[i] = self.east[k] as f64;
                a.south[i] = self.south[k] as f64;
                a.rhs[i] = self.rhs[k];
            }
        }
        for &(k, m) in &self.pins {
            a.mass[(k / s - 1) * w + k % s - 1] = m;
        }
        a
    }
}

/// Makes the (sanitised) gradient planes p, q again.
pub(crate) type Remake<'a> = &'a (dyn Fn() -> (Vec<f32>, Vec<f32>) + Sync);

/// The gradient planes for [`integrate`]: kept by the caller, or handed over with a way
/// to make them again, so that they are freed while the solver runs (the peak of a big
/// run: two planes of 4 B per pixel, 134 MB at 4096²).
pub(crate) enum Gradients<'a> {
    Kept(&'a [f32], &'a [f32]),
    Handed(Vec<f32>, Vec<f32>, Remake<'a>),
}

/// [`integrate`] on the planes p, q: handed over (and made again afterwards) when both
/// are owned and a `remake` is given, else kept by the caller.
pub(crate) fn integrate_planes(
    (p, q, remake): (&mut Cow<'_, [f32]>, &mut Cow<'_, [f32]>, Option<Remake<'_>>),
    mask: &Mask,
    weights: Option<&GrayImage>,
    comps: &Components,
    progress: &dyn Progress,
) -> Result<(Vec<f32>, usize)> {
    if let (Some(remake), Cow::Owned(pv), Cow::Owned(qv)) = (remake, &mut *p, &mut *q) {
        let grads = Gradients::Handed(std::mem::take(pv), std::mem::take(qv), remake);
        let solved = integrate(grads, mask, weights, comps, progress)?;
        let (pv, qv) = remake();
        (*p, *q) = (Cow::Owned(pv), Cow::Owned(qv));
        return Ok(solved);
    }
    integrate(Gradients::Kept(p, q), mask, weights, comps, progress)
}

/// Solve the masked problem; returns depth on the whole grid (0 outside the mask) and
/// the CG iterations.
pub(crate) fn integrate(
    grads: Gradients<'_>,
    mask: &Mask,
    weights: Option<&GrayImage>,
    comps: &Components,
    progress: &dyn Progress,
) -> Result<(Vec<f32>, usize)> {
    let (w, h) = (mask.width, mask.height);
    let win = Window::around(mask);
    let s = win.w + 2;
    progress.start("lsq: assemble, solve", 2);
    // handed-over planes are dropped at the end of their arm, before the solve
    let (mut sys, source) = match grads {
        Gradients::Kept(p, q) => (Padded::assemble((p, q), mask, weights, &win), Ok((p, q))),
        Gradients::Handed(p, q, remake) => {
            (Padded::assemble((&p, &q), mask, weights, &win), Err(remake))
        }
    };
    sys.pin(comps, &win);
    progress.advance(1);
    // CG's first access to x is x ← x + α p (a read): zeroed by writing.
    let mut x = filled(sys.rhs.len(), 0.0);
    let Padded {
        east,
        south,
        rhs,
        pins,
    } = sys;
    let solver = System::from_padded(win.w, win.h, east, south, pins);
    let out = solver.solve_padded(rhs, &mut x, false, TOL, MAX_ITER);
    let (z, iterations) = if out.relative_residual <= TOL * 10.0 {
        let mut z = vec![0.0f32; w * h];
        for r in 0..win.h {
            let row = &x[(r + 1) * s + 1..(r + 1) * s + 1 + win.w];
            let start = (win.r0 + r) * w + win.c0;
            z[start..start + win.w]
                .iter_mut()
                .zip(row)
                .for_each(|(o, &v)| *o = v as f32);
        }
        (z, out.iterations)
    } else {
        // CG did not converge (not seen; see the module documentation): assemble again
        // for the exact solver.
        let mut again = match source {
            Ok((p, q)) => Padded::assemble((p, q), mask, weights, &win),
            Err(remake) => {
                let (p, q) = remake();
                Padded::assemble((&p, &q), mask, weights, &win)
            }
        };
        again.pin(comps, &win);
        let exact = again.unpadded(win.w, win.h).cholesky(&win.mask(mask))?;
        let exact: Vec<f32> = exact.iter().map(|&v| v as f32).collect();
        (win.put(&exact, 0.0), 0)
    };
    progress.advance(1);
    progress.finish();
    Ok((z, iterations))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use crate::integrate::label_components;
    use crate::progress::NoProgress;

    /// An object in a corner of a bigger image, in two parts: the solve on its bounding
    /// box (multigrid CG) and the exact fallback on the same box agree, and both leave
    /// the pixels outside the mask at 0.
    #[test]
    fn boxed_solve_matches_the_exact_fallback() {
        let (w, h) = (40, 30);
        let mask: Mask = Image::from_fn(w, h, |r, c| {
            (5..17).contains(&r) && (22..37).contains(&c) && c != 29
        });
        let p: Vec<f32> = (0..w * h).map(|i| ((i % w) as f32 * 0.1).sin()).collect();
        let q: Vec<f32> = (0..w * h).map(|i| ((i / w) as f32 * 0.07).cos()).collect();
        let comps = label_components(&mask);
        assert_eq!(comps.count, 2);
        let grads = Gradients::Kept(&p, &q);
        let (z, iterations) = integrate(grads, &mask, None, &comps, &NoProgress).unwrap();
        assert!(iterations > 0);
        let win = Window::around(&mask);
        assert_eq!((win.c0, win.r0, win.w, win.h), (22, 5, 15, 12));
        let mut sys = Padded::assemble((&p, &q), &mask, None, &win);
        sys.pin(&comps, &win);
        let exact = sys
            .unpadded(win.w, win.h)
            .cholesky(&win.mask(&mask))
            .unwrap();
        let exact = win.put(&exact, 0.0);
        for i in 0..w * h {
            if mask.data[i] {
                assert!(
                    (z[i] as f64 - exact[i]).abs() < 1e-4,
                    "{i}: {} {}",
                    z[i],
                    exact[i]
                );
            } else {
                assert_eq!((z[i], exact[i]), (0.0, 0.0), "{i}");
            }
        }
    }
}
