//! The quadratic spatial problem and its coarse-to-fine conjugate-gradient solution.
//!
//! Unknowns u_i = (n_x, n_y) at the mask pixels; energy
//! E(u) = Σ_i (u_i − û_i)ᵀ A_i (u_i − û_i) + λ Σ_t ω_t ‖u_a − 2u_b + u_c‖²
//! over the triples t = (a, b, c) of consecutive mask pixels along rows and columns.
//! The normal equations (A + λ DᵀΩD) u = A û are solved by conjugate gradients with a
//! block-Jacobi (2×2) preconditioner, matrix-free, row-parallel. Coarse-to-fine
//! (cascadic): each coarser level sums the information of 2×2 pixels (A_c = Σ A,
//! b_c = Σ A û; λ_c = λ/4 keeps the energy of a smooth field), is solved first, and its
//! solution, interpolated, starts the finer level, so that wide regions without
//! evidence are filled in a few iterations per level.
//!
//! **Memory**: a level stores its unknowns, information and right-hand side per *mask*
//! pixel (row-major order), with one index per grid pixel to find neighbours; the
//! conjugate-gradient loop keeps four vectors (x, r, p, Ap) and evaluates the second
//! differences and the block-Jacobi preconditioner on the fly. On a 4096² capture whose
//! mask covers 58% of the image this is what brought the run's peak under the issue 26
//! budget (docs/benchmarks.md, "Big captures").

use rayon::prelude::*;

/// Levels stop halving below this side (pixels).
const COARSEST_SIDE: usize = 24;
/// Iterations on the coarsest level.
const COARSE_ITERATIONS: usize = 300;
/// Relative residual ‖r‖/‖b‖ below which a level may stop (see [`converged`]).
const TOLERANCE: f64 = 1e-5;
/// Mean squared correction, in units of each pixel's posterior variance (zᵀ M z with
/// z = M⁻¹ r the block-Jacobi step), that the pixels may still ask for when a level
/// stops (see [`converged`]): 1e-4 = an RMS correction of a hundredth of a standard
/// error. Measured (2026-12-04): the same errors as a bound of 0.01 on the *largest*
/// correction (`tests/camera_images.rs`, every row within 0.001°), at half its extra
/// cost on 2048² renders (`normals` wall time over the relative-residual test alone:
/// clean metal +11% against +23%, blurred 8-bit plastic +10% against +35%; medians of
/// three alternated runs, docs/benchmarks.md, "Spatial stage"); 1e-3 is
/// cheaper still but gives back part of the gain (8-bit metal 0.273 → 0.281°).
const STEP_TOLERANCE: f64 = 1e-4;
/// Ridge (× λ) that pulls every pixel towards its own solution A⁻¹b (0 where it has no
/// evidence): it only keeps the system definite where no pixel carries evidence (an
/// isolated pixel without data has no prior term either). It must stay far below the
/// prior over the widest region without evidence: on a band L px wide a smooth bend δ
/// costs the prior about λδ²/L³ per line and the ridge ridge·L·δ², a ratio ridge·L⁴.
/// At 1e-3 (until 2026-12-06) that ratio was ≈ 800 over the 30 px dark rim of an 8-bit
/// metal, which the prior should continue from the lit inside to the contour: the ridge
/// pulled those pixels to their scattered matches (or, with no information, to a
/// normal facing the camera). Measured (`examples/camera_metals`, GGX metal F₀ 0.9,
/// 8-bit exposed for the peak, 256² blob, sphere r 100): α 0.15 (37% of the pixels
/// below 6 levels in every image) 1.740° → 0.774° (1e-5: 0.88°), α 0.1 (true circle)
/// 17.9° → 1.04°, α 0.15 blurred 0.8 px with a 3% black level (true circle) 2.40° →
/// 0.84°; `tests/camera_images.rs` within +0.008° (8-bit metal α 0.2 0.264 → 0.271°)
/// and −0.015° (8-bit Lambertian clipped), the noise sweep's metal at 1% 1.394 →
/// 1.392°. At 1e-7 the ratio passes 1 on bands wider than about 55 px, yet on a 1024²
/// render of the α 0.15 metal (a rim about 120 px wide) 1e-9 and 0 were no better
/// (1.545° at 1e-7, 1.572° / 1.590°): there the error is in the dark pixels returned to
/// their scattered matches and in those with no information at all, not the ridge
/// (docs/accuracy.md, "Refit without the rejected pixels").
const RIDGE: f32 = 1e-7;
/// Index of a grid pixel outside the mask.
const NONE: u32 = u32::MAX;
/// Bit of [`Level::tri`]: the row triple centred at the pixel is in the prior.
const ROW: u8 = 1;
/// Bit of [`Level::tri`]: the column triple centred at the pixel is in the prior.
const COL: u8 = 2;

/// Information A, matches û and gradient g (empty: zero) of the evidence over the grid.
pub(crate) type Fields<'a> = (&'a [[f32; 3]], &'a [[f32; 2]], &'a [[f32; 2]]);

/// One level of the problem: arrays over its mask pixels in row-major order.
#[derive(Clone, Debug)]
pub(crate) struct Level {
    pub w: usize,
    pub h: usize,
    /// Index among the mask pixels of each grid pixel ([`NONE`] outside the mask).
    idx: Vec<u32>,
    /// Index of the first mask pixel of each row (h + 1 entries).
    starts: Vec<usize>,
    /// Information matrices (A₁₁, A₁₂, A₂₂), ridge included.
    pub a: Vec<[f32; 3]>,
    /// Right-hand side A û.
    pub b: Vec<[f32; 2]>,
    /// [`ROW`] and [`COL`]: which triples centred at the pixel carry the prior (weight λ).
    tri: Vec<u8>,
    /// Prior weight λ of this level.
    pub lambda: f32,
}

/// The mask pixels' indices of a grid (`idx`, `starts` of [`Level`]).
fn index(mask: &[bool], w: usize, h: usize) -> (Vec<u32>, Vec<usize>) {
    let mut idx = vec![NONE; w * h];
    let mut starts = Vec::with_capacity(h + 1);
    let mut n = 0usize;
    for r in 0..h {
        starts.push(n);
        for (i, &m) in mask[r * w..(r + 1) * w].iter().enumerate() {
            if m {
                idx[r * w + i] = n as u32;
                n += 1;
            }
        }
    }
    starts.push(n);
    (idx, starts)
}

impl Level {
    /// Number of mask pixels.
    pub fn len(&self) -> usize {
        self.starts[self.h]
    }

    /// Index among the mask pixels of grid pixel `i`, if in the mask.
    pub fn at(&self, i: usize) -> Option<usize> {
        let j = self.idx[i];
        (j != NONE).then_some(j as usize)
    }

    /// `out[j] = f(row, column, grid index, j)` for every mask pixel j, rows in parallel.
    pub fn each<T: Send>(&self, out: &mut [T], f: impl Fn(usize, usize, usize, usize) -> T + Sync) {
        let mut rows: Vec<&mut [T]> = Vec::with_capacity(self.h);
        let mut rest = out;
        for r in 0..self.h {
            let (row, more) = rest.split_at_mut(self.starts[r + 1] - self.starts[r]);
            rows.push(row);
            rest = more;
        }
        let w = self.w;
        rows.into_par_iter().enumerate().for_each(|(r, row)| {
            let mut k = 0;
            for c in 0..w {
                let i = r * w + c;
                if let Some(j) = self.at(i) {
                    row[k] = f(r, c, i, j);
                    k += 1;
                }
            }
        });
    }

    /// The finest level from the evidence: information `a`, matches `u` and gradient
    /// `g` (empty: zero) over the grid, `extra` (grid index, ΔA, Δb) added to a pixel's
    /// cost (the contour prior); `pair_ok(i, j, step)` says whether neighbours i and
    /// j = i + step may be smoothed together (no evidence of a discontinuity); each
    /// pixel's cost (its own and `extra`) multiplied by `scale(i)` (the local prior
    /// scale, [`super::roughness`]).
    pub fn finest(
        (w, h): (usize, usize),
        mask: &[bool],
        (a, u, g): Fields,
        extra: &[(usize, [f32; 3], [f32; 2])],
        (lambda, scale): (f32, impl Fn(usize) -> f32 + Sync),
        pair_ok: impl Fn(usize, usize, usize) -> bool + Sync,
    ) -> Level {
        let (idx, starts) = index(mask, w, h);
        let n = starts[h];
        let mut l = Level {
            w,
            h,
            idx,
            starts,
            a: vec![[0.0; 3]; n],
            b: vec![[0.0; 2]; n],
            tri: vec![0; n],
            lambda,
        };
        let mut ab = vec![([0.0f32; 3], [0.0f32; 2]); n];
        l.each(&mut ab, |_, _, i, _| {
            let (a, u) = (a[i], u[i]);
            let mut b = [a[0] * u[0] + a[1] * u[1], a[1] * u[0] + a[2] * u[1]];
            if let Some(g) = g.get(i) {
                b = [b[0] + g[0], b[1] + g[1]];
            }
            let s = scale(i);
            ([s * a[0], s * a[1], s * a[2]], [s * b[0], s * b[1]])
        });
        for &(i, da, db) in extra {
            if let Some(j) = l.at(i) {
                let s = scale(i);
                let (a, b) = &mut ab[j];
                *a = [a[0] + s * da[0], a[1] + s * da[1], a[2] + s * da[2]];
                *b = [b[0] + s * db[0], b[1] + s * db[1]];
            }
        }
        // the ridge pulls towards the pixel's own solution A⁻¹b
        let ridge = RIDGE * lambda;
        for ((dst_a, dst_b), (a, b)) in l.a.iter_mut().zip(l.b.iter_mut()).zip(ab) {
            let own = own_solution(a, b);
            *dst_a = [a[0] + ridge, a[1], a[2] + ridge];
            *dst_b = [b[0] + ridge * own[0], b[1] + ridge * own[1]];
        }
        let triple = |i: usize, step: usize| -> bool {
            mask[i - step]
                && mask[i + step]
                && pair_ok(i - step, i, step)
                && pair_ok(i, i + step, step)
        };
        let mut tri = vec![0u8; n];
        l.each(&mut tri, |r, c, i, _| {
            let row = c > 0 && c + 1 < w && triple(i, 1);
            let col = r > 0 && r + 1 < h && triple(i, w);
            u8::from(row) * ROW + u8::from(col) * COL
        });
        l.tri = tri;
        l
    }

    /// Whether the row (`bit` [`ROW`]) or column triple centred at grid pixel `i` is in
    /// the prior (false outside the mask).
    fn has(&self, i: usize, bit: u8) -> bool {
        self.at(i).is_some_and(|j| self.tri[j] & bit != 0)
    }

    /// The next coarser level (2×2 pixels → 1).
    pub fn coarser(&self) -> Level {
        let (w, h) = (self.w.div_ceil(2), self.h.div_ceil(2));
        let coarse_of = |i: usize| (i / self.w / 2) * w + (i % self.w) / 2;
        let mut mask = vec![false; w * h];
        for i in (0..self.w * self.h).filter(|&i| self.idx[i] != NONE) {
            mask[coarse_of(i)] = true;
        }
        let (idx, starts) = index(&mask, w, h);
        let n = starts[h];
        let mut a = vec![[0.0f32; 3]; n];
        let mut b = vec![[0.0f32; 2]; n];
        // a coarse triple is cut when any fine triple inside its centre pixel is cut
        let mut cut = vec![0u8; n];
        for r in 0..self.h {
            for c in 0..self.w {
                let i = r * self.w + c;
                let Some(fj) = self.at(i) else { continue };
                let j = idx[coarse_of(i)] as usize;
                for (dst, src) in a[j].iter_mut().zip(self.a[fj]) {
                    *dst += src;
                }
                b[j][0] += self.b[fj][0];
                b[j][1] += self.b[fj][1];
                let in_mask = |i: usize| self.idx[i] != NONE;
                let interior_h = c > 0 && c + 1 < self.w && in_mask(i - 1) && in_mask(i + 1);
                let interior_v =
                    r > 0 && r + 1 < self.h && in_mask(i - self.w) && in_mask(i + self.w);
                if interior_h && self.tri[fj] & ROW == 0 {
                    cut[j] |= ROW;
                }
                if interior_v && self.tri[fj] & COL == 0 {
                    cut[j] |= COL;
                }
            }
        }
        let mut l = Level {
            w,
            h,
            idx,
            starts,
            a,
            b,
            tri: Vec::new(),
            lambda: self.lambda / 4.0,
        };
        let mut tri = vec![0u8; n];
        l.each(&mut tri, |r, c, i, j| {
            let row = c > 0 && c + 1 < w && mask[i - 1] && mask[i + 1];
            let col = r > 0 && r + 1 < h && mask[i - w] && mask[i + w];
            (u8::from(row) * ROW + u8::from(col) * COL) & !cut[j]
        });
        l.tri = tri;
        l
    }

    /// Prior's diagonal at mask pixel j (grid pixel i at row r, column c): Σ over the
    /// triples through it of coefficient² · λ.
    fn prior_diag(&self, (r, c, i, j): (usize, usize, usize, usize)) -> f32 {
        let (w, l) = (self.w, self.lambda);
        let on = |b: bool| if b { l } else { 0.0 };
        let mut d = 4.0 * (on(self.tri[j] & ROW != 0) + on(self.tri[j] & COL != 0));
        if c > 0 {
            d += on(self.has(i - 1, ROW));
        }
        if c + 1 < w {
            d += on(self.has(i + 1, ROW));
        }
        if r > 0 {
            d += on(self.has(i - w, COL));
        }
        if r + 1 < self.h {
            d += on(self.has(i + w, COL));
        }
        d
    }

    /// Share of mask pixel j's own data in its solution ([`leverage`] of its
    /// information); `at` = (row, column, grid index, j).
    pub fn own_share(&self, at: (usize, usize, usize, usize)) -> f32 {
        if self.prior_diag(at) == 0.0 {
            return 1.0;
        }
        let a = self.a[at.3];
        leverage(0.5 * (a[0] + a[2]) / self.lambda)
    }

    /// λ × the second difference of `x` along the row (`bit` [`ROW`], neighbours j ± 1:
    /// a row triple's pixels are consecutive mask pixels) or the column centred at mask
    /// pixel j (grid pixel i); zero where that triple is not in the prior.
    fn second_at(&self, x: &[[f32; 2]], i: usize, j: usize, bit: u8) -> [f32; 2] {
        if self.tri[j] & bit == 0 {
            return [0.0; 2];
        }
        if bit == ROW {
            second(x[j - 1], x[j], x[j + 1], self.lambda)
        } else {
            let (up, down) = (self.idx[i - self.w] as usize, self.idx[i + self.w] as usize);
            second(x[up], x[j], x[down], self.lambda)
        }
    }

    /// y = (A + λDᵀΩD) x.
    fn apply(&self, x: &[[f32; 2]], y: &mut [[f32; 2]]) {
        let w = self.w;
        self.each(y, |r, c, i, j| {
            let (sh, sv) = (self.second_at(x, i, j, ROW), self.second_at(x, i, j, COL));
            let a = self.a[j];
            let mut v = [
                a[0] * x[j][0] + a[1] * x[j][1] - 2.0 * (sh[0] + sv[0]),
                a[1] * x[j][0] + a[2] * x[j][1] - 2.0 * (sh[1] + sv[1]),
            ];
            let mut add = |i: usize, bit: u8| {
                if let Some(k) = self.at(i) {
                    let s = self.second_at(x, i, k, bit);
                    v[0] += s[0];
                    v[1] += s[1];
                }
            };
            if c > 0 {
                add(i - 1, ROW);
            }
            if c + 1 < w {
                add(i + 1, ROW);
            }
            if r > 0 {
                add(i - w, COL);
            }
            if r + 1 < self.h {
                add(i + w, COL);
            }
            v
        });
    }

    /// The 2×2 block-diagonal preconditioner's inverse applied to `r` at mask pixel j.
    fn precondition(&self, at: (usize, usize, usize, usize), r: [f32; 2]) -> [f32; 2] {
        let d = self.prior_diag(at);
        let a = self.a[at.3];
        let (m11, m12, m22) = ((a[0] + d) as f64, a[1] as f64, (a[2] + d) as f64);
        let det = m11 * m22 - m12 * m12;
        let m = if det > 0.0 {
            [(m22 / det) as f32, (-m12 / det) as f32, (m11 / det) as f32]
        } else {
            [0.0; 3]
        };
        [m[0] * r[0] + m[1] * r[1], m[1] * r[0] + m[2] * r[1]]
    }

    /// Preconditioned conjugate gradients from `x` (at most `iterations`; stopping test
    /// [`converged`]); returns the iterations run. The preconditioned residual z is not
    /// stored: it is evaluated where it is used (for rᵀz, then for the new direction).
    pub fn solve(&self, x: &mut [[f32; 2]], iterations: usize) -> usize {
        let n = self.len();
        let mut ax = vec![[0.0f32; 2]; n];
        self.apply(x, &mut ax);
        let mut r: Vec<[f32; 2]> = self
            .b
            .par_iter()
            .zip(&ax)
            .map(|(b, a)| [b[0] - a[0], b[1] - a[1]])
            .collect();
        let bnorm = dot(&self.b, &self.b).sqrt().max(1e-30);
        let mut p = vec![[0.0f32; 2]; n];
        self.each(&mut p, |r0, c, i, j| self.precondition((r0, c, i, j), r[j]));
        let mut rz = dot(&r, &p);
        if converged(&r, rz, bnorm) {
            return 0; // converged already (e.g. clean data: every pixel keeps its match)
        }
        for it in 0..iterations {
            self.apply(&p, &mut ax);
            let pap = dot(&p, &ax);
            if pap.is_nan() || pap <= 0.0 {
                return it;
            }
            let alpha = (rz / pap) as f32;
            x.par_iter_mut()
                .zip(r.par_iter_mut())
                .zip(p.par_iter().zip(&ax))
                .for_each(|((xi, ri), (pi, api))| {
                    for t in 0..2 {
                        xi[t] += alpha * pi[t];
                        ri[t] -= alpha * api[t];
                    }
                });
            // z = M⁻¹r into ax (free until the next product), then p = z + βp
            self.each(&mut ax, |r0, c, i, j| {
                self.precondition((r0, c, i, j), r[j])
            });
            let rz_new = dot(&r, &ax);
            if converged(&r, rz_new, bnorm) {
                return it + 1;
            }
            let beta = (rz_new / rz.max(1e-300)) as f32;
            rz = rz_new;
            p.par_iter_mut().zip(&ax).for_each(|(pi, zi)| {
                pi[0] = zi[0] + beta * pi[0];
                pi[1] = zi[1] + beta * pi[1];
            });
        }
        iterations
    }

    /// Initial guess on this level from the coarser level's solution `xc` (bilinear
    /// interpolation over the coarse mask pixels), blended with the own match where the
    /// pixel's own information dominates.
    pub fn start_from(&self, coarse: &Level, xc: &[[f32; 2]]) -> Vec<[f32; 2]> {
        let mut x = vec![[0.0f32; 2]; self.len()];
        self.each(&mut x, |r, c, i, j| {
            let prol = interpolate(coarse, xc, r, c);
            let a = self.a[j];
            let d = self.prior_diag((r, c, i, j));
            let own = own_solution(a, self.b[j]);
            // weights: own information vs the prior's
            let (ta, td) = ((a[0] + a[2]) * 0.5, d);
            let t = if ta + td > 0.0 { ta / (ta + td) } else { 0.0 };
            [
                t * own[0] + (1.0 - t) * prol[0],
                t * own[1] + (1.0 - t) * prol[1],
            ]
        });
        x
    }

    /// The own matches û = A⁻¹ b (the start of the coarsest level).
    pub fn own(&self) -> Vec<[f32; 2]> {
        self.a
            .iter()
            .zip(&self.b)
            .map(|(a, b)| own_solution(*a, *b))
            .collect()
    }

    /// Triples inside the mask (all three pixels in it) that were cut.
    pub fn cut_triples(&self) -> usize {
        let mut cuts = vec![false; self.len()];
        let (w, h) = (self.w, self.h);
        let inside = |i: usize| self.idx[i] != NONE;
        self.each(&mut cuts, |r, c, i, j| {
            let h_in = c > 0 && c + 1 < w && inside(i - 1) && inside(i + 1);
            let v_in = r > 0 && r + 1 < h && inside(i - w) && inside(i + w);
            (h_in && self.tri[j] & ROW == 0) || (v_in && self.tri[j] & COL == 0)
        });
        cuts.iter().filter(|&&c| c).count()
    }
}

/// Leverage ∂u_i/∂û_i of a pixel of information a = ρ·λ among neighbours of the same
/// information: the mean over frequencies ω of ρ / (ρ + s(ω)), s the symbol
/// (2 − 2cos ω_x)² + (2 − 2cos ω_y)² of the prior (tabulated in log₂ ρ, interpolated).
pub(crate) fn leverage(rho: f32) -> f32 {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    const LO: f32 = -20.0;
    const HI: f32 = 20.0;
    const STEPS: usize = 81;
    let table = TABLE.get_or_init(|| {
        let n = 48;
        let sym: Vec<f64> = (0..n * n)
            .map(|i| {
                let wx = std::f64::consts::TAU * ((i % n) as f64 + 0.5) / n as f64;
                let wy = std::f64::consts::TAU * ((i / n) as f64 + 0.5) / n as f64;
                (2.0 - 2.0 * wx.cos()).powi(2) + (2.0 - 2.0 * wy.cos()).powi(2)
            })
            .collect();
        (0..STEPS)
            .map(|j| {
                let rho = 2f64.powf((LO + (HI - LO) * j as f32 / (STEPS - 1) as f32) as f64);
                (sym.iter().map(|s| rho / (rho + s)).sum::<f64>() / sym.len() as f64) as f32
            })
            .collect()
    });
    if rho.is_nan() || rho <= 0.0 {
        return 0.0;
    }
    let t = ((rho.log2() - LO) / (HI - LO) * (STEPS - 1) as f32).clamp(0.0, (STEPS - 1) as f32);
    let j = (t.floor() as usize).min(STEPS - 2);
    let f = t - j as f32;
    table[j] * (1.0 - f) + table[j + 1] * f
}

/// Number of CG iterations on the coarsest level.
pub(crate) fn coarse_iterations() -> usize {
    COARSE_ITERATIONS
}

/// Whether a level of this size gets a coarser one.
pub(crate) fn has_coarser(w: usize, h: usize) -> bool {
    w.min(h) > COARSEST_SIDE
}

fn own_solution(a: [f32; 3], b: [f32; 2]) -> [f32; 2] {
    let det = a[0] as f64 * a[2] as f64 - (a[1] as f64).powi(2);
    if det > 0.0 {
        [
            ((a[2] as f64 * b[0] as f64 - a[1] as f64 * b[1] as f64) / det) as f32,
            ((a[0] as f64 * b[1] as f64 - a[1] as f64 * b[0] as f64) / det) as f32,
        ]
    } else {
        [0.0; 2]
    }
}

/// Bilinear interpolation of the coarse solution at fine pixel (r, c), over coarse mask
/// pixels only.
fn interpolate(coarse: &Level, xc: &[[f32; 2]], r: usize, c: usize) -> [f32; 2] {
    let fy = (r as f32 + 0.5) / 2.0 - 0.5;
    let fx = (c as f32 + 0.5) / 2.0 - 0.5;
    let (y0, x0) = (fy.floor(), fx.floor());
    let (ty, tx) = (fy - y0, fx - x0);
    let mut acc = [0.0f32; 2];
    let mut wsum = 0.0f32;
    for (dy, wy) in [(0i64, 1.0 - ty), (1, ty)] {
        for (dx, wx) in [(0i64, 1.0 - tx), (1, tx)] {
            let (rr, cc) = (y0 as i64 + dy, x0 as i64 + dx);
            if rr < 0 || cc < 0 || rr >= coarse.h as i64 || cc >= coarse.w as i64 {
                continue;
            }
            let wgt = wy * wx;
            match coarse.at(rr as usize * coarse.w + cc as usize) {
                Some(j) if wgt > 0.0 => {
                    acc[0] += wgt * xc[j][0];
                    acc[1] += wgt * xc[j][1];
                    wsum += wgt;
                }
                _ => {}
            }
        }
    }
    if wsum > 0.0 {
        [acc[0] / wsum, acc[1] / wsum]
    } else {
        // the coarse pixel holding (r, c) is in the coarse mask
        let i = (r / 2).min(coarse.h - 1) * coarse.w + (c / 2).min(coarse.w - 1);
        coarse.at(i).map_or([0.0; 2], |j| xc[j])
    }
}

#[inline]
fn second(a: [f32; 2], b: [f32; 2], c: [f32; 2], l: f32) -> [f32; 2] {
    [
        l * (a[0] - 2.0 * b[0] + c[0]),
        l * (a[1] - 2.0 * b[1] + c[1]),
    ]
}

/// Whether conjugate gradients may stop at residual `r`, `rz` = rᵀM⁻¹r being the
/// preconditioned residual's product: the relative residual is below [`TOLERANCE`]
/// *and* the pixels' own corrections z = M⁻¹r are, on average, a small fraction of their
/// posterior standard errors (rᵀz / n = mean zᵀMz below [`STEP_TOLERANCE`]). The first
/// alone is a norm dominated by the best-lit pixels (A spans ten orders of magnitude on
/// a clean 16-bit capture): it called a level solved while the dim rim of a clean metal
/// still sat where the coarser level's interpolation had put it, about one standard
/// error (0.05–0.1°) from its solution.
fn converged(r: &[[f32; 2]], rz: f64, bnorm: f64) -> bool {
    rz / (r.len().max(1) as f64) < STEP_TOLERANCE && dot(r, r).sqrt() / bnorm < TOLERANCE
}

fn dot(a: &[[f32; 2]], b: &[[f32; 2]]) -> f64 {
    a.par_chunks(4096)
        .zip(b.par_chunks(4096))
        .map(|(x, y)| {
            x.iter()
                .zip(y)
                .map(|(p, q)| p[0] as f64 * q[0] as f64 + p[1] as f64 * q[1] as f64)
                .sum::<f64>()
        })
        .sum()
}
