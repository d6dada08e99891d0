//! Gauss–Seidel row kernels with short dependency chains.
//!
//! A Gauss–Seidel sweep along a row is one chain of dependent operations (each cell
//! needs its left or right neighbour's new value), so its speed is set by latency, not
//! by memory: the kernels write a cell as x_i = t_i + (w_i / d_i) x_{i∓1}, t_i holding
//! every term off the chain (one multiply and one add on it), and sweep two rows at
//! once, the second [`LAG`] columns behind the first (it needs the first row's new value
//! in its own column), so that two independent chains overlap. The order of the updates
//! is exactly Gauss–Seidel's; only the rounding differs from the textbook formula.
//!
//! Why [`LAG`] columns and not one: the compiler packs the two rows' cells into one
//! vector register, and the second row's cell then waits for the first row's value of
//! the step before (stored, loaded back, four operations), a chain twice as long as
//! each row's own. Three columns apart, that value was set three steps before and the
//! chain is each row's own again (1024² disk, whole `integrate --method lsq` process:
//! see docs/benchmarks.md). The arithmetic and its order per cell are the same for any
//! lag: the results are bit for bit those of one column.

use super::level::Level;

/// Columns by which the second row of a pair trails the first (module documentation).
const LAG: usize = 3;

/// Σ a_i b_i with four partial sums (a chain of additions per partial sum, not one).
#[inline(always)]
pub(super) fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

impl Level {
    /// Forward sweep of row r from zero (cells left of and above it already set;
    /// `above` is row r − 1, or zeros at a band's first row).
    #[inline(always)]
    pub(super) fn fwd_row(&self, r: usize, b: &[f64], above: &[f64], cur: &mut [f64]) {
        let (w, s) = (self.w, self.stride());
        let (b, above, cur) = (&b[..s], &above[..s], &mut cur[..s]);
        let e = &self.east[r * s..(r + 1) * s];
        let su = &self.south[(r - 1) * s..r * s];
        let inv = &self.inv_diag[r * s..(r + 1) * s];
        let mut left = 0.0;
        for c in 1..=w {
            let d = inv[c] as f64;
            let v = (b[c] + su[c] as f64 * above[c]) * d + e[c - 1] as f64 * d * left;
            cur[c] = v;
            left = v;
        }
    }

    /// Forward sweep of rows r and r + 1 from zero (`above`: row r − 1 or zeros), the
    /// second row [`LAG`] columns behind the first.
    #[inline(always)]
    pub(super) fn fwd_pair(
        &self,
        r: usize,
        (b0, b1): (&[f64], &[f64]),
        above: &[f64],
        cur0: &mut [f64],
        cur1: &mut [f64],
    ) {
        let (w, s) = (self.w, self.stride());
        let (b0, b1, above) = (&b0[..s], &b1[..s], &above[..s]);
        let (cur0, cur1) = (&mut cur0[..s], &mut cur1[..s]);
        let (e0, e1) = (
            &self.east[r * s..(r + 1) * s],
            &self.east[(r + 1) * s..(r + 2) * s],
        );
        let (su0, su1) = (
            &self.south[(r - 1) * s..r * s],
            &self.south[r * s..(r + 1) * s],
        );
        let i0 = &self.inv_diag[r * s..(r + 1) * s];
        let i1 = &self.inv_diag[(r + 1) * s..(r + 2) * s];
        // Cell c of row r from its left neighbour's new value.
        let cell0 = |c: usize, left: f64| {
            let d0 = i0[c] as f64;
            (b0[c] + su0[c] as f64 * above[c]) * d0 + e0[c - 1] as f64 * d0 * left
        };
        // Cell k of row r + 1 from the new values above it and to its left.
        let cell1 = |k: usize, up: f64, left: f64| {
            let d1 = i1[k] as f64;
            (b1[k] + su1[k] as f64 * up) * d1 + e1[k - 1] as f64 * d1 * left
        };
        let lag = LAG.min(w);
        let (mut l0, mut l1) = (0.0, 0.0);
        for (c, out) in cur0.iter_mut().enumerate().take(lag + 1).skip(1) {
            l0 = cell0(c, l0);
            *out = l0;
        }
        for c in lag + 1..=w {
            let v0 = cell0(c, l0);
            let k = c - lag;
            let v1 = cell1(k, cur0[k], l1);
            cur0[c] = v0;
            cur1[k] = v1;
            l0 = v0;
            l1 = v1;
        }
        for k in w + 1 - lag..=w {
            l1 = cell1(k, cur0[k], l1);
            cur1[k] = l1;
        }
    }

    /// Backward sweep of row r (right to left; `above`, `below`: rows r ∓ 1 as the
    /// sweep finds them). Returns Σ b_i x_i over the row.
    #[inline(always)]
    pub(super) fn bwd_row(
        &self,
        r: usize,
        b: &[f64],
        above: &[f64],
        cur: &mut [f64],
        below: &[f64],
    ) -> f64 {
        let (w, s) = (self.w, self.stride());
        let (b, above, cur, below) = (&b[..s], &above[..s], &mut cur[..s], &below[..s]);
        let (e, sd) = (
            &self.east[r * s..(r + 1) * s],
            &self.south[r * s..(r + 1) * s],
        );
        let su = &self.south[(r - 1) * s..r * s];
        let inv = &self.inv_diag[r * s..(r + 1) * s];
        let (mut right, mut dot) = (0.0, 0.0);
        for c in (1..=w).rev() {
            let d = inv[c] as f64;
            let t = b[c]
                + e[c - 1] as f64 * cur[c - 1]
                + sd[c] as f64 * below[c]
                + su[c] as f64 * above[c];
            let v = t * d + e[c] as f64 * d * right;
            cur[c] = v;
            right = v;
            dot += b[c] * v;
        }
        dot
    }

    /// Backward sweep of rows r (first) and r − 1 ([`LAG`] columns behind): `above` is
    /// row r − 2, `below` row r + 1. Returns Σ b_i x_i over both rows.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn bwd_pair(
        &self,
        r: usize,
        (bt, bb): (&[f64], &[f64]),
        above: &[f64],
        top: &mut [f64],
        bot: &mut [f64],
        below: &[f64],
    ) -> f64 {
        let (w, s) = (self.w, self.stride());
        let (bt, bb, above, below) = (&bt[..s], &bb[..s], &above[..s], &below[..s]);
        let (top, bot) = (&mut top[..s], &mut bot[..s]);
        let (et, eb) = (
            &self.east[(r - 1) * s..r * s],
            &self.east[r * s..(r + 1) * s],
        );
        let st = &self.south[(r - 2) * s..(r - 1) * s];
        let (sm, sb) = (
            &self.south[(r - 1) * s..r * s],
            &self.south[r * s..(r + 1) * s],
        );
        let it = &self.inv_diag[(r - 1) * s..r * s];
        let ib = &self.inv_diag[r * s..(r + 1) * s];
        // Cell c of row r: `left` and `up` are the old values, `right` the new one.
        let cell_b = |c: usize, left: f64, up: f64, right: f64| {
            let db = ib[c] as f64;
            let t = bb[c] + eb[c - 1] as f64 * left + sb[c] as f64 * below[c] + sm[c] as f64 * up;
            t * db + eb[c] as f64 * db * right
        };
        // Cell k of row r − 1: `left` old, `down` and `right` new.
        let cell_t = |k: usize, left: f64, down: f64, right: f64| {
            let dt = it[k] as f64;
            let t = bt[k] + et[k - 1] as f64 * left + sm[k] as f64 * down + st[k] as f64 * above[k];
            t * dt + et[k] as f64 * dt * right
        };
        let lag = LAG.min(w);
        let (mut rb, mut rt, mut dot_b, mut dot_t) = (0.0, 0.0, 0.0, 0.0);
        for c in (w + 1 - lag..=w).rev() {
            rb = cell_b(c, bot[c - 1], top[c], rb);
            bot[c] = rb;
            dot_b += bb[c] * rb;
        }
        for c in (1..=w - lag).rev() {
            let vb = cell_b(c, bot[c - 1], top[c], rb);
            let k = c + lag;
            let vt = cell_t(k, top[k - 1], bot[k], rt);
            bot[c] = vb;
            top[k] = vt;
            rb = vb;
            rt = vt;
            dot_b += bb[c] * vb;
            dot_t += bt[k] * vt;
        }
        for k in (1..=lag).rev() {
            rt = cell_t(k, top[k - 1], bot[k], rt);
            top[k] = rt;
            dot_t += bt[k] * rt;
        }
        dot_b + dot_t
    }
}
