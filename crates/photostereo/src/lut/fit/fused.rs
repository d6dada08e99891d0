//! Fast path of the sub-pixel refinement for one table.
//!
//! It minimises the same cost as [`super::generic::Model::refine`] (weighted
//! ‖t − c·I(gx, gy)‖² over the continuous sphere position, Gauss–Newton with variable
//! projection, Levenberg damping 10⁻⁶·tr H, steps of at most 1.5 px, up to 4 halvings),
//! but fuses the bilinear interpolation of I and of its gradient, the coefficient fit, the
//! cost and the normal equations into one pass over the K lights. The pass runs on
//! 4-lane vectors (SSE2, the x86-64 baseline); on x86-64 processors with AVX (checked
//! at run time) [`Single::refine`] runs a second build of the same code on 8-lane AVX
//! vectors, and with AVX and FMA a third with fused multiply-adds (lane sums added in
//! another order, products rounded once: results agree to rounding). The
//! sphere window's tuples must therefore come in blocks of [`LANES`] = 8: when K is not
//! a multiple of it, the window is copied with its tuples padded with zeros. Target
//! tuples and weights are padded the same way
//! (weight 0 beyond K); without weights (all lights) the pass skips them. Without a
//! scale each evaluation also sums ‖t − I_e‖² to the tuple I_e of the cell corner at the
//! even grid point nearest to it ([`even`]), which the certificate of the coherence
//! shortcut needs for the final fit (`search/certify.rs`): it is read with the cell.
//!
//! With a free scale c = ⟨t, I⟩/⟨I, I⟩ (normalised matching), the Jacobian is that of
//! variable projection in Kaufman's form: the part of ∂I that c absorbs is projected
//! out, J = c·(∂I − I·⟨I, ∂I⟩/⟨I, I⟩), so JᵀJ = c²·(∂Iᵀ∂I − ⟨I, ∂I⟩⟨I, ∂I⟩ᵀ/⟨I, I⟩)
//! (Golub & Pereyra, SIAM J. Numer. Anal. 10(2), 1973; Kaufman, BIT 15, 1975). Without
//! the projection the iteration converges only linearly.
//!
//! Stopping rule: the iteration ends when the Gauss–Newton step is below 0.01 px (the
//! step is then not taken: the position is within about that of the minimum).

use super::generic::{Fit, NEIGHBOURS};
use crate::lut::table::Table;
use std::borrow::Cow;

/// Lane width of the fused pass (lights per block).
pub(crate) const LANES: usize = 8;
/// Maximum Gauss–Newton step (pixels), as in the generic refinement.
const MAX_STEP: f64 = 1.5;
/// Squared step length (px²) below which the iteration stops.
const STOP2: f64 = 1e-4;

/// The even grid coordinate nearest to g (≥ 0): the certificate's entries lie at even
/// rows and columns.
#[inline(always)]
pub(crate) fn even(g: f64) -> usize {
    2 * nearest(0.5 * g)
}

/// The grid coordinate nearest to g (≥ 0; halves round up, as `f64::round` does for
/// g ≥ 0): a truncating cast, where `round` is a libm call on the x86-64 baseline. The
/// cast is to `u32` (grid coordinates are far below 2³²; larger values saturate): one
/// conversion instruction, where a cast to `usize` handles values beyond 2⁶³ too.
#[inline(always)]
pub(crate) fn nearest(g: f64) -> usize {
    (g.max(0.0) + 0.5) as u32 as usize
}

/// Round `k` up to a multiple of [`LANES`].
pub(crate) fn padded(k: usize) -> usize {
    k.div_ceil(LANES) * LANES
}

/// The table's window, padded per pixel to a multiple of [`LANES`] lights.
pub(crate) struct Single<'a> {
    /// The window's tuples, borrowed when K is already a multiple of [`LANES`].
    data: Cow<'a, [f32]>,
    kp: usize,
    width: usize,
    height: usize,
    /// Grid position of the circle centre.
    centre: (f64, f64),
    /// Search radius (grid pixels).
    rmax: f64,
    /// Fit a free scale c (normalised matching); else c = 1.
    scale: bool,
    /// The processor has AVX (x86-64): [`Single::refine`] runs its AVX build.
    avx: Option<Avx>,
    /// The processor also has FMA: [`Single::refine`] runs its AVX + FMA build.
    fma: Option<AvxFma>,
}

/// Result of one fused evaluation: position, coefficient, cost and normal equations
/// (H = JᵀWJ as h11, h12, h22; g = JᵀWr).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Point {
    pub gx: f64,
    pub gy: f64,
    pub c: f32,
    pub cost: f32,
    h: [f64; 3],
    g: [f64; 2],
    /// The Gauss–Newton step below the stopping length that ended the iteration (not
    /// taken: cur + step estimates the minimum better than cur); zero when the
    /// iteration ended otherwise.
    pub step: [f64; 2],
    /// Without a scale: the window pixel (row-major index) at the even grid point nearest
    /// to (gx, gy) ([`even`]; one of the cell's corners) and ‖t − I‖² to its tuple over
    /// all lights, for the certificate; `u32::MAX` when not computed.
    pub corner: u32,
    pub corner_d2: f32,
}

impl Point {
    /// As a [`Fit`] of the generic model (one table: the second coefficient is 0).
    pub fn fit(&self) -> Fit {
        Fit {
            gx: self.gx,
            gy: self.gy,
            coef: [self.c, 0.0],
            cost: self.cost,
        }
    }
}

/// Where [`Single::refine`] starts.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Start {
    /// Grid position (window pixels).
    pub gx: f64,
    pub gy: f64,
    /// First step (window pixels) of a pattern search run before Gauss–Newton, as
    /// [`super::generic::Model::descend`] does it (for starts that may lie several pixels
    /// from the minimum); 0: none.
    pub pattern: f64,
}

/// Per-worker buffers of the fused pass (interpolated tuple and gradients).
pub(crate) struct Buf {
    v: Vec<f32>,
    dx: Vec<f32>,
    dy: Vec<f32>,
}

impl Buf {
    pub fn new(k: usize) -> Self {
        let kp = padded(k);
        Buf {
            v: vec![0.0; kp],
            dx: vec![0.0; kp],
            dy: vec![0.0; kp],
        }
    }
}

mod lanes;

use crate::cpu::{Avx, AvxFma};
use lanes::{Baseline, Lanes};

/// The lane sums of one evaluation: JᵀJ terms (h11, h12, h22), ⟨I,∂I/∂x⟩, ⟨I,∂I/∂y⟩
/// (weighted; without a scale `xi` holds ‖t − corner‖² instead) and the residual terms
/// (cost, gradient x, gradient y); ⟨I,I⟩ (summed).
struct Sums<V> {
    h: [V; 3],
    ii: f32,
    xi: V,
    yi: V,
    res: [V; 3],
}

/// The evaluation's [`Point`] at scale c from its lane sums: with a fitted scale the
/// part of ∂I that c absorbs is projected out (variable projection, Kaufman),
/// J = c·(∂I − I⟨I,∂I⟩/⟨I,I⟩). Also returns the lane sum of `xi` (without a scale it
/// holds the corner's squared distance).
#[inline(always)]
fn point<V: Lanes>(gx: f64, gy: f64, c: f32, scaled: bool, s: &Sums<V>) -> (Point, f32) {
    let (c64, c2) = (c as f64, (c * c) as f64);
    let [h0, h1, h2, r0, r1, r2, xi, yi] = V::sum8([
        s.h[0], s.h[1], s.h[2], s.res[0], s.res[1], s.res[2], s.xi, s.yi,
    ]);
    let mut h = [h0 as f64, h1 as f64, h2 as f64];
    let ii = s.ii as f64;
    if scaled && ii > 0.0 {
        let (xi, yi) = (xi as f64, yi as f64);
        h = [
            h[0] - xi * xi / ii,
            h[1] - xi * yi / ii,
            h[2] - yi * yi / ii,
        ];
    }
    let p = Point {
        gx,
        gy,
        c,
        cost: r0,
        h: [c2 * h[0], c2 * h[1], c2 * h[2]],
        g: [c64 * r1 as f64, c64 * r2 as f64],
        step: [0.0; 2],
        corner: u32::MAX,
        corner_d2: f32::INFINITY,
    };
    (p, xi)
}

/// Second pass of a scaled fit: c = max(⟨t,I⟩/⟨I,I⟩, 0) from the sums `ti`, `ii`,
/// then the residual terms of t − c·I (interpolated tuple and gradients in `b`) added to
/// `acc`, with the weights `w` (`W`) or all 1. Returns c.
#[inline(always)]
fn scaled_residuals<V: Lanes, const W: bool>(
    cpu: V::Cpu,
    t: &[f32],
    w: &[f32],
    b: &Buf,
    ti: f32,
    ii: f32,
    acc: &mut [V; 3],
) -> f32 {
    let c = if ii > 0.0 { (ti / ii).max(0.0) } else { 0.0 };
    let cv = V::splat(cpu, c);
    for o in (0..t.len()).step_by(V::N) {
        let r = V::load(cpu, t, o).sub(V::load(cpu, &b.v, o).mul(cv));
        let (dx, dy) = (V::load(cpu, &b.dx, o), V::load(cpu, &b.dy, o));
        accumulate::<V, W>(cpu, acc, r, (w, o), dx, dy);
    }
    c
}

/// Add the weighted residual terms (Σ w r², Σ w r ∂I/∂gx, Σ w r ∂I/∂gy) of the lane
/// block at `o` to `acc`, with the weights `w` (`W`) or all 1.
#[inline(always)]
fn accumulate<V: Lanes, const W: bool>(
    cpu: V::Cpu,
    acc: &mut [V; 3],
    r: V,
    (w, o): (&[f32], usize),
    dx: V,
    dy: V,
) {
    let wr = if W { V::load(cpu, w, o).mul(r) } else { r };
    acc[0] = acc[0].mul_add(wr, r);
    acc[1] = acc[1].mul_add(wr, dx);
    acc[2] = acc[2].mul_add(wr, dy);
}

impl<'a> Single<'a> {
    /// The window of `table` with padded tuples (a copy only when K needs padding).
    pub fn new(table: &'a Table, scale: bool) -> Self {
        let ws = &table.window.stack;
        let (k, kp) = (ws.k, padded(ws.k));
        let data = if k == kp {
            Cow::Borrowed(&ws.data[..])
        } else {
            let mut data = vec![0.0f32; ws.width * ws.height * kp];
            for (dst, src) in data.chunks_exact_mut(kp).zip(ws.data.chunks_exact(k)) {
                dst[..k].copy_from_slice(src);
            }
            Cow::Owned(data)
        };
        Single {
            data,
            kp,
            width: ws.width,
            height: ws.height,
            centre: table.to_grid(table.circle.cx, table.circle.cy),
            rmax: table.search_radius(),
            scale,
            avx: Avx::detect(),
            fma: AvxFma::detect(),
        }
    }

    /// (gx, gy) moved back inside the search disc (as [`Table::clamp_grid`]).
    #[inline]
    fn clamp(&self, gx: f64, gy: f64) -> (f64, f64) {
        let (dx, dy) = (gx - self.centre.0, gy - self.centre.1);
        let d2 = dx * dx + dy * dy;
        if d2 > self.rmax * self.rmax {
            let f = self.rmax / d2.sqrt();
            (self.centre.0 + dx * f, self.centre.1 + dy * f)
        } else {
            (gx, gy)
        }
    }

    /// Cost and normal equations at (gx, gy) (clamped to the search disc) for the target
    /// `t` with weights `w` (both padded; `None`: all lights, weight 1); `b` keeps the
    /// interpolated tuple.
    #[inline(always)]
    pub fn eval<V: Lanes>(
        &self,
        cpu: V::Cpu,
        t: &[f32],
        w: Option<&[f32]>,
        gx: f64,
        gy: f64,
        b: &mut Buf,
    ) -> Point {
        let (gx, gy) = self.clamp(gx, gy);
        match (self.scale, w) {
            (true, Some(w)) => self.eval_with::<V, true, true>(cpu, t, w, gx, gy, b),
            (true, None) => self.eval_with::<V, true, false>(cpu, t, t, gx, gy, b),
            (false, Some(w)) => self.eval_with::<V, false, true>(cpu, t, w, gx, gy, b),
            (false, None) => self.eval_with::<V, false, false>(cpu, t, t, gx, gy, b),
        }
    }

    /// [`Single::eval`] at a clamped position, with the weights `w` (`W`; else all 1).
    /// Without a scale (c = 1) everything is accumulated in one pass; with one, a first
    /// pass interpolates and fits c, a second accumulates the residual terms.
    #[inline(always)]
    fn eval_with<V: Lanes, const SCALE: bool, const W: bool>(
        &self,
        cpu: V::Cpu,
        t: &[f32],
        w: &[f32],
        gx: f64,
        gy: f64,
        b: &mut Buf,
    ) -> Point {
        let kp = self.kp;
        // positions are ≥ 0 inside the window; `as` saturates (floor for x ≥ 0)
        let c0 = (gx.max(0.0) as usize).min(self.width - 2);
        let r0 = (gy.max(0.0) as usize).min(self.height - 2);
        let (a, bv) = (
            V::splat(cpu, (gx - c0 as f64) as f32),
            V::splat(cpu, (gy - r0 as f64) as f32),
        );
        let top = (r0 * self.width + c0) * kp;
        let bot = self.width * kp;
        let d = &self.data[top..top + bot + 2 * kp];
        let (t, w) = (&t[..kp], &w[..if W { kp } else { 0 }]);
        // the certificate's corner (without a scale): offset of its tuple in `d`
        let (ce, re) = (even(gx), even(gy));
        let corner = !SCALE && ce.wrapping_sub(c0) < 2 && re.wrapping_sub(r0) < 2;
        let eo = if corner {
            (re - r0) * bot + (ce - c0) * kp
        } else {
            0
        };
        let z = V::zero(cpu);
        let (mut ti, mut ii, mut h11, mut h12, mut h22) = (z, z, z, z, z);
        let (mut xi, mut yi) = (z, z);
        let mut res = [z; 3];
        // the four cells, the corner and the target in blocks of N (exact chunks: no
        // bounds checks in the loop)
        let n = V::N;
        let (up_row, down_row) = (&d[..2 * kp], &d[bot..bot + 2 * kp]);
        let cells = up_row[..kp]
            .chunks_exact(n)
            .zip(up_row[kp..].chunks_exact(n));
        let cells = cells.zip(
            down_row[..kp]
                .chunks_exact(n)
                .zip(down_row[kp..].chunks_exact(n)),
        );
        let rest = d[eo..eo + kp].chunks_exact(n).zip(t.chunks_exact(n));
        for (i, (((x00, x01), (x10, x11)), (ec, tc))) in cells.zip(rest).enumerate() {
            let o = i * n;
            let (x00, x01) = (V::load(cpu, x00, 0), V::load(cpu, x01, 0));
            let (x10, x11) = (V::load(cpu, x10, 0), V::load(cpu, x11, 0));
            let tl = V::load(cpu, tc, 0);
            let (e0, e1) = (x01.sub(x00), x11.sub(x10));
            let up = x00.mul_add(e0, a);
            let dy = x10.mul_add(e1, a).sub(up);
            let v = up.mul_add(dy, bv);
            let dx = e0.mul_add(e1.sub(e0), bv);
            v.store(&mut b.v, o);
            let (wdx, wdy) = if W {
                let wl = V::load(cpu, w, o);
                (wl.mul(dx), wl.mul(dy))
            } else {
                (dx, dy)
            };
            h11 = h11.mul_add(wdx, dx);
            h12 = h12.mul_add(wdx, dy);
            h22 = h22.mul_add(wdy, dy);
            if SCALE {
                dx.store(&mut b.dx, o);
                dy.store(&mut b.dy, o);
                let wv = if W { V::load(cpu, w, o).mul(v) } else { v };
                ti = ti.mul_add(wv, tl);
                ii = ii.mul_add(wv, v);
                xi = xi.mul_add(wv, dx);
                yi = yi.mul_add(wv, dy);
            } else {
                accumulate::<V, W>(cpu, &mut res, tl.sub(v), (w, o), dx, dy);
                let q = tl.sub(V::load(cpu, ec, 0));
                xi = xi.mul_add(q, q);
            }
        }
        let (c, ii) = if SCALE {
            let ii = ii.sum();
            (
                scaled_residuals::<V, W>(cpu, t, w, b, ti.sum(), ii, &mut res),
                ii,
            )
        } else {
            (1.0, 0.0)
        };
        let sums = Sums {
            h: [h11, h12, h22],
            ii,
            xi,
            yi,
            res,
        };
        let (mut p, d2) = point(gx, gy, c, SCALE, &sums);
        if corner {
            p.corner = (re * self.width + ce) as u32;
            p.corner_d2 = d2;
        }
        p
    }

    /// Whether some light is dark in the target `t` (within `level` of its floor in
    /// `floors`, the black level) but lit in the model c·I of the last evaluation (above
    /// t + `level`): the test of a cast shadow.
    pub fn any_dark_lit(&self, t: &[f32], floors: &[f32], c: f32, level: f32, b: &Buf) -> bool {
        (t.iter().zip(floors).zip(&b.v)).fold(false, |any, ((&t, &floor), &v)| {
            any | ((t - floor < level) & (c * v > t + level))
        })
    }

    /// The model tuple c·I of the last evaluation into `out` (K values).
    pub fn prediction(&self, c: f32, b: &Buf, out: &mut [f32]) {
        for (o, v) in out.iter_mut().zip(&b.v) {
            *o = c * v;
        }
    }

    /// Gauss–Newton from `start` (see the module docs), after its pattern search if it
    /// asks for one, with the weights `w` (`None`: all lights). The result's tuple is
    /// left in `b` only when the second value of the returned pair is true.
    #[inline]
    pub fn refine(
        &self,
        t: &[f32],
        w: Option<&[f32]>,
        start: Start,
        iters: usize,
        b: &mut Buf,
    ) -> (Point, bool) {
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = self.fma {
            // SAFETY: the token `cpu` exists only where the processor has AVX and FMA,
            // all that `refine_fma` needs
            return unsafe { self.refine_fma(cpu, t, w, start, iters, b) };
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = self.avx {
            // SAFETY: the token `cpu` exists only where the processor has AVX
            return unsafe { self.refine_avx(cpu, t, w, start, iters, b) };
        }
        self.refine_with::<lanes::V4>(Baseline, t, w, start, iters, b)
    }

    /// [`Single::refine`] compiled with AVX, on 8-lane vectors (the lane sums are taken
    /// in another order than the 4-lane build's: results agree to rounding).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[allow(clippy::too_many_arguments)]
    fn refine_avx(
        &self,
        cpu: Avx,
        t: &[f32],
        w: Option<&[f32]>,
        start: Start,
        iters: usize,
        b: &mut Buf,
    ) -> (Point, bool) {
        self.refine_with::<lanes::V8>(cpu, t, w, start, iters, b)
    }

    /// [`Single::refine`] compiled with AVX and FMA, on 8-lane vectors with fused
    /// multiply-adds (rounded once: results agree with the other builds to rounding).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,fma")]
    #[allow(clippy::too_many_arguments)]
    fn refine_fma(
        &self,
        cpu: AvxFma,
        t: &[f32],
        w: Option<&[f32]>,
        start: Start,
        iters: usize,
        b: &mut Buf,
    ) -> (Point, bool) {
        self.refine_with::<lanes::V8F>(cpu, t, w, start, iters, b)
    }

    /// The body of [`Single::refine`], inlined into each build.
    #[inline(always)]
    fn refine_with<V: Lanes>(
        &self,
        cpu: V::Cpu,
        t: &[f32],
        w: Option<&[f32]>,
        start: Start,
        iters: usize,
        b: &mut Buf,
    ) -> (Point, bool) {
        let cur = self.eval::<V>(cpu, t, w, start.gx, start.gy, b);
        let (mut cur, mut fresh) = if start.pattern > 0.0 {
            self.pattern_search::<V>(cpu, (t, w), cur, start.pattern, b)
        } else {
            (cur, true)
        };
        for _ in 0..iters {
            let [h11, h12, h22] = cur.h;
            let damp = 1e-6 * (h11 + h22) + 1e-12;
            let (a, bb, d) = (h11 + damp, h12, h22 + damp);
            let det = a * d - bb * bb;
            if det.is_nan() || det <= 0.0 {
                break;
            }
            let mut dx = (d * cur.g[0] - bb * cur.g[1]) / det;
            let mut dy = (a * cur.g[1] - bb * cur.g[0]) / det;
            let len2 = dx * dx + dy * dy;
            if len2 < STOP2 {
                cur.step = [dx, dy];
                break;
            }
            if len2 > MAX_STEP * MAX_STEP {
                (dx, dy) = shorten(dx, dy, len2);
            }
            let mut accepted = false;
            for _ in 0..4 {
                let f = self.eval::<V>(cpu, t, w, cur.gx + dx, cur.gy + dy, b);
                fresh = false;
                if f.cost <= cur.cost {
                    cur = f;
                    fresh = true;
                    accepted = true;
                    break;
                }
                dx *= 0.5;
                dy *= 0.5;
            }
            if !accepted || dx * dx + dy * dy < STOP2 {
                break;
            }
        }
        (cur, fresh)
    }

    /// The pattern search of [`Start::pattern`] from `best` (evaluated): the 8 neighbours
    /// at distance h in turn, moving to each one that improves (the next neighbours are
    /// then taken around it), h halved after a round without a move, down to half a
    /// pixel. Returns the best point and whether `b` holds its tuple.
    #[inline(always)]
    fn pattern_search<V: Lanes>(
        &self,
        cpu: V::Cpu,
        (t, w): (&[f32], Option<&[f32]>),
        mut best: Point,
        step: f64,
        b: &mut Buf,
    ) -> (Point, bool) {
        let (mut h, mut fresh) = (step, true);
        while h >= 0.5 {
            let mut moved = false;
            for (dx, dy) in NEIGHBOURS {
                let f = self.eval::<V>(cpu, t, w, best.gx + dx * h, best.gy + dy * h, b);
                fresh = f.cost < best.cost;
                if fresh {
                    best = f;
                    moved = true;
                }
            }
            if !moved {
                h /= 2.0;
            }
        }
        (best, fresh)
    }
}

/// The step (dx, dy) of squared length `len2` shortened to [`MAX_STEP`]: out of line, so
/// that the usual short step does not wait on its square root and division.
#[cold]
#[inline(never)]
fn shorten(dx: f64, dy: f64, len2: f64) -> (f64, f64) {
    let f = MAX_STEP / len2.sqrt();
    (dx * f, dy * f)
}

#[cfg(test)]
mod tests;
