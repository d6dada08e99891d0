//! How smooth the surface is, block by block: the prior's local scale τ from the
//! matches' own second differences (empirical Bayes).
//!
//! One τ does not suit a whole object. Inside a smooth surface the true second
//! differences of (n_x, n_y) are tiny — RMS 0.00015 / 0.0009 per pixel² on DiLiGenT's
//! bear and harvest true normals, 0.00075 on the shared Mitsuba blob — and a strong
//! prior removes most of the noise there; near an occluding contour (n_x, n_y) bends
//! fast (the blob's 99th percentile, 0.003, lies on its rim) and the same prior
//! flattens it. Measured on the project's blurred 8-bit plastic (blob, sphere r 100):
//! τ = 0.003 everywhere cuts the error inside (0–60° of tilt) from 0.08° to 0.06° but
//! raises the 75–85° band from 2.3° to 4.0°.
//!
//! So the variance of the true second differences is estimated where the evidence is,
//! over blocks of [`BLOCK`]² pixels and the 3 × 3 blocks around each: for every row or
//! column triple (a, b, c) of mask pixels that all know their normal (tr A⁻¹ below
//! `known`), the squared second difference of the matches less the part their own
//! noise explains,
//!
//! e_t = ‖û_a − 2û_b + û_c‖² − (tr A_a⁻¹ + 4 tr A_b⁻¹ + tr A_c⁻¹),
//!
//! is an unbiased estimate of the true ‖D²u‖² (the matches' errors independent, with
//! covariances A⁻¹). Under noise much larger than the surface's bending its mean
//! scatters far more than the signal it estimates (on a plane of normals with noise 0.01
//! per component, the plain mean put 38% of the blocks at τ_max), so the bending kept is
//! the lower bound of [`BOUND`] standard errors: per component
//! ŝ² = max(0, ē − BOUND · SE(ē)) / 2, SE from the spread of e_t with the triples of a
//! line counted as a third as many independent ones (neighbouring triples share
//! pixels). The block's prior scale is τ = clamp(κ ŝ, τ_min, τ_max) with κ = [`MARGIN`]:
//! τ_max where the data show the surface bending (or say nothing: fewer than
//! [`MIN_TRIPLES`] triples, the behaviour of a single τ = τ_max), τ_min where they do
//! not show it. The solve keeps
//! λ = 1/τ_min² and multiplies each pixel's own cost by (τ/τ_min)², which is the same
//! balance of a pixel's data against the prior as a prior weight 1/τ² there.

use super::info::Evidence;
use crate::image::Mask;

/// Side (pixels) of the blocks over which the roughness is estimated.
pub const BLOCK: usize = 4;
/// τ = κ ŝ: the prior's scale is kept this many times the estimated RMS second
/// difference, so that the estimate's own scatter does not oversmooth.
pub const MARGIN: f32 = 2.0;
/// Fewest triples in a 3 × 3 neighbourhood of blocks that make an estimate.
pub const MIN_TRIPLES: f32 = 8.0;
/// Standard errors below the mean excess at which the bending is taken (a lower bound).
/// Measured (own renders, `tests/camera_images.rs`, and DiLiGenT's ball at 0.75×): 0 and
/// 1 give the same blurred 8-bit plastic (0.186 / 0.184°) and ball (0.079 / 0.078°), 1
/// removes more noise (1% noise, Mitsuba Lambertian 0.201 → 0.173°); 2 oversmooths
/// the bending at a blurred object's contour (blurred plastic 0.242°, ball 0.090°).
pub const BOUND: f64 = 1.0;

/// The per-pixel factor (τ/τ_min)² ≥ 1 by which each pixel's own cost is multiplied.
pub(crate) struct PriorScale {
    bw: usize,
    bh: usize,
    /// τ of each block.
    tau: Vec<f32>,
    tau_min: f32,
    width: usize,
}

impl PriorScale {
    /// The factor of grid pixel `i`: τ interpolated bilinearly between the centres of
    /// the blocks around it (a step of τ from block to block would put a seam in the
    /// prior's balance), (τ/τ_min)².
    pub fn at(&self, i: usize) -> f32 {
        let (r, c) = (i / self.width, i % self.width);
        let centre = |p: usize, n: usize| {
            let x = ((p as f32 + 0.5) / BLOCK as f32 - 0.5).clamp(0.0, (n - 1) as f32);
            let lo = (x as usize).min(n - 1);
            (lo, (lo + 1).min(n - 1), x - lo as f32)
        };
        let (r0, r1, fr) = centre(r, self.bh);
        let (c0, c1, fc) = centre(c, self.bw);
        let t = |r: usize, c: usize| self.tau[r * self.bw + c];
        let top = t(r0, c0) + fc * (t(r0, c1) - t(r0, c0));
        let bottom = t(r1, c0) + fc * (t(r1, c1) - t(r1, c0));
        ((top + fr * (bottom - top)) / self.tau_min).powi(2)
    }

    /// From the evidence's matches; `(tau_min, tau_max)` the prior's scales, `known` the
    /// variance tr A⁻¹ below which a match takes part.
    pub fn estimate(
        ev: &Evidence,
        mask: &Mask,
        (tau_min, tau_max): (f32, f32),
        known: f32,
    ) -> Self {
        let (w, h) = (ev.width, ev.height);
        let (bw, bh) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
        let sums = block_sums(ev, mask, known, (bw, bh));
        let mut taus = vec![tau_min; bw * bh];
        for br in 0..bh {
            for bc in 0..bw {
                let [mut s, mut s2, mut n] = [0.0f64; 3];
                for r in br.saturating_sub(1)..(br + 2).min(bh) {
                    for c in bc.saturating_sub(1)..(bc + 2).min(bw) {
                        let b = sums[r * bw + c];
                        (s, s2, n) = (s + b[0], s2 + b[1], n + b[2]);
                    }
                }
                let tau = if n < MIN_TRIPLES as f64 {
                    tau_max
                } else {
                    let mean = s / n;
                    let se = ((s2 / n - mean * mean).max(0.0) * 3.0 / n).sqrt();
                    let bend = ((mean - BOUND * se).max(0.0) / 2.0) as f32;
                    (MARGIN * bend.sqrt()).clamp(tau_min, tau_max)
                };
                taus[br * bw + bc] = tau;
            }
        }
        PriorScale {
            bw,
            bh,
            tau: taus,
            tau_min,
            width: w,
        }
    }
}

/// Per block: the sum of e_t and of e_t² over the triples centred in it, and their
/// number.
fn block_sums(ev: &Evidence, mask: &Mask, known: f32, (bw, bh): (usize, usize)) -> Vec<[f64; 3]> {
    let (w, h) = (ev.width, ev.height);
    let m = &mask.data;
    let var = |i: usize| super::trace_inverse(ev.a[i]);
    let ok = |i: usize| m[i] && var(i) < known;
    let excess = |a: usize, b: usize, c: usize| {
        let d = |k: usize| ev.u[a][k] - 2.0 * ev.u[b][k] + ev.u[c][k];
        let d2 = (d(0) as f64).powi(2) + (d(1) as f64).powi(2);
        d2 - (var(a) + 4.0 * var(b) + var(c)) as f64
    };
    let mut sums = vec![[0.0f64; 3]; bw * bh];
    let mut add = |k: usize, e: f64| {
        let b = &mut sums[k];
        *b = [b[0] + e, b[1] + e * e, b[2] + 1.0];
    };
    for r in 0..h {
        for c in 0..w {
            let b = r * w + c;
            if !ok(b) {
                continue;
            }
            let k = (r / BLOCK) * bw + c / BLOCK;
            if c > 0 && c + 1 < w && ok(b - 1) && ok(b + 1) {
                add(k, excess(b - 1, b, b + 1));
            }
            if r > 0 && r + 1 < h && ok(b - w) && ok(b + w) {
                add(k, excess(b - w, b, b + w));
            }
        }
    }
    sums
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Evidence of a w × h grid whose matches are `field(r, c)` plus Gaussian-like noise of
    /// standard deviation `sigma` per component, each pixel claiming exactly that noise.
    fn evidence(w: usize, h: usize, sigma: f32, field: impl Fn(f32, f32) -> [f32; 2]) -> Evidence {
        let mut state = 12345u64;
        let mut noise = || {
            // sum of 12 uniforms − 6: unit variance, deterministic
            let mut s = 0.0f32;
            for _ in 0..12 {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                s += (state >> 40) as f32 / (1u64 << 24) as f32;
            }
            s - 6.0
        };
        let mut u = Vec::with_capacity(w * h);
        for r in 0..h {
            for c in 0..w {
                let f = field(r as f32, c as f32);
                u.push([f[0] + sigma * noise(), f[1] + sigma * noise()]);
            }
        }
        let info = 1.0 / (sigma * sigma);
        Evidence {
            width: w,
            height: h,
            u,
            a: vec![[info, 0.0, info]; w * h],
            g: Vec::new(),
        }
    }

    const TAUS: (f32, f32) = (0.0025, 0.01);
    const KNOWN: f32 = 0.0025;

    #[test]
    fn a_noisy_plane_of_normals_is_smooth() {
        // (n_x, n_y) linear in the position (a sphere) with noise 0.01: the noise explains
        // the second differences, the prior takes its smallest scale nearly everywhere
        let ev = evidence(64, 64, 0.01, |r, c| {
            [(c - 32.0) / 100.0, (32.0 - r) / 100.0]
        });
        let mask = Mask::filled(64, 64, true);
        let s = PriorScale::estimate(&ev, &mask, TAUS, KNOWN);
        let f: Vec<f32> = (0..64 * 64).map(|i| s.at(i)).collect();
        let at_min = f.iter().filter(|&&x| x < 1.5).count();
        let at_max = f.iter().filter(|&&x| x > 15.0).count();
        eprintln!("noisy plane: {at_min} of 4096 pixels near τ_min, {at_max} at τ_max");
        // a one-sided bound of one standard error leaves about 84% of the blocks at τ_min
        // where the excess is pure scatter
        assert!(at_min > 64 * 64 * 3 / 4, "{at_min} of 4096 near τ_min");
        assert!(at_max < 64 * 64 / 20, "{at_max} of 4096 at τ_max");
    }

    #[test]
    fn a_bending_field_keeps_the_largest_scale() {
        // second differences 0.02 per pixel² (κ ŝ = 0.028 > τ_max) with little noise
        let ev = evidence(48, 48, 1e-4, |r, c| [0.01 * c * c, 0.01 * r * r]);
        let mask = Mask::filled(48, 48, true);
        let s = PriorScale::estimate(&ev, &mask, TAUS, KNOWN);
        let top = (TAUS.1 / TAUS.0).powi(2);
        assert!((0..48 * 48).all(|i| (s.at(i) - top).abs() < 1e-3));
    }

    #[test]
    fn no_evidence_means_the_largest_scale_and_no_panic() {
        let top = (TAUS.1 / TAUS.0).powi(2);
        // every pixel too uncertain to take part
        let ev = evidence(20, 12, 0.5, |_, _| [0.0, 0.0]);
        let s = PriorScale::estimate(&ev, &Mask::filled(20, 12, true), TAUS, KNOWN);
        assert!((0..240).all(|i| s.at(i) == top));
        // empty mask, and a 0 × 0 grid
        let s = PriorScale::estimate(&ev, &Mask::filled(20, 12, false), TAUS, KNOWN);
        assert_eq!(s.at(239), top);
        let ev = evidence(0, 0, 0.01, |_, _| [0.0, 0.0]);
        let _ = PriorScale::estimate(&ev, &Mask::filled(0, 0, true), TAUS, KNOWN);
    }
}
