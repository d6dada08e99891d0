//! Gauss–Seidel row kernels with short dependency chains.
//!
//! A Gauss–Seidel sweep along a row is one chain of dependent operations (each cell
//! needs its left or right neighbour's new value), so its speed is set by latency, not
//! by memory: the kernels write a cell as x_i = t_i + (w_i / d_i) x_{i∓1}, t_i holding
//! every term off the chain (one multiply and one add on it), and sweep two rows at
//! once, the second one column behind the first (it needs the first row's new value in
//! its own column), so that two independent chains overlap. The order of the updates
//! is exactly Gauss–Seidel's; only the rounding differs from the textbook formula.

use super::level::Level;

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
    /// second row one column behind the first.
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
        let mut l0 = (b0[1] + su0[1] as f64 * above[1]) * i0[1] as f64;
        cur0[1] = l0;
        let mut l1 = 0.0;
        for c in 2..=w {
            let d0 = i0[c] as f64;
            let v0 = (b0[c] + su0[c] as f64 * above[c]) * d0 + e0[c - 1] as f64 * d0 * l0;
            let k = c - 1;
            let d1 = i1[k] as f64;
            let v1 = (b1[k] + su1[k] as f64 * cur0[k]) * d1 + e1[k - 1] as f64 * d1 * l1;
            cur0[c] = v0;
            cur1[k] = v1;
            l0 = v0;
            l1 = v1;
        }
        let d1 = i1[w] as f64;
        cur1[w] = (b1[w] + su1[w] as f64 * cur0[w]) * d1 + e1[w - 1] as f64 * d1 * l1;
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

    /// Backward sweep of rows r (first) and r − 1 (one column behind): `above` is row
    /// r − 2, `below` row r + 1. Returns Σ b_i x_i over both rows.
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
        let row_b = |c: usize, bot: &[f64], top: &[f64]| {
            bb[c] + eb[c - 1] as f64 * bot[c - 1] + sb[c] as f64 * below[c] + sm[c] as f64 * top[c]
        };
        let row_t = |c: usize, top: &[f64], bot: &[f64]| {
            bt[c] + et[c - 1] as f64 * top[c - 1] + sm[c] as f64 * bot[c] + st[c] as f64 * above[c]
        };
        let db = ib[w] as f64;
        let mut rb = row_b(w, bot, top) * db;
        bot[w] = rb;
        let (mut rt, mut dot_b, mut dot_t) = (0.0, bb[w] * rb, 0.0);
        for c in (1..w).rev() {
            let db = ib[c] as f64;
            let vb = row_b(c, bot, top) * db + eb[c] as f64 * db * rb;
            let k = c + 1;
            let dt = it[k] as f64;
            let vt = row_t(k, top, bot) * dt + et[k] as f64 * dt * rt;
            bot[c] = vb;
            top[k] = vt;
            rb = vb;
            rt = vt;
            dot_b += bb[c] * vb;
            dot_t += bt[k] * vt;
        }
        let dt = it[1] as f64;
        let vt = row_t(1, top, bot) * dt + et[1] as f64 * dt * rt;
        top[1] = vt;
        dot_t += bt[1] * vt;
        dot_b + dot_t
    }
}
