//! The Nayar–Ikeuchi–Kanade iteration ("Shape from interreflections", IJCV 6(3), 1991).
//!
//! Photometric stereo on images with interreflections sees a concave shape too shallow
//! (bounced light flattens the shading) and too bright. Starting from that shape S₀:
//!
//! 1. build the kernel K on S_{t−1} (facets, visibility),
//! 2. compensate the raw images: I_direct = I_raw − ρ_{t−1}∘(K·I_raw),
//! 3. photometric stereo + integration on I_direct → S_t (normals, albedo, depth),
//! 4. stop when the spread of Δz = z_t − z_{t−1} over the mask (its 99th minus its 1st
//!    percentile, so the free offset of integration does not count) divided by the depth
//!    range of z_t is below the tolerance, or after `max_iter` steps. For a bowl or a groove
//!    this is the relative change of the depth of the concavity; unlike the mean |Δz| it is
//!    not diluted by flat parts that do not move.
//!
//! The fixed point is exact: with the true shape and albedo, step 2 returns the direct
//! images, which are then exactly Lambertian. Each iterate is therefore rated by the
//! photometric-stereo residual of the images compensated with it ([`Iterate::fit_residual`]).
//! Without convergence (oscillation, divergence — e.g. on images that hold no
//! interreflections, where every compensation over-corrects) the run stops at the maximum,
//! says so in [`Convergence`], and [`NikOutput::best`] points at the iterate with the
//! smallest fit residual.
//!
//! The residual is no check of the image scale: one bounce under a directional light is
//! linear in the light direction wherever every light sees every facet, so plain
//! photometric stereo fits it with no residual (a bowl: < 1e-4 at every iterate); only
//! attached shadows (a groove's walls) make it informative. With images off by a factor f
//! the iteration removes f times the right bounced light and converges to a wrong depth
//! (bowl: 0.94 of the truth at f = 0.5, 1.21 at f = 2); see `docs/interreflection-scale.md`
//! for the table and the evidence for keeping the residual-based choice, and
//! [`NikOptions::scale_known`].

use super::radiosity::Model;
use super::RadiosityOptions;
use crate::error::{Error, Result};
use crate::image::{DepthMap, GrayImage, ImageStack, Lights, Mask, NormalMap};
use crate::progress::{NoProgress, Progress};
use crate::{integrate, lambertian};
use std::borrow::Cow;

/// Options of the iteration.
#[derive(Clone, Debug)]
pub struct NikOptions {
    /// Most compensation steps after the first (raw) reconstruction.
    pub max_iter: usize,
    /// Stop when the spread of Δz (99th − 1st percentile) / depth range falls below this
    /// (unitless; 0.01 = 1 %).
    pub tol: f32,
    /// The forward model used to predict bounced light.
    pub radiosity: RadiosityOptions,
    /// Photometric stereo used at every step (default: shadow rejection, no highlight
    /// rejection — the model is Lambertian). Its `black_level` (image units) is taken off
    /// the images once, before the iteration ([`solve`]).
    pub lambertian: lambertian::Options,
    /// Integration used at every step (default: masked least squares).
    pub integrate: integrate::Options,
    /// Whether the caller knows that `raw` is in radiance units (a white Lambertian surface
    /// facing a unit light reads 1): calibrated intensities, an image scale given by the
    /// user or read from the dataset. The iteration cannot check it — the bounced light it
    /// removes is proportional to the absolute albedo, so the recovered depth follows any
    /// error in the scale (table in `docs/interreflection-scale.md`). It is only echoed in
    /// [`NikOutput::scale_known`] so that front ends can warn; default `false`.
    pub scale_known: bool,
}

impl Default for NikOptions {
    fn default() -> Self {
        NikOptions {
            max_iter: 10,
            tol: 0.01,
            radiosity: RadiosityOptions::default(),
            lambertian: lambertian::Options {
                reject_shadows: true,
                reject_highlights: false,
                residual_rejection: 0.0,
                ..lambertian::Options::default()
            },
            integrate: integrate::Options::default(),
            scale_known: false,
        }
    }
}

/// The iteration with Lambertian photometric stereo ([`lambertian::solve`]) and integration
/// ([`integrate::solve`]) on images `raw` taken under `lights`. The camera's black level
/// of `opts.lambertian` is taken off `raw` before the iteration, so that the bounced
/// light is computed from the radiance alone.
pub fn solve(
    raw: &ImageStack,
    mask: &Mask,
    lights: &Lights,
    opts: &NikOptions,
    progress: &dyn Progress,
) -> Result<NikOutput> {
    if lights.is_empty() || lights.len() != raw.k {
        return Err(Error::LightCount {
            what: "light directions for the interreflection iteration".into(),
            expected: raw.k,
            found: lights.len(),
            fix: "give one light direction per image (at least 3)".into(),
        });
    }
    // the camera's black level comes off the images once, before the iteration: the
    // bounced light is computed from the images as the radiance the facets send, which
    // does not include it
    let (level, mut ps_opts) = (opts.lambertian.black_level, opts.lambertian.clone());
    if !(level.is_finite() && level >= 0.0) {
        return Err(Error::invalid(
            format!("black level {level} of the interreflection iteration"),
            "give the camera's black level in image units (0 for none)",
        ));
    }
    let raw = if level == 0.0 {
        Cow::Borrowed(raw)
    } else {
        ps_opts.black_level = 0.0;
        Cow::Owned(without_black_level(raw, level))
    };
    let reconstruct = |stack: &ImageStack| -> Result<Reconstruction> {
        let ps = lambertian::solve(stack, mask, lights, &ps_opts)?;
        let z = integrate::solve(&ps.normals, mask, &opts.integrate)?;
        let residual = masked_mean(&ps.residual, mask);
        Ok(Reconstruction {
            normals: ps.normals,
            albedo: ps.albedo,
            depth: z.depth,
            residual,
        })
    };
    iterate(&raw, mask, opts, &reconstruct, progress)
}

/// `stack` less `level` in every sample (not clipped at 0, as the Lambertian solve takes
/// a level off).
fn without_black_level(stack: &ImageStack, level: f32) -> ImageStack {
    let mut out = stack.clone();
    out.data.iter_mut().for_each(|v| *v -= level);
    out
}

/// One shape estimate: what photometric stereo + integration return for a set of images.
#[derive(Clone, Debug)]
pub struct Reconstruction {
    /// Unit normals.
    pub normals: NormalMap,
    /// Albedo (same scale as the images / light intensities).
    pub albedo: GrayImage,
    /// Depth, pixel units, NaN outside the mask.
    pub depth: DepthMap,
    /// How well the images fit the Lambertian model: mean over the mask of the photometric
    /// stereo RMS residual (image units); NaN when unknown.
    pub residual: f32,
}

/// One iterate with its diagnostics.
#[derive(Clone, Debug)]
pub struct Iterate {
    /// The shape estimate.
    pub shape: Reconstruction,
    /// Mean |Δz| (pixels) against the previous iterate, after removing each mean; NaN for
    /// iterate 0.
    pub mean_change: f32,
    /// Spread of Δz (99th − 1st percentile over the mask) / depth range of this iterate;
    /// NaN for iterate 0. The convergence test compares it with the tolerance.
    pub relative_change: f32,
    /// Depth range (max − min over the mask), pixels: the depth of the concavity.
    pub depth_range: f32,
    /// Mean albedo over the mask.
    pub mean_albedo: f32,
    /// [`Reconstruction::residual`] of the images compensated with THIS iterate's shape and
    /// albedo: near 0 when the shape explains the interreflections (the compensated images
    /// are then exactly Lambertian). NaN when not computed (after convergence, the last one).
    pub fit_residual: f32,
}

/// How the iteration ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Convergence {
    /// The relative change fell below the tolerance at this iterate.
    Converged {
        /// Iterate index (1-based compensation steps).
        at: usize,
    },
    /// `max_iter` was reached first.
    MaxIterations {
        /// True when the change went up again at least once (oscillation or divergence).
        oscillating: bool,
    },
}

/// Result of [`iterate`].
#[derive(Clone, Debug)]
pub struct NikOutput {
    /// Iterate 0 is the raw reconstruction; iterate t the one after t compensations.
    pub iterations: Vec<Iterate>,
    /// Index of the iterate to use: the last one when converged, otherwise the one with the
    /// smallest fit residual (the shape whose compensated images are the most Lambertian),
    /// or the smallest change when residuals are unknown ([`choose_best`]).
    pub best: usize,
    /// How the iteration ended.
    pub convergence: Convergence,
    /// Facet block (pixels) of the interreflection model ([`RadiosityOptions::block_for`]).
    pub block: usize,
    /// The tolerance of the stopping test ([`NikOptions::tol`]).
    pub tol: f32,
    /// [`NikOptions::scale_known`]: `false` when nobody said that the images are in
    /// radiance units; the depth then depends on that unknown factor and should be reported
    /// as such.
    pub scale_known: bool,
}

impl NikOutput {
    /// The iterate to use.
    pub fn best_shape(&self) -> &Reconstruction {
        &self.iterations[self.best].shape
    }

    /// One-line summary: converged or not, which iterate is kept, the facet size.
    pub fn summary(&self) -> String {
        let ending = match &self.convergence {
            Convergence::Converged { at } => format!(
                "converged after {at} iteration(s) (relative change {:.4})",
                self.iterations[*at].relative_change
            ),
            Convergence::MaxIterations { oscillating } => {
                let b = &self.iterations[self.best];
                let why = if b.fit_residual.is_finite() {
                    format!("smallest fit residual {:.5}", b.fit_residual)
                } else {
                    format!("smallest change {:.4}", b.relative_change)
                };
                format!(
                    "did not converge in {} iterations{}; keeping iterate {} ({why})",
                    self.iterations.len() - 1,
                    if *oscillating {
                        " (the change oscillates)"
                    } else {
                        ""
                    },
                    self.best,
                )
            }
        };
        format!("{ending}; facets of {0}×{0} px", self.block)
    }

    /// Convergence table as CSV: iteration, mean change (px), relative change, depth range
    /// (px), mean albedo, fit residual.
    pub fn convergence_csv(&self) -> String {
        let mut s = String::from(
            "iteration,mean_change_px,relative_change,depth_range_px,mean_albedo,fit_residual\n",
        );
        for (t, it) in self.iterations.iter().enumerate() {
            s.push_str(&format!(
                "{t},{},{},{},{},{}\n",
                it.mean_change, it.relative_change, it.depth_range, it.mean_albedo, it.fit_residual
            ));
        }
        s
    }
}

/// Run the iteration with any photometric stereo + integration given as `reconstruct`.
///
/// `raw` are the images with interreflections; `mask` selects the object.
pub fn iterate(
    raw: &ImageStack,
    mask: &Mask,
    opts: &NikOptions,
    reconstruct: &dyn Fn(&ImageStack) -> Result<Reconstruction>,
    progress: &dyn Progress,
) -> Result<NikOutput> {
    mask.check_size(raw.width, raw.height, "interreflection mask")?;
    mask.check_not_empty("interreflection mask")?;
    if opts.tol.is_nan() || opts.tol < 0.0 {
        return Err(Error::invalid(
            format!("interreflection tolerance {}", opts.tol),
            "use a tolerance ≥ 0 (e.g. 0.01)",
        ));
    }
    let mut opts = opts.clone();
    opts.radiosity.block = opts.radiosity.block_for(mask);
    let opts = &opts;
    progress.start("interreflection iterations", opts.max_iter as u64 + 1);
    let first = reconstruct(raw)?;
    let mut iterations = vec![make_iterate(first, None, mask)];
    progress.note(&format!(
        "iteration 0 (raw): depth range {:.3} px, mean albedo {:.4}; facets of {2}×{2} px",
        iterations[0].depth_range, iterations[0].mean_albedo, opts.radiosity.block
    ));
    progress.advance(1);
    let mut convergence = None;
    for t in 1..=opts.max_iter {
        let shape =
            compensate_and_reconstruct(raw, mask, &iterations[t - 1].shape, opts, reconstruct)?;
        iterations[t - 1].fit_residual = shape.residual;
        let it = make_iterate(shape, Some(&iterations[t - 1].shape.depth), mask);
        let done = it.relative_change < opts.tol;
        progress.note(&format!(
            "iteration {t}/{}: depth range {:.3} px, relative change {:.4} (tolerance {}), mean albedo {:.4}",
            opts.max_iter, it.depth_range, it.relative_change, opts.tol, it.mean_albedo
        ));
        iterations.push(it);
        progress.advance(1);
        if done {
            convergence = Some(Convergence::Converged { at: t });
            break;
        }
    }
    progress.finish();
    let (best, convergence) = match convergence {
        Some(c @ Convergence::Converged { at }) => (at, c),
        _ => rate_and_choose(raw, mask, &mut iterations, opts, reconstruct)?,
    };
    Ok(NikOutput {
        iterations,
        best,
        convergence,
        block: opts.radiosity.block,
        tol: opts.tol,
        scale_known: opts.scale_known,
    })
}

/// Without convergence: rate the last iterate too (one more compensation gives its fit
/// residual), then pick the best iterate by [`choose_best`].
fn rate_and_choose(
    raw: &ImageStack,
    mask: &Mask,
    iterations: &mut [Iterate],
    opts: &NikOptions,
    reconstruct: &dyn Fn(&ImageStack) -> Result<Reconstruction>,
) -> Result<(usize, Convergence)> {
    if let Some(last) = iterations.last_mut() {
        if opts.max_iter > 0 {
            let next = compensate_and_reconstruct(raw, mask, &last.shape, opts, reconstruct)?;
            last.fit_residual = next.residual;
        }
    }
    let changes: Vec<f32> = iterations.iter().map(|i| i.relative_change).collect();
    let residuals: Vec<f32> = iterations.iter().map(|i| i.fit_residual).collect();
    Ok(choose_best(&changes, &residuals))
}

/// Compensate `raw` with the kernel and albedo of `shape`, then reconstruct.
fn compensate_and_reconstruct(
    raw: &ImageStack,
    mask: &Mask,
    shape: &Reconstruction,
    opts: &NikOptions,
    reconstruct: &dyn Fn(&ImageStack) -> Result<Reconstruction>,
) -> Result<Reconstruction> {
    let model = Model::new(
        &shape.depth,
        &shape.normals,
        mask,
        &opts.radiosity,
        &NoProgress,
    )?;
    let direct = model.compensate(raw, &shape.albedo)?;
    reconstruct(&direct)
}

/// Without convergence: the iterate with the smallest finite fit residual when every iterate
/// has one, otherwise the iterate (≥ 1) with the smallest change; and whether the change ever
/// went up (oscillation or divergence). `changes[0]` belongs to the raw iterate.
pub fn choose_best(changes: &[f32], residuals: &[f32]) -> (usize, Convergence) {
    let argmin = |v: &[f32], skip: usize| {
        v.iter()
            .enumerate()
            .skip(skip)
            .filter(|(_, c)| c.is_finite())
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(t, _)| t)
    };
    let best = if !residuals.is_empty() && residuals.iter().all(|r| r.is_finite()) {
        argmin(residuals, 0)
    } else {
        argmin(changes, 1)
    };
    let oscillating = changes
        .windows(2)
        .skip(1)
        .any(|w| w[1].is_finite() && w[0].is_finite() && w[1] > w[0]);
    (best, Convergence::MaxIterations { oscillating })
}

fn make_iterate(shape: Reconstruction, prev: Option<&DepthMap>, mask: &Mask) -> Iterate {
    let range = depth_range(&shape.depth, mask);
    let mean_change = prev.map_or(f32::NAN, |p| mean_abs_change(p, &shape.depth, mask));
    let relative_change =
        prev.map_or(f32::NAN, |p| change_spread(p, &shape.depth, mask)) / range.max(1e-6);
    let mean_albedo = masked_mean(&shape.albedo, mask);
    Iterate {
        shape,
        mean_change,
        relative_change,
        depth_range: range,
        mean_albedo,
        fit_residual: f32::NAN,
    }
}

/// Max − min of the finite depths inside the mask (0 when there is none).
pub fn depth_range(depth: &DepthMap, mask: &Mask) -> f32 {
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for (&z, &m) in depth.data.iter().zip(&mask.data) {
        if m && z.is_finite() {
            lo = lo.min(z);
            hi = hi.max(z);
        }
    }
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}

/// Mean over the mask of the finite values.
pub fn masked_mean(img: &GrayImage, mask: &Mask) -> f32 {
    let (mut s, mut n) = (0.0f64, 0usize);
    for (&v, &m) in img.data.iter().zip(&mask.data) {
        if m && v.is_finite() {
            s += v as f64;
            n += 1;
        }
    }
    if n == 0 {
        f32::NAN
    } else {
        (s / n as f64) as f32
    }
}

/// 99th minus 1st percentile of b − a over mask pixels where both are finite (0 if none).
pub fn change_spread(a: &DepthMap, b: &DepthMap, mask: &Mask) -> f32 {
    let mut d: Vec<f32> = (0..a.data.len())
        .filter(|&i| mask.data[i] && a.data[i].is_finite() && b.data[i].is_finite())
        .map(|i| b.data[i] - a.data[i])
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    let n = d.len();
    let (lo, hi) = ((n - 1) / 100, (n - 1) - (n - 1) / 100);
    let low = *d.select_nth_unstable_by(lo, f32::total_cmp).1;
    let high = *d.select_nth_unstable_by(hi, f32::total_cmp).1;
    high - low
}

/// Mean |(a − mean a) − (b − mean b)| over mask pixels where both are finite.
pub fn mean_abs_change(a: &DepthMap, b: &DepthMap, mask: &Mask) -> f32 {
    let both = |i: usize| mask.data[i] && a.data[i].is_finite() && b.data[i].is_finite();
    let idx: Vec<usize> = (0..a.data.len()).filter(|&i| both(i)).collect();
    if idx.is_empty() {
        return f32::NAN;
    }
    let n = idx.len() as f64;
    let ma = idx.iter().map(|&i| a.data[i] as f64).sum::<f64>() / n;
    let mb = idx.iter().map(|&i| b.data[i] as f64).sum::<f64>() / n;
    let s: f64 = idx
        .iter()
        .map(|&i| ((a.data[i] as f64 - ma) - (b.data[i] as f64 - mb)).abs())
        .sum();
    (s / n) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn best_iterate_is_the_smallest_change_and_oscillation_is_flagged() {
        let changes = [f32::NAN, 0.3, 0.1, 0.2, 0.05, 0.4];
        let (best, c) = choose_best(&changes, &[f32::NAN; 6]);
        assert_eq!(best, 4);
        assert_eq!(c, Convergence::MaxIterations { oscillating: true });
        // With residuals for every iterate, the smallest residual wins (here the raw one).
        let (best, _) = choose_best(&changes, &[0.01, 0.02, 0.03, 0.04, 0.05, 0.06]);
        assert_eq!(best, 0);
        let (best, c) = choose_best(&[f32::NAN, 0.3, 0.2, 0.1], &[]);
        assert_eq!(best, 3);
        assert_eq!(c, Convergence::MaxIterations { oscillating: false });
    }

    #[test]
    fn a_black_level_that_is_not_a_level_is_refused() {
        let stack = ImageStack::zeros(8, 8, 3);
        let lights =
            Lights::from_directions(vec![[0.0, 0.0, 1.0], [0.5, 0.0, 0.8], [0.0, 0.5, 0.8]]);
        for level in [f32::NAN, -0.01, f32::INFINITY] {
            let mut opts = NikOptions::default();
            opts.lambertian.black_level = level;
            let err = solve(&stack, &Mask::full(8, 8), &lights, &opts, &NoProgress);
            assert!(
                matches!(err, Err(Error::InvalidInput { .. })),
                "level {level}: {err:?}"
            );
        }
    }

    #[test]
    fn mean_change_ignores_the_offset() {
        let mask = Mask::full(3, 1);
        let a = DepthMap::from_vec(3, 1, vec![0.0, 1.0, 2.0]).unwrap();
        let b = a.map(|z| z + 5.0);
        assert!(mean_abs_change(&a, &b, &mask) < 1e-6);
        let c = DepthMap::from_vec(3, 1, vec![0.0, 2.0, 4.0]).unwrap();
        // Centred: a = (-1, 0, 1), c = (-2, 0, 2): mean |Δ| = 2/3.
        assert!((mean_abs_change(&a, &c, &mask) - 2.0 / 3.0).abs() < 1e-6);
        assert_eq!(depth_range(&c, &mask), 4.0);
        // Δ = (0, 1, 2): with 3 samples the percentiles are the extremes.
        assert!((change_spread(&a, &c, &mask) - 2.0).abs() < 1e-6);
        assert!(change_spread(&a, &b, &mask).abs() < 1e-6);
    }
}
