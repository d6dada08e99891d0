//! What is fitted at one target pixel, and the sub-pixel refinement.
//!
//! A position is a point (gx, gy) on the window grid of the first table (continuous
//! sphere-pixel coordinates). Each table gives its bilinearly interpolated tuple
//! I_j(gx, gy) there (a second table of another radius is reached through the common
//! normal: its grid point is an affine image of the first one's). The model of the
//! target tuple t is p = Σ_j c_j · I_j with
//!
//! * one table, raw matching: c = 1;
//! * one table, normalised matching: c = ⟨t, I⟩ / ⟨I, I⟩ (the albedo ratio), which is
//!   the same as matching t/‖t‖ against I/‖I‖;
//! * two tables (Hertzmann & Seitz 2005): (a, b) ≥ 0 by a 2-variable non-negative
//!   least-squares fit.
//!
//! The cost is the weighted squared residual Σ_i w_i (t_i − p_i)², w_i ∈ {0, 1} (w_i = 0
//! drops a light in cast shadow). [`Model::refine`] minimises it over (gx, gy) by
//! Gauss–Newton with variable projection (the coefficients re-fitted at every step),
//! a small Levenberg damping and step halving; positions are kept inside the table's
//! search disc.
//!
//! For two tables the Jacobian's part that the weights absorb is projected out
//! (L. Kaufman, "A variable projection method for solving separable nonlinear least
//! squares problems", BIT 15, 1975), the Gauss–Newton result is polished by a pattern
//! search down to 1/32 px (the bilinear tables crease the cost at cell edges), and
//! [`Model::weight_sigma`] gives the weights' standard error from the covariance of
//! all four parameters.

use crate::lut::table::Table;

/// Maximum Gauss–Newton step (pixels).
const MAX_STEP: f64 = 1.5;
/// Pattern-search + Gauss–Newton rounds that polish a mixture fit.
const POLISH_ROUNDS: usize = 3;

/// The reference tables and the kind of fit.
pub(crate) struct Model<'a> {
    pub tables: &'a [Table],
    /// Fit a free scale (normalised matching) for a single table.
    pub scale: bool,
    /// Affine map (alpha, bx, by) from table 0's grid to table 1's grid.
    map: (f64, f64, f64),
    pub k: usize,
}

/// Scratch buffers of one worker.
pub(crate) struct Scratch {
    pub basis: [Vec<f32>; 2],
    pub grad: [Vec<f32>; 2],
    pub pred: Vec<f32>,
    /// Jacobian columns ∂p/∂gx (first k) and ∂p/∂gy (last k).
    pub jac: Vec<f32>,
    /// Relative residual √cost/‖t‖ of the last pixel of the row matched or confirmed by
    /// the tree.
    pub rel_ref: f32,
}

impl Scratch {
    pub fn new(k: usize) -> Self {
        Scratch {
            basis: [vec![0.0; k], vec![0.0; k]],
            grad: [vec![0.0; 2 * k], vec![0.0; 2 * k]],
            pred: vec![0.0; k],
            jac: vec![0.0; 2 * k],
            rel_ref: 0.0,
        }
    }
}

/// A fitted position with its coefficients and cost.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fit {
    pub gx: f64,
    pub gy: f64,
    pub coef: [f32; 2],
    pub cost: f32,
}

impl<'a> Model<'a> {
    pub fn new(tables: &'a [Table], scale: bool) -> Self {
        let k = tables[0].k;
        let mut map = (1.0, 0.0, 0.0);
        if let Some(b) = tables.get(1) {
            let a = &tables[0];
            let alpha = b.circle.radius / a.circle.radius;
            let (ax, ay) = a.to_grid(a.circle.cx, a.circle.cy);
            let (bx, by) = b.to_grid(b.circle.cx, b.circle.cy);
            map = (alpha, bx - alpha * ax, by - alpha * ay);
        }
        Model {
            tables,
            scale,
            map,
            k,
        }
    }

    pub fn is_mix(&self) -> bool {
        self.tables.len() > 1
    }

    /// Interpolate every table at (gx, gy) into `s.basis` (and gradients w.r.t. gx, gy).
    #[inline]
    pub fn sample(&self, gx: f64, gy: f64, s: &mut Scratch, with_grad: bool) {
        let [b0, b1] = &mut s.basis;
        let [g0, g1] = &mut s.grad;
        self.tables[0].sample(gx, gy, b0, with_grad.then_some(&mut g0[..]));
        if let Some(t1) = self.tables.get(1) {
            let (alpha, bx, by) = self.map;
            t1.sample(
                alpha * gx + bx,
                alpha * gy + by,
                b1,
                with_grad.then_some(&mut g1[..]),
            );
            if with_grad {
                let alpha = alpha as f32;
                g1.iter_mut().for_each(|g| *g *= alpha);
            }
        }
    }

    /// Fit the coefficients to `t` on the current basis; returns (coef, cost).
    #[inline]
    pub fn fit_coef(&self, t: &[f32], w: Option<&[f32]>, s: &Scratch) -> ([f32; 2], f32) {
        self.fit_with(t, w, &s.basis[0], &s.basis[1])
    }

    /// Fit the coefficients to `t` on the basis tuples `a` (and `b` for a mixture).
    #[inline]
    pub fn fit_with(&self, t: &[f32], w: Option<&[f32]>, a: &[f32], b: &[f32]) -> ([f32; 2], f32) {
        if !self.is_mix() {
            let c = if self.scale {
                let (ta, aa) = dot2(t, a, w);
                if aa > 0.0 {
                    (ta / aa).max(0.0)
                } else {
                    0.0
                }
            } else {
                1.0
            };
            return ([c, 0.0], cost1(t, a, c, w));
        }
        let [ta, tb, aa, bb, ab] = gram5(t, a, b, w);
        let coef = nnls2(ta, tb, aa, bb, ab);
        (coef, cost2(t, a, b, coef, w))
    }

    /// Cost at grid point (gx, gy), clamped to the search disc.
    pub fn eval(&self, t: &[f32], w: Option<&[f32]>, gx: f64, gy: f64, s: &mut Scratch) -> Fit {
        let (gx, gy) = self.tables[0].clamp_grid(gx, gy);
        self.sample(gx, gy, s, false);
        let (coef, cost) = self.fit_coef(t, w, s);
        Fit { gx, gy, coef, cost }
    }

    /// Pattern search on the grid around `start`: try the 8 neighbours at distance
    /// `step` in turn, moving to each one that improves (the next neighbours are then
    /// taken around it), halve the step after a round without a move, stop below half a
    /// pixel.
    pub fn descend(
        &self,
        t: &[f32],
        w: Option<&[f32]>,
        start: Fit,
        step: f64,
        s: &mut Scratch,
    ) -> Fit {
        self.descend_to(t, w, start, step, 0.5, s)
    }

    /// [`Model::descend`] down to steps of `min_step` pixels.
    fn descend_to(
        &self,
        t: &[f32],
        w: Option<&[f32]>,
        start: Fit,
        step: f64,
        min_step: f64,
        s: &mut Scratch,
    ) -> Fit {
        let mut best = start;
        let mut h = step;
        while h >= min_step {
            let mut moved = false;
            for (dx, dy) in NEIGHBOURS {
                let f = self.eval(t, w, best.gx + dx * h, best.gy + dy * h, s);
                if f.cost < best.cost {
                    best = f;
                    moved = true;
                }
            }
            if !moved {
                h /= 2.0;
            }
        }
        best
    }

    /// Cost and gradients at (gx, gy) (clamped to the search disc); the basis and its
    /// gradients stay in `s`.
    #[inline]
    fn eval_grad(&self, t: &[f32], w: Option<&[f32]>, gx: f64, gy: f64, s: &mut Scratch) -> Fit {
        let (gx, gy) = self.tables[0].clamp_grid(gx, gy);
        self.sample(gx, gy, s, true);
        let (coef, cost) = self.fit_coef(t, w, s);
        Fit { gx, gy, coef, cost }
    }

    /// Gauss–Newton normal equations (JᵀJ, Jᵀr) at the fit whose basis is in `s`.
    #[inline]
    fn normal_equations(
        &self,
        t: &[f32],
        w: Option<&[f32]>,
        coef: [f32; 2],
        s: &mut Scratch,
    ) -> [f64; 5] {
        let k = self.k;
        // model p = Σ c_j B_j and its Jacobian columns, gathered into pred / jac
        let (jx, jy) = s.jac.split_at_mut(k);
        let used = if self.is_mix() { 2 } else { 1 };
        s.pred.fill(0.0);
        jx.fill(0.0);
        jy.fill(0.0);
        for (j, &c) in coef.iter().enumerate().take(used) {
            let (gx, gy) = s.grad[j].split_at(k);
            for ((((p, x), y), b), (dx, dy)) in s
                .pred
                .iter_mut()
                .zip(jx.iter_mut())
                .zip(jy.iter_mut())
                .zip(&s.basis[j])
                .zip(gx.iter().zip(gy))
            {
                *p += c * b;
                *x += c * dx;
                *y += c * dy;
            }
        }
        if self.is_mix() {
            project_out(&s.basis, coef, w, jx, jy);
        }
        let (p, t, jx, jy) = (&s.pred[..k], &t[..k], &jx[..k], &jy[..k]);
        let (h11, h12, h22, g1, g2) = match w {
            None => (
                lane_sum(k, |i| jx[i] * jx[i]),
                lane_sum(k, |i| jx[i] * jy[i]),
                lane_sum(k, |i| jy[i] * jy[i]),
                lane_sum(k, |i| jx[i] * (t[i] - p[i])),
                lane_sum(k, |i| jy[i] * (t[i] - p[i])),
            ),
            Some(w) => {
                let w = &w[..k];
                (
                    lane_sum(k, |i| w[i] * jx[i] * jx[i]),
                    lane_sum(k, |i| w[i] * jx[i] * jy[i]),
                    lane_sum(k, |i| w[i] * jy[i] * jy[i]),
                    lane_sum(k, |i| w[i] * jx[i] * (t[i] - p[i])),
                    lane_sum(k, |i| w[i] * jy[i] * (t[i] - p[i])),
                )
            }
        };
        [h11 as f64, h12 as f64, h22 as f64, g1 as f64, g2 as f64]
    }

    /// Gauss–Newton refinement of (gx, gy) from `start` (see the module docs); stops when
    /// a step is below 0.01 px or after `iters` steps. For a mixture, the Gauss–Newton
    /// solution is then polished: a pattern search down to 1/32 px and Gauss–Newton again
    /// from any better point (up to [`POLISH_ROUNDS`] times), because the bilinear tables
    /// crease the cost at cell edges and the two materials' trade-off valley is shallow.
    pub fn refine(
        &self,
        t: &[f32],
        w: Option<&[f32]>,
        start: Fit,
        iters: usize,
        s: &mut Scratch,
    ) -> Fit {
        let mut cur = self.gauss_newton(t, w, start, iters, s);
        if !self.is_mix() {
            return cur;
        }
        for _ in 0..POLISH_ROUNDS {
            let f = self.descend_to(t, w, cur, 0.5, 1.0 / 32.0, s);
            if f.cost >= cur.cost || f.cost.is_nan() {
                break;
            }
            cur = self.gauss_newton(t, w, f, iters, s);
        }
        cur
    }

    /// The Gauss–Newton iterations of [`Model::refine`].
    fn gauss_newton(
        &self,
        t: &[f32],
        w: Option<&[f32]>,
        start: Fit,
        iters: usize,
        s: &mut Scratch,
    ) -> Fit {
        let mut cur = self.eval_grad(t, w, start.gx, start.gy, s);
        if cur.cost > start.cost {
            return start;
        }
        for _ in 0..iters {
            let [h11, h12, h22, g1, g2] = self.normal_equations(t, w, cur.coef, s);
            let damp = 1e-6 * (h11 + h22) + 1e-12;
            let (a, b, d) = (h11 + damp, h12, h22 + damp);
            let det = a * d - b * b;
            if det.is_nan() || det <= 0.0 {
                break;
            }
            let mut dx = (d * g1 - b * g2) / det;
            let mut dy = (a * g2 - b * g1) / det;
            let len = (dx * dx + dy * dy).sqrt();
            if len > MAX_STEP {
                dx *= MAX_STEP / len;
                dy *= MAX_STEP / len;
            }
            let mut accepted = false;
            for _ in 0..4 {
                let f = self.eval_grad(t, w, cur.gx + dx, cur.gy + dy, s);
                if f.cost <= cur.cost {
                    cur = f;
                    accepted = true;
                    break;
                }
                dx *= 0.5;
                dy *= 0.5;
            }
            if !accepted {
                // the basis in `s` is that of the last rejected trial; nothing uses it
                break;
            }
            if dx * dx + dy * dy < 1e-4 {
                break;
            }
        }
        cur
    }

    /// Standard error of the mixture weights at a fit: max(σ_a, σ_b) from the
    /// Gauss–Newton covariance σ²(JᵀJ)⁻¹ of the four parameters (gx, gy, a, b) over the
    /// lights used (w_i > 0), J = [a·∂A/∂g + b·∂B/∂g, A, B], σ² = cost / (lights − 4).
    /// Large where the two materials trade off against the normal (grazing normals lit by
    /// few lights, no highlight) or the fit is poor; infinite with 4 lights or fewer.
    pub fn weight_sigma(&self, t: &[f32], w: &[f32], fit: &Fit, s: &mut Scratch) -> f32 {
        let k = self.k;
        self.sample(fit.gx, fit.gy, s, true);
        let (a, b) = (&s.basis[0], &s.basis[1]);
        let (gax, gay) = s.grad[0].split_at(k);
        let (gbx, gby) = s.grad[1].split_at(k);
        let [ca, cb] = fit.coef;
        let mut m = [[0.0f64; 4]; 4];
        let (mut cost, mut used) = (0.0f64, 0usize);
        for i in (0..k).filter(|&i| w[i] > 0.0) {
            let col = [
                (ca * gax[i] + cb * gbx[i]) as f64,
                (ca * gay[i] + cb * gby[i]) as f64,
                a[i] as f64,
                b[i] as f64,
            ];
            for (r, row) in m.iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v += col[r] * col[c];
                }
            }
            cost += (t[i] as f64 - ca as f64 * col[2] - cb as f64 * col[3]).powi(2);
            used += 1;
        }
        if used <= 4 {
            return f32::INFINITY;
        }
        let var = cost / (used - 4) as f64;
        let ia = inverse_entry(m, 2);
        let ib = inverse_entry(m, 3);
        match (ia, ib) {
            (Some(ia), Some(ib)) => (var * ia.max(ib)).max(0.0).sqrt() as f32,
            _ => f32::INFINITY,
        }
    }

    /// Dark level of a mixture fit whose prediction is in `s.pred`: `shadow_level` times
    /// the brightest predicted sample of this pixel. (The tables' peaks would make it
    /// b × a specular peak, far above the grazing-lit samples a cast shadow hides.)
    pub fn mix_dark_level(&self, shadow_level: f32, s: &Scratch) -> f32 {
        shadow_level * s.pred[..self.k].iter().fold(0.0f32, |m, &v| m.max(v))
    }

    /// Predicted tuple of a fit into `s.pred`.
    pub fn predict(&self, f: &Fit, s: &mut Scratch) {
        self.sample(f.gx, f.gy, s, false);
        for i in 0..self.k {
            let mut p = f.coef[0] * s.basis[0][i];
            if self.is_mix() {
                p += f.coef[1] * s.basis[1][i];
            }
            s.pred[i] = p;
        }
    }
}

/// Variable projection for the mixture (Kaufman 1975): remove from the Jacobian columns
/// `jx`, `jy` their (w-weighted) least-squares fit by the active basis tuples (those
/// with a positive coefficient), J ← (I − B(BᵀWB)⁻¹BᵀW) J. What the coefficients can
/// absorb by re-fitting is then no longer counted as curvature, so the Gauss–Newton
/// step along the direction where the two materials trade off is not shortened.
fn project_out(
    basis: &[Vec<f32>; 2],
    coef: [f32; 2],
    w: Option<&[f32]>,
    jx: &mut [f32],
    jy: &mut [f32],
) {
    let (a, b) = (&basis[0][..jx.len()], &basis[1][..jx.len()]);
    let aa = dotw(a, a, w) as f64;
    let bb = dotw(b, b, w) as f64;
    let ab = dotw(a, b, w) as f64;
    let det = aa * bb - ab * ab;
    let both = coef[0] > 0.0 && coef[1] > 0.0 && det > 1e-9 * aa * bb;
    for j in [jx, jy] {
        let (ja, jb) = (dotw(a, j, w) as f64, dotw(b, j, w) as f64);
        let (ca, cb) = if both {
            ((ja * bb - jb * ab) / det, (jb * aa - ja * ab) / det)
        } else if coef[0] > 0.0 && aa > 0.0 {
            (ja / aa, 0.0)
        } else if coef[1] > 0.0 && bb > 0.0 {
            (0.0, jb / bb)
        } else {
            (0.0, 0.0)
        };
        let (ca, cb) = (ca as f32, cb as f32);
        for ((v, x), y) in j.iter_mut().zip(a).zip(b) {
            *v -= ca * x + cb * y;
        }
    }
}

/// Diagonal entry j of M⁻¹ for a symmetric 4×4 M (Gauss–Jordan with partial pivoting on
/// the system M x = e_j); None when M is singular.
fn inverse_entry(mut m: [[f64; 4]; 4], j: usize) -> Option<f64> {
    let scale = (0..4).map(|i| m[i][i].abs()).fold(0.0, f64::max);
    let mut x = [0.0f64; 4];
    x[j] = 1.0;
    for c in 0..4 {
        let p = (c..4).max_by(|&u, &v| m[u][c].abs().total_cmp(&m[v][c].abs()))?;
        let pivot = m[p][c].abs();
        if pivot <= 1e-12 * scale || pivot.is_nan() {
            return None;
        }
        m.swap(c, p);
        x.swap(c, p);
        for r in 0..4 {
            if r != c {
                let f = m[r][c] / m[c][c];
                let pivot_row = m[c];
                for (v, p) in m[r].iter_mut().zip(pivot_row).skip(c) {
                    *v -= f * p;
                }
                x[r] -= f * x[c];
            }
        }
    }
    Some(x[j] / m[j][j])
}

/// The 8 directions of the pattern search ([`Model::descend`]), in the order tried.
pub(crate) const NEIGHBOURS: [(f64, f64); 8] = [
    (1.0, 0.0),
    (-1.0, 0.0),
    (0.0, 1.0),
    (0.0, -1.0),
    (1.0, 1.0),
    (1.0, -1.0),
    (-1.0, 1.0),
    (-1.0, -1.0),
];

/// Σ f(i) over 0..n, accumulated in 8 lanes so that the compiler vectorises it.
#[inline(always)]
fn lane_sum(n: usize, f: impl Fn(usize) -> f32) -> f32 {
    let mut acc = [0.0f32; 8];
    let full = n / 8 * 8;
    for base in (0..full).step_by(8) {
        for (l, a) in acc.iter_mut().enumerate() {
            *a += f(base + l);
        }
    }
    let mut tail = 0.0;
    for i in full..n {
        tail += f(i);
    }
    acc.iter().sum::<f32>() + tail
}

#[inline]
fn dotw(a: &[f32], b: &[f32], w: Option<&[f32]>) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    match w {
        None => lane_sum(n, |i| a[i] * b[i]),
        Some(w) => {
            let w = &w[..n];
            lane_sum(n, |i| a[i] * b[i] * w[i])
        }
    }
}

/// (⟨t, a⟩, ⟨a, a⟩) with weights.
#[inline]
fn dot2(t: &[f32], a: &[f32], w: Option<&[f32]>) -> (f32, f32) {
    (dotw(t, a, w), dotw(a, a, w))
}

#[inline]
fn cost1(t: &[f32], a: &[f32], c: f32, w: Option<&[f32]>) -> f32 {
    let n = t.len().min(a.len());
    let (t, a) = (&t[..n], &a[..n]);
    match w {
        None => lane_sum(n, |i| (t[i] - c * a[i]) * (t[i] - c * a[i])),
        Some(w) => {
            let w = &w[..n];
            lane_sum(n, |i| w[i] * (t[i] - c * a[i]) * (t[i] - c * a[i]))
        }
    }
}

#[inline]
fn cost2(t: &[f32], a: &[f32], b: &[f32], c: [f32; 2], w: Option<&[f32]>) -> f32 {
    let n = t.len().min(a.len()).min(b.len());
    let (t, a, b) = (&t[..n], &a[..n], &b[..n]);
    let r = |i: usize| t[i] - c[0] * a[i] - c[1] * b[i];
    match w {
        None => lane_sum(n, |i| r(i) * r(i)),
        Some(w) => {
            let w = &w[..n];
            lane_sum(n, |i| w[i] * r(i) * r(i))
        }
    }
}

/// The Gram entries [⟨t,a⟩, ⟨t,b⟩, ⟨a,a⟩, ⟨b,b⟩, ⟨a,b⟩] (weighted by `w`) in one pass
/// over the lights, 8 lanes each.
#[inline]
pub(crate) fn gram5(t: &[f32], a: &[f32], b: &[f32], w: Option<&[f32]>) -> [f32; 5] {
    let n = t.len().min(a.len()).min(b.len());
    let (t, a, b) = (&t[..n], &a[..n], &b[..n]);
    let mut acc = [[0.0f32; 8]; 5];
    let full = n / 8 * 8;
    let mut add = |i: usize, l: usize, wi: f32| {
        let (ti, ai, bi) = (t[i] * wi, a[i], b[i]);
        acc[0][l] += ti * ai;
        acc[1][l] += ti * bi;
        acc[2][l] += wi * ai * ai;
        acc[3][l] += wi * bi * bi;
        acc[4][l] += wi * ai * bi;
    };
    match w {
        None => {
            for base in (0..full).step_by(8) {
                for l in 0..8 {
                    add(base + l, l, 1.0);
                }
            }
            for i in full..n {
                add(i, 0, 1.0);
            }
        }
        Some(w) => {
            let w = &w[..n];
            for base in (0..full).step_by(8) {
                for l in 0..8 {
                    add(base + l, l, w[base + l]);
                }
            }
            for (i, &wi) in w.iter().enumerate().skip(full) {
                add(i, 0, wi);
            }
        }
    }
    acc.map(|lanes| lanes.iter().sum())
}

/// Non-negative least squares for min ‖t − a·A − b·B‖² given the Gram entries
/// ⟨t,A⟩, ⟨t,B⟩, ⟨A,A⟩, ⟨B,B⟩, ⟨A,B⟩: the unconstrained solution when both are
/// non-negative, otherwise the better of the two one-variable fits.
#[inline]
pub(crate) fn nnls2(ta: f32, tb: f32, aa: f32, bb: f32, ab: f32) -> [f32; 2] {
    let det = aa * bb - ab * ab;
    if det > 1e-12 * (aa * bb).max(1e-30) {
        let a = (ta * bb - tb * ab) / det;
        let b = (tb * aa - ta * ab) / det;
        if a >= 0.0 && b >= 0.0 {
            return [a, b];
        }
    }
    let a_only = if aa > 0.0 { (ta / aa).max(0.0) } else { 0.0 };
    let b_only = if bb > 0.0 { (tb / bb).max(0.0) } else { 0.0 };
    // explained energy of each one-variable fit: c²·⟨X,X⟩
    if a_only * a_only * aa >= b_only * b_only * bb {
        [a_only, 0.0]
    } else {
        [0.0, b_only]
    }
}

#[cfg(test)]
mod tests {
    use super::{inverse_entry, nnls2};

    #[test]
    fn inverse_entry_matches_the_inverse() {
        // M = diag(2, 4, 5, 10) + a rank-one coupling; check M · (M⁻¹ e_j) = e_j
        let v = [1.0, 0.5, -0.25, 2.0];
        let mut m = [[0.0f64; 4]; 4];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x = v[r] * v[c]
                    + if r == c {
                        [2.0, 4.0, 5.0, 10.0][r]
                    } else {
                        0.0
                    };
            }
        }
        // by Sherman–Morrison: (D + vvᵀ)⁻¹_jj = 1/d_j − (v_j/d_j)² / (1 + Σ v_i²/d_i)
        let d = [2.0, 4.0, 5.0, 10.0];
        let s: f64 = (0..4).map(|i| v[i] * v[i] / d[i]).sum();
        for j in 0..4 {
            let expected = 1.0 / d[j] - (v[j] / d[j]).powi(2) / (1.0 + s);
            let got = inverse_entry(m, j).unwrap();
            assert!((got - expected).abs() < 1e-12, "{j}: {got} vs {expected}");
        }
        // a singular matrix has no inverse
        let mut sing = m;
        sing[3] = sing[2];
        sing[0][3] = sing[0][2];
        sing[1][3] = sing[1][2];
        sing[2][3] = sing[2][2];
        sing[3][3] = sing[2][2];
        assert!(inverse_entry(sing, 0).is_none());
    }

    #[test]
    fn nnls2_clamps_to_the_non_negative_quadrant() {
        // t = 2A + 1B with A ⟂ B
        assert_eq!(nnls2(2.0, 1.0, 1.0, 1.0, 0.0), [2.0, 1.0]);
        // t = 2A − 1B: b would be negative → A only
        assert_eq!(nnls2(2.0, -1.0, 1.0, 1.0, 0.0), [2.0, 0.0]);
        // t = −A + 3B → B only
        assert_eq!(nnls2(-1.0, 3.0, 1.0, 1.0, 0.0), [0.0, 3.0]);
    }
}
