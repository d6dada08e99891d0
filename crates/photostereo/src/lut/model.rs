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

use super::table::Table;

/// Maximum Gauss–Newton step (pixels).
const MAX_STEP: f64 = 1.5;

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
    /// Table entries to seed the next tree search with (the last pixel's candidates).
    pub seeds: Vec<u32>,
    /// The previous pixel's solution (coherence shortcut); reset at row starts and gaps.
    pub warm: Option<super::search::Warm>,
    /// Relative residual √cost/‖t‖ of the last pixel of the row matched through the tree.
    pub rel_ref: f32,
}

impl Scratch {
    pub fn new(k: usize) -> Self {
        Scratch {
            basis: [vec![0.0; k], vec![0.0; k]],
            grad: [vec![0.0; 2 * k], vec![0.0; 2 * k]],
            pred: vec![0.0; k],
            jac: vec![0.0; 2 * k],
            seeds: Vec::with_capacity(super::index::MAX_CANDIDATES),
            warm: None,
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
        let (ta, aa) = dot2(t, a, w);
        let (tb, bb) = dot2(t, b, w);
        let ab = dotw(a, b, w);
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
    /// `step`, move to the best improvement, halve the step when none improves, stop
    /// below half a pixel.
    pub fn descend(
        &self,
        t: &[f32],
        w: Option<&[f32]>,
        start: Fit,
        step: f64,
        s: &mut Scratch,
    ) -> Fit {
        let mut best = start;
        let mut h = step;
        while h >= 0.5 {
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
        let (gx0, gy0) = s.grad[0].split_at(k);
        for ((((p, x), y), b), (dx, dy)) in s
            .pred
            .iter_mut()
            .zip(jx.iter_mut())
            .zip(jy.iter_mut())
            .zip(&s.basis[0])
            .zip(gx0.iter().zip(gy0))
        {
            *p = coef[0] * b;
            *x = coef[0] * dx;
            *y = coef[0] * dy;
        }
        if self.is_mix() {
            let (gx1, gy1) = s.grad[1].split_at(k);
            for ((((p, x), y), b), (dx, dy)) in s
                .pred
                .iter_mut()
                .zip(jx.iter_mut())
                .zip(jy.iter_mut())
                .zip(&s.basis[1])
                .zip(gx1.iter().zip(gy1))
            {
                *p += coef[1] * b;
                *x += coef[1] * dx;
                *y += coef[1] * dy;
            }
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
    /// a step is below 0.01 px or after `iters` steps.
    pub fn refine(
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

const NEIGHBOURS: [(f64, f64); 8] = [
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
    let mut sum = 0.0;
    for i in 0..t.len() {
        let wi = w.map_or(1.0, |w| w[i]);
        let r = t[i] - c[0] * a[i] - c[1] * b[i];
        sum += wi * r * r;
    }
    sum
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
    use super::nnls2;

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
