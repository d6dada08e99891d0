//! Fast path of the sub-pixel refinement for one table.
//!
//! It minimises the same cost as [`super::model::Model::refine`] (weighted
//! ‖t − c·I(gx, gy)‖² over the continuous sphere position, Gauss–Newton with variable
//! projection, Levenberg damping 10⁻⁶·tr H, steps of at most 1.5 px, up to 4 halvings),
//! but fuses the bilinear interpolation of I and of its gradient, the coefficient fit, the
//! cost and the normal equations into one pass over the K lights. The pass runs on
//! 4-lane vectors (SSE2, the x86-64 baseline); on x86-64 processors with AVX (checked
//! at run time) [`Single::refine`] runs a second build of the same code on 8-lane AVX
//! vectors (its lane sums are added in another order: results agree to rounding). The
//! sphere window's tuples must therefore come in blocks of [`LANES`] = 8: when K is not
//! a multiple of it, the window is copied with its tuples padded with zeros. Target
//! tuples and weights are padded the same way
//! (weight 0 beyond K).
//!
//! With a free scale c = ⟨t, I⟩/⟨I, I⟩ (normalised matching), the Jacobian is that of
//! variable projection in Kaufman's form: the part of ∂I that c absorbs is projected
//! out, J = c·(∂I − I·⟨I, ∂I⟩/⟨I, I⟩), so JᵀJ = c²·(∂Iᵀ∂I − ⟨I, ∂I⟩⟨I, ∂I⟩ᵀ/⟨I, I⟩)
//! (Golub & Pereyra, SIAM J. Numer. Anal. 10(2), 1973; Kaufman, BIT 15, 1975). Without
//! the projection the iteration converges only linearly.
//!
//! Stopping rule: the iteration ends when the Gauss–Newton step is below 0.01 px (the
//! step is then not taken: the position is within about that of the minimum).

use super::model::Fit;
use super::table::Table;
use std::borrow::Cow;

/// Lane width of the fused pass (lights per block).
pub(crate) const LANES: usize = 8;
/// Maximum Gauss–Newton step (pixels), as in the generic refinement.
const MAX_STEP: f64 = 1.5;
/// Squared step length (px²) below which the iteration stops.
const STOP2: f64 = 1e-4;

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
    avx: bool,
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

/// f32 lane vectors: [`lanes::V4`] (SSE2 on x86-64, always there; plain arrays
/// elsewhere) and, on x86-64, [`lanes::V8`] (AVX, used only by [`Single::refine`]'s AVX
/// build, which runs only where the processor has it).
mod lanes {
    #[cfg(target_arch = "x86_64")]
    use std::arch::x86_64::*;

    /// The operations of the fused pass on `N` lanes.
    pub trait Lanes: Copy {
        /// Number of lanes.
        const N: usize;
        fn zero() -> Self;
        fn splat(x: f32) -> Self;
        /// The `N` values at `s[at..at + N]`.
        fn load(s: &[f32], at: usize) -> Self;
        fn store(self, s: &mut [f32], at: usize);
        fn add(self, o: Self) -> Self;
        fn sub(self, o: Self) -> Self;
        fn mul(self, o: Self) -> Self;
        /// Sum of the lanes.
        fn sum(self) -> f32;
    }

    /// Four f32 lanes.
    #[cfg(target_arch = "x86_64")]
    #[derive(Clone, Copy)]
    pub struct V4(__m128);
    /// Four f32 lanes.
    #[cfg(not(target_arch = "x86_64"))]
    #[derive(Clone, Copy)]
    pub struct V4([f32; 4]);

    /// `impl Lanes` for a vector type over x86-64 intrinsics: its lane count, then the
    /// intrinsics for zero, splat, unaligned load and store, add, sub and mul, then the
    /// body of `sum`. Loads and stores go through slices of exactly N values.
    #[cfg(target_arch = "x86_64")]
    macro_rules! intrinsic_lanes {
        ($v:ident, $n:literal, $zero:ident, $splat:ident, $load:ident, $store:ident,
         $add:ident, $sub:ident, $mul:ident, |$x:ident| $sum:block) => {
            impl Lanes for $v {
                const N: usize = $n;
                #[inline(always)]
                fn zero() -> $v {
                    $v(unsafe { $zero() })
                }
                #[inline(always)]
                fn splat(x: f32) -> $v {
                    $v(unsafe { $splat(x) })
                }
                #[inline(always)]
                fn load(s: &[f32], at: usize) -> $v {
                    let s = &s[at..at + $n];
                    $v(unsafe { $load(s.as_ptr()) })
                }
                #[inline(always)]
                fn store(self, s: &mut [f32], at: usize) {
                    let s = &mut s[at..at + $n];
                    unsafe { $store(s.as_mut_ptr(), self.0) }
                }
                #[inline(always)]
                fn add(self, o: $v) -> $v {
                    $v(unsafe { $add(self.0, o.0) })
                }
                #[inline(always)]
                fn sub(self, o: $v) -> $v {
                    $v(unsafe { $sub(self.0, o.0) })
                }
                #[inline(always)]
                fn mul(self, o: $v) -> $v {
                    $v(unsafe { $mul(self.0, o.0) })
                }
                #[inline(always)]
                fn sum(self) -> f32 {
                    let $x = self.0;
                    unsafe { $sum }
                }
            }
        };
    }

    // SAFETY (all `unsafe` blocks of this impl): SSE and SSE2 are part of the x86-64
    // baseline, so the intrinsics are always available.
    #[cfg(target_arch = "x86_64")]
    intrinsic_lanes!(
        V4,
        4,
        _mm_setzero_ps,
        _mm_set1_ps,
        _mm_loadu_ps,
        _mm_storeu_ps,
        _mm_add_ps,
        _mm_sub_ps,
        _mm_mul_ps,
        |x| {
            let s2 = _mm_add_ps(x, _mm_movehl_ps(x, x));
            _mm_cvtss_f32(_mm_add_ss(s2, _mm_shuffle_ps::<1>(s2, s2)))
        }
    );

    #[cfg(not(target_arch = "x86_64"))]
    impl Lanes for V4 {
        const N: usize = 4;
        #[inline(always)]
        fn zero() -> V4 {
            V4([0.0; 4])
        }
        #[inline(always)]
        fn splat(x: f32) -> V4 {
            V4([x; 4])
        }
        #[inline(always)]
        fn load(s: &[f32], at: usize) -> V4 {
            V4([s[at], s[at + 1], s[at + 2], s[at + 3]])
        }
        #[inline(always)]
        fn store(self, s: &mut [f32], at: usize) {
            s[at..at + 4].copy_from_slice(&self.0);
        }
        #[inline(always)]
        fn add(self, o: V4) -> V4 {
            V4(std::array::from_fn(|i| self.0[i] + o.0[i]))
        }
        #[inline(always)]
        fn sub(self, o: V4) -> V4 {
            V4(std::array::from_fn(|i| self.0[i] - o.0[i]))
        }
        #[inline(always)]
        fn mul(self, o: V4) -> V4 {
            V4(std::array::from_fn(|i| self.0[i] * o.0[i]))
        }
        #[inline(always)]
        fn sum(self) -> f32 {
            (self.0[0] + self.0[2]) + (self.0[1] + self.0[3])
        }
    }

    /// Eight f32 lanes (AVX). Used only inside `Single::refine_avx`, which runs only
    /// after the run-time check that the processor has AVX.
    #[cfg(target_arch = "x86_64")]
    #[derive(Clone, Copy)]
    pub struct V8(__m256);

    // SAFETY (all `unsafe` blocks of this impl): the AVX intrinsics are sound where the
    // processor has AVX; `V8` is used only by `Single::refine_avx`, which
    // `Single::refine` calls only when `is_x86_feature_detected!("avx")` said so (the
    // methods are inlined into it, so the intrinsics are compiled with AVX enabled).
    #[cfg(target_arch = "x86_64")]
    intrinsic_lanes!(
        V8,
        8,
        _mm256_setzero_ps,
        _mm256_set1_ps,
        _mm256_loadu_ps,
        _mm256_storeu_ps,
        _mm256_add_ps,
        _mm256_sub_ps,
        _mm256_mul_ps,
        |x| {
            let s4 = _mm_add_ps(_mm256_castps256_ps128(x), _mm256_extractf128_ps::<1>(x));
            let s2 = _mm_add_ps(s4, _mm_movehl_ps(s4, s4));
            _mm_cvtss_f32(_mm_add_ss(s2, _mm_shuffle_ps::<1>(s2, s2)))
        }
    );
}

use lanes::Lanes;

/// The lane sums of one evaluation: JᵀJ terms (h11, h12, h22), ⟨I,I⟩, ⟨I,∂I/∂x⟩,
/// ⟨I,∂I/∂y⟩ (weighted) and the residual terms (cost, gradient x, gradient y).
struct Sums<V> {
    h: [V; 3],
    ii: V,
    xi: V,
    yi: V,
    res: [V; 3],
}

/// The evaluation's [`Point`] at scale c from its lane sums: with a fitted scale the
/// part of ∂I that c absorbs is projected out (variable projection, Kaufman),
/// J = c·(∂I − I⟨I,∂I⟩/⟨I,I⟩).
#[inline(always)]
fn point<V: Lanes>(gx: f64, gy: f64, c: f32, scaled: bool, s: &Sums<V>) -> Point {
    let (c64, c2) = (c as f64, (c * c) as f64);
    let sum = |x: V| x.sum() as f64;
    let mut h = s.h.map(sum);
    let ii = sum(s.ii);
    if scaled && ii > 0.0 {
        let (xi, yi) = (sum(s.xi), sum(s.yi));
        h = [
            h[0] - xi * xi / ii,
            h[1] - xi * yi / ii,
            h[2] - yi * yi / ii,
        ];
    }
    Point {
        gx,
        gy,
        c,
        cost: s.res[0].sum(),
        h: [c2 * h[0], c2 * h[1], c2 * h[2]],
        g: [c64 * sum(s.res[1]), c64 * sum(s.res[2])],
        step: [0.0; 2],
    }
}

/// Second pass of a scaled fit: c = max(⟨t,I⟩/⟨I,I⟩, 0) from the sums `ti`, `ii`,
/// then the residual terms of t − c·I (interpolated tuple and gradients in `b`) added to
/// `acc`. Returns c.
#[inline(always)]
fn scaled_residuals<V: Lanes>(
    t: &[f32],
    w: &[f32],
    b: &Buf,
    ti: f32,
    ii: f32,
    acc: &mut [V; 3],
) -> f32 {
    let c = if ii > 0.0 { (ti / ii).max(0.0) } else { 0.0 };
    let cv = V::splat(c);
    for o in (0..t.len()).step_by(V::N) {
        let r = V::load(t, o).sub(V::load(&b.v, o).mul(cv));
        let (dx, dy) = (V::load(&b.dx, o), V::load(&b.dy, o));
        accumulate(acc, r, V::load(w, o), dx, dy);
    }
    c
}

/// Add the weighted residual terms (Σ w r², Σ w r ∂I/∂gx, Σ w r ∂I/∂gy) of one lane
/// block to `acc`.
#[inline(always)]
fn accumulate<V: Lanes>(acc: &mut [V; 3], r: V, w: V, dx: V, dy: V) {
    let wr = w.mul(r);
    acc[0] = acc[0].add(wr.mul(r));
    acc[1] = acc[1].add(wr.mul(dx));
    acc[2] = acc[2].add(wr.mul(dy));
}

/// Whether the processor has AVX (checked once per [`Single`]).
fn avx_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
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
            avx: avx_available(),
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
    /// `t` with weights `w` (both padded); `b` keeps the interpolated tuple.
    #[inline(always)]
    pub fn eval<V: Lanes>(&self, t: &[f32], w: &[f32], gx: f64, gy: f64, b: &mut Buf) -> Point {
        let (gx, gy) = self.clamp(gx, gy);
        if self.scale {
            self.eval_with::<V, true>(t, w, gx, gy, b)
        } else {
            self.eval_with::<V, false>(t, w, gx, gy, b)
        }
    }

    /// [`Single::eval`] at a clamped position. Without a scale (c = 1) everything is
    /// accumulated in one pass; with one, a first pass interpolates and fits c, a second
    /// accumulates the residual terms.
    #[inline(always)]
    fn eval_with<V: Lanes, const SCALE: bool>(
        &self,
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
            V::splat((gx - c0 as f64) as f32),
            V::splat((gy - r0 as f64) as f32),
        );
        let top = (r0 * self.width + c0) * kp;
        let bot = self.width * kp;
        let d = &self.data[top..top + bot + 2 * kp];
        let (t, w) = (&t[..kp], &w[..kp]);
        let z = V::zero();
        let (mut ti, mut ii, mut h11, mut h12, mut h22) = (z, z, z, z, z);
        let (mut xi, mut yi) = (z, z);
        let mut res = [z; 3];
        for o in (0..kp).step_by(V::N) {
            let (x00, x01) = (V::load(d, o), V::load(d, kp + o));
            let (x10, x11) = (V::load(d, bot + o), V::load(d, bot + kp + o));
            let (tl, wl) = (V::load(t, o), V::load(w, o));
            let (e0, e1) = (x01.sub(x00), x11.sub(x10));
            let up = x00.add(e0.mul(a));
            let dy = x10.add(e1.mul(a)).sub(up);
            let v = up.add(dy.mul(bv));
            let dx = e0.add(e1.sub(e0).mul(bv));
            v.store(&mut b.v, o);
            let (wdx, wdy) = (wl.mul(dx), wl.mul(dy));
            h11 = h11.add(wdx.mul(dx));
            h12 = h12.add(wdx.mul(dy));
            h22 = h22.add(wdy.mul(dy));
            if SCALE {
                dx.store(&mut b.dx, o);
                dy.store(&mut b.dy, o);
                let wv = wl.mul(v);
                ti = ti.add(wv.mul(tl));
                ii = ii.add(wv.mul(v));
                xi = xi.add(wv.mul(dx));
                yi = yi.add(wv.mul(dy));
            } else {
                accumulate(&mut res, tl.sub(v), wl, dx, dy);
            }
        }
        let c = if SCALE {
            scaled_residuals::<V>(t, w, b, ti.sum(), ii.sum(), &mut res)
        } else {
            1.0
        };
        let sums = Sums {
            h: [h11, h12, h22],
            ii,
            xi,
            yi,
            res,
        };
        point(gx, gy, c, SCALE, &sums)
    }

    /// Whether some light is dark in the target `t` (below `level`) but lit in the model
    /// c·I of the last evaluation (above t + `level`): the test of a cast shadow.
    pub fn any_dark_lit(&self, t: &[f32], c: f32, level: f32, b: &Buf) -> bool {
        t.iter().zip(&b.v).fold(false, |any, (&t, &v)| {
            any | ((t < level) & (c * v > t + level))
        })
    }

    /// The model tuple c·I of the last evaluation into `out` (K values).
    pub fn prediction(&self, c: f32, b: &Buf, out: &mut [f32]) {
        for (o, v) in out.iter_mut().zip(&b.v) {
            *o = c * v;
        }
    }

    /// Gauss–Newton from (gx, gy) (see the module docs). The result's tuple is left in
    /// `b` only when `b_holds` of the returned pair is true.
    pub fn refine(
        &self,
        t: &[f32],
        w: &[f32],
        gx: f64,
        gy: f64,
        iters: usize,
        b: &mut Buf,
    ) -> (Point, bool) {
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where the processor reports AVX (`Single::new`)
            return unsafe { self.refine_avx(t, w, gx, gy, iters, b) };
        }
        self.refine_with::<lanes::V4>(t, w, gx, gy, iters, b)
    }

    /// [`Single::refine`] compiled with AVX, on 8-lane vectors (the lane sums are taken
    /// in another order than the 4-lane build's: results agree to rounding). Safety: call
    /// only where the processor has AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn refine_avx(
        &self,
        t: &[f32],
        w: &[f32],
        gx: f64,
        gy: f64,
        iters: usize,
        b: &mut Buf,
    ) -> (Point, bool) {
        self.refine_with::<lanes::V8>(t, w, gx, gy, iters, b)
    }

    /// The body of [`Single::refine`], inlined into each build.
    #[inline(always)]
    fn refine_with<V: Lanes>(
        &self,
        t: &[f32],
        w: &[f32],
        gx: f64,
        gy: f64,
        iters: usize,
        b: &mut Buf,
    ) -> (Point, bool) {
        let mut cur = self.eval::<V>(t, w, gx, gy, b);
        let mut fresh = true;
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
                let f = MAX_STEP / len2.sqrt();
                dx *= f;
                dy *= f;
            }
            let mut accepted = false;
            for _ in 0..4 {
                let f = self.eval::<V>(t, w, cur.gx + dx, cur.gy + dy, b);
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::{dot3, normalize, ImageStack};
    use crate::lut::model::{Model, Scratch};
    use crate::lut::table::BuildOptions;
    use crate::sphere::Circle;

    /// [`Single::eval`] on 8 AVX lanes. Safety: call only where the processor has AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn eval_avx(
        single: &Single,
        t: &[f32],
        w: &[f32],
        gx: f64,
        gy: f64,
        b: &mut Buf,
    ) -> Point {
        single.eval::<lanes::V8>(t, w, gx, gy, b)
    }

    /// A 64² sphere (radius 28 px) under `k` lights, diffuse + a Blinn–Phong lobe.
    fn table(k: usize) -> Table {
        let size = 64;
        let circle = Circle {
            cx: 32.3,
            cy: 31.8,
            radius: 28.0,
        };
        let mut stack = ImageStack::zeros(size, size, k);
        for r in 0..size {
            for c in 0..size {
                let Some(n) = circle.normal_at(r, c, 0.0) else {
                    continue;
                };
                for (i, v) in stack.pixel_flat_mut(r * size + c).iter_mut().enumerate() {
                    let a = i as f32 * 2.4;
                    let l = normalize([0.5 * a.cos(), 0.5 * a.sin(), 0.8]);
                    let h = normalize([l[0], l[1], l[2] + 1.0]);
                    *v = 0.7 * dot3(n, l).max(0.0) + 0.4 * dot3(n, h).max(0.0).powi(20);
                }
            }
        }
        let opts = BuildOptions {
            smooth: Some(0.0),
            ..BuildOptions::default()
        };
        Table::build(&stack, &circle, &opts).unwrap()
    }

    #[test]
    fn fused_pass_matches_the_generic_model_and_converges() {
        // K = 5 needs padding (a copy of the window), K = 8 does not
        for k in [5, 8] {
            for scale in [false, true] {
                let tables = [table(k)];
                let model = Model::new(&tables, scale);
                let single = Single::new(&tables[0], scale);
                let (kp, truth) = (padded(k), (20.3, 25.7));
                let mut s = Scratch::new(k);
                model.sample(truth.0, truth.1, &mut s, false);
                let albedo = if scale { 0.8 } else { 1.0 };
                let mut t = vec![0.0f32; kp];
                t[..k]
                    .iter_mut()
                    .zip(&s.basis[0])
                    .for_each(|(t, v)| *t = albedo * v);
                let mut w = vec![0.0f32; kp];
                w[..k].fill(1.0);
                w[2] = 0.0;
                let mut b = Buf::new(k);
                for (gx, gy) in [(18.2, 24.9), (21.0, 26.5), (30.4, 12.1)] {
                    let p = single.eval::<lanes::V4>(&t, &w, gx, gy, &mut b);
                    #[cfg(target_arch = "x86_64")]
                    if avx_available() {
                        // SAFETY: the processor has AVX (checked just above)
                        let p8 = unsafe { eval_avx(&single, &t, &w, gx, gy, &mut b) };
                        assert!((p8.cost - p.cost).abs() <= 1e-5 * (1.0 + p.cost));
                        assert!((p8.c - p.c).abs() < 1e-5);
                        let (h, h8) = (p.h[0] + p.h[2], p8.h[0] + p8.h[2]);
                        assert!((h8 - h).abs() <= 1e-4 * h.abs(), "AVX {h8} vs {h}");
                    }
                    let f = model.eval(&t[..k], Some(&w[..k]), gx, gy, &mut s);
                    assert!(
                        (p.cost - f.cost).abs() <= 1e-5 * (1.0 + f.cost),
                        "K {k} scale {scale}: cost {} vs {}",
                        p.cost,
                        f.cost
                    );
                    assert!((p.c - f.coef[0]).abs() < 1e-5);
                }
                let (p, _) = single.refine(&t, &w, 19.0, 24.6, 8, &mut b);
                let err = ((p.gx - truth.0).powi(2) + (p.gy - truth.1).powi(2)).sqrt();
                assert!(err < 0.01, "K {k} scale {scale}: {err} px off");
                assert!((p.c - albedo).abs() < 1e-3, "K {k}: c = {}", p.c);
            }
        }
    }
}
