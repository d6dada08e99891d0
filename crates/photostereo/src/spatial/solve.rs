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

use rayon::prelude::*;

/// Levels stop halving below this side (pixels).
const COARSEST_SIDE: usize = 24;
/// Iterations on the coarsest level.
const COARSE_ITERATIONS: usize = 300;
/// Relative residual ‖r‖/‖b‖ at which a level stops.
const TOLERANCE: f64 = 1e-5;
/// Ridge (× λ) that pulls every pixel towards its own match (keeps the system definite
/// where no pixel carries evidence).
const RIDGE: f32 = 1e-3;

/// One level of the problem (dense arrays over its grid, zero outside the mask).
#[derive(Clone, Debug)]
pub(crate) struct Level {
    pub w: usize,
    pub h: usize,
    pub mask: Vec<bool>,
    /// Information matrices (A₁₁, A₁₂, A₂₂), ridge included.
    pub a: Vec<[f32; 3]>,
    /// Right-hand side A û.
    pub b: Vec<[f32; 2]>,
    /// λ·ω of the row triple centred at each pixel (0 where there is none).
    pub wh: Vec<f32>,
    /// λ·ω of the column triple centred at each pixel.
    pub wv: Vec<f32>,
    /// Prior weight λ of this level.
    pub lambda: f32,
}

impl Level {
    /// The finest level from the evidence; `pair_ok(i, j)` says whether neighbours i
    /// and j may be smoothed together (no evidence of a discontinuity between them).
    pub fn finest(
        (w, h): (usize, usize),
        mask: &[bool],
        (a, b): (&[[f32; 3]], &[[f32; 2]]),
        lambda: f32,
        pair_ok: impl Fn(usize, usize, usize) -> bool + Sync,
    ) -> Level {
        let ridge = RIDGE * lambda;
        let mut a: Vec<[f32; 3]> = a.to_vec();
        let mut b: Vec<[f32; 2]> = b.to_vec();
        for ((a, b), &m) in a.iter_mut().zip(b.iter_mut()).zip(mask) {
            if m {
                // the ridge pulls towards the pixel's own solution A⁻¹b
                let own = own_solution(*a, *b);
                *a = [a[0] + ridge, a[1], a[2] + ridge];
                *b = [b[0] + ridge * own[0], b[1] + ridge * own[1]];
            } else {
                *a = [0.0; 3];
                *b = [0.0; 2];
            }
        }
        let triple = |i: usize, step: usize| -> f32 {
            let ok = mask[i - step] && mask[i] && mask[i + step];
            if ok && pair_ok(i - step, i, step) && pair_ok(i, i + step, step) {
                lambda
            } else {
                0.0
            }
        };
        let mut wh = vec![0.0f32; w * h];
        let mut wv = vec![0.0f32; w * h];
        wh.par_chunks_mut(w)
            .zip(wv.par_chunks_mut(w))
            .enumerate()
            .for_each(|(r, (hrow, vrow))| {
                for c in 0..w {
                    let i = r * w + c;
                    if c > 0 && c + 1 < w {
                        hrow[c] = triple(i, 1);
                    }
                    if r > 0 && r + 1 < h {
                        vrow[c] = triple(i, w);
                    }
                }
            });
        Level {
            w,
            h,
            mask: mask.to_vec(),
            a,
            b,
            wh,
            wv,
            lambda,
        }
    }

    /// The next coarser level (2×2 pixels → 1).
    pub fn coarser(&self) -> Level {
        let (w, h) = (self.w.div_ceil(2), self.h.div_ceil(2));
        let mut mask = vec![false; w * h];
        let mut a = vec![[0.0f32; 3]; w * h];
        let mut b = vec![[0.0f32; 2]; w * h];
        // a coarse triple is cut when any fine triple inside its centre pixel is cut
        let mut cut_h = vec![false; w * h];
        let mut cut_v = vec![false; w * h];
        for r in 0..self.h {
            for c in 0..self.w {
                let (i, j) = (r * self.w + c, (r / 2) * w + c / 2);
                if !self.mask[i] {
                    continue;
                }
                mask[j] = true;
                for (dst, src) in a[j].iter_mut().zip(self.a[i]) {
                    *dst += src;
                }
                b[j][0] += self.b[i][0];
                b[j][1] += self.b[i][1];
                let interior_h = c > 0 && c + 1 < self.w && self.mask[i - 1] && self.mask[i + 1];
                let interior_v =
                    r > 0 && r + 1 < self.h && self.mask[i - self.w] && self.mask[i + self.w];
                cut_h[j] |= interior_h && self.wh[i] == 0.0;
                cut_v[j] |= interior_v && self.wv[i] == 0.0;
            }
        }
        let lambda = self.lambda / 4.0;
        let mut wh = vec![0.0f32; w * h];
        let mut wv = vec![0.0f32; w * h];
        for r in 0..h {
            for c in 0..w {
                let i = r * w + c;
                if c > 0 && c + 1 < w && mask[i - 1] && mask[i] && mask[i + 1] && !cut_h[i] {
                    wh[i] = lambda;
                }
                if r > 0 && r + 1 < h && mask[i - w] && mask[i] && mask[i + w] && !cut_v[i] {
                    wv[i] = lambda;
                }
            }
        }
        Level {
            w,
            h,
            mask,
            a,
            b,
            wh,
            wv,
            lambda,
        }
    }

    /// Prior's diagonal at pixel i: Σ over the triples through i of coefficient² · λω.
    fn prior_diag(&self, i: usize) -> f32 {
        let (w, r, c) = (self.w, i / self.w, i % self.w);
        let mut d = 4.0 * (self.wh[i] + self.wv[i]);
        if c > 0 {
            d += self.wh[i - 1];
        }
        if c + 1 < w {
            d += self.wh[i + 1];
        }
        if r > 0 {
            d += self.wv[i - w];
        }
        if r + 1 < self.h {
            d += self.wv[i + w];
        }
        d
    }

    /// Share of pixel i's own data in its solution ([`leverage`] of its information).
    pub fn own_share(&self, i: usize) -> f32 {
        if self.prior_diag(i) == 0.0 {
            return 1.0;
        }
        leverage(0.5 * (self.a[i][0] + self.a[i][2]) / self.lambda)
    }

    /// y = (A + λDᵀΩD) x, with `s` (two buffers) as scratch for the second differences.
    fn apply(&self, x: &[[f32; 2]], s: &mut [Vec<[f32; 2]>; 2], y: &mut [[f32; 2]]) {
        let w = self.w;
        let [sh, sv] = s;
        sh.par_chunks_mut(w)
            .zip(sv.par_chunks_mut(w))
            .enumerate()
            .for_each(|(r, (hrow, vrow))| {
                for c in 0..w {
                    let i = r * w + c;
                    let (lh, lv) = (self.wh[i], self.wv[i]);
                    hrow[c] = if lh > 0.0 {
                        second(x[i - 1], x[i], x[i + 1], lh)
                    } else {
                        [0.0; 2]
                    };
                    vrow[c] = if lv > 0.0 {
                        second(x[i - w], x[i], x[i + w], lv)
                    } else {
                        [0.0; 2]
                    };
                }
            });
        let (sh, sv) = (&s[0], &s[1]);
        y.par_chunks_mut(w).enumerate().for_each(|(r, row)| {
            for (c, out) in row.iter_mut().enumerate() {
                let i = r * w + c;
                if !self.mask[i] {
                    *out = [0.0; 2];
                    continue;
                }
                let a = self.a[i];
                let mut v = [
                    a[0] * x[i][0] + a[1] * x[i][1] - 2.0 * (sh[i][0] + sv[i][0]),
                    a[1] * x[i][0] + a[2] * x[i][1] - 2.0 * (sh[i][1] + sv[i][1]),
                ];
                let mut addv = |s: [f32; 2]| {
                    v[0] += s[0];
                    v[1] += s[1];
                };
                if c > 0 {
                    addv(sh[i - 1]);
                }
                if c + 1 < w {
                    addv(sh[i + 1]);
                }
                if r > 0 {
                    addv(sv[i - w]);
                }
                if r + 1 < self.h {
                    addv(sv[i + w]);
                }
                *out = v;
            }
        });
    }

    /// Inverse of the 2×2 block-diagonal preconditioner at each pixel.
    fn preconditioner(&self) -> Vec<[f32; 3]> {
        (0..self.w * self.h)
            .into_par_iter()
            .map(|i| {
                if !self.mask[i] {
                    return [0.0; 3];
                }
                let d = self.prior_diag(i);
                let (m11, m12, m22) = (
                    (self.a[i][0] + d) as f64,
                    self.a[i][1] as f64,
                    (self.a[i][2] + d) as f64,
                );
                let det = m11 * m22 - m12 * m12;
                if det > 0.0 {
                    [(m22 / det) as f32, (-m12 / det) as f32, (m11 / det) as f32]
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    }

    /// Preconditioned conjugate gradients from `x` (at most `iterations`); returns the
    /// iterations run.
    pub fn solve(&self, x: &mut [[f32; 2]], iterations: usize) -> usize {
        let n = self.w * self.h;
        let mut s = [vec![[0.0f32; 2]; n], vec![[0.0f32; 2]; n]];
        let mut ax = vec![[0.0f32; 2]; n];
        self.apply(x, &mut s, &mut ax);
        let mut r: Vec<[f32; 2]> = self
            .b
            .par_iter()
            .zip(&ax)
            .map(|(b, a)| [b[0] - a[0], b[1] - a[1]])
            .collect();
        let bnorm = dot(&self.b, &self.b).sqrt().max(1e-30);
        if dot(&r, &r).sqrt() / bnorm < TOLERANCE {
            return 0; // converged already (e.g. clean data: every pixel keeps its match)
        }
        let pre = self.preconditioner();
        let mut z: Vec<[f32; 2]> = mul2(&pre, &r);
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        for it in 0..iterations {
            if dot(&r, &r).sqrt() / bnorm < TOLERANCE {
                return it;
            }
            self.apply(&p, &mut s, &mut ax);
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
            z = mul2(&pre, &r);
            let rz_new = dot(&r, &z);
            let beta = (rz_new / rz.max(1e-300)) as f32;
            rz = rz_new;
            p.par_iter_mut().zip(&z).for_each(|(pi, zi)| {
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
        let w = self.w;
        let mut x = vec![[0.0f32; 2]; w * self.h];
        x.par_chunks_mut(w).enumerate().for_each(|(r, row)| {
            for (c, out) in row.iter_mut().enumerate() {
                let i = r * w + c;
                if !self.mask[i] {
                    continue;
                }
                let prol = interpolate(coarse, xc, r, c);
                let a = self.a[i];
                let d = self.prior_diag(i);
                let own = own_solution(a, self.b[i]);
                // weights: own information vs the prior's
                let (ta, td) = ((a[0] + a[2]) * 0.5, d);
                let t = if ta + td > 0.0 { ta / (ta + td) } else { 0.0 };
                *out = [
                    t * own[0] + (1.0 - t) * prol[0],
                    t * own[1] + (1.0 - t) * prol[1],
                ];
            }
        });
        x
    }

    /// The own matches û = A⁻¹ b (the start of the coarsest level).
    pub fn own(&self) -> Vec<[f32; 2]> {
        (0..self.w * self.h)
            .map(|i| own_solution(self.a[i], self.b[i]))
            .collect()
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
            let j = rr as usize * coarse.w + cc as usize;
            let wgt = wy * wx;
            if coarse.mask[j] && wgt > 0.0 {
                acc[0] += wgt * xc[j][0];
                acc[1] += wgt * xc[j][1];
                wsum += wgt;
            }
        }
    }
    if wsum > 0.0 {
        [acc[0] / wsum, acc[1] / wsum]
    } else {
        xc[(r / 2).min(coarse.h - 1) * coarse.w + (c / 2).min(coarse.w - 1)]
    }
}

#[inline]
fn second(a: [f32; 2], b: [f32; 2], c: [f32; 2], l: f32) -> [f32; 2] {
    [
        l * (a[0] - 2.0 * b[0] + c[0]),
        l * (a[1] - 2.0 * b[1] + c[1]),
    ]
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

fn mul2(m: &[[f32; 3]], r: &[[f32; 2]]) -> Vec<[f32; 2]> {
    m.par_iter()
        .zip(r)
        .map(|(m, r)| [m[0] * r[0] + m[1] * r[1], m[1] * r[0] + m[2] * r[1]])
        .collect()
}
