//! Lambertian photometric stereo (Woodham 1980) with outlier rejection.
//!
//! A Lambertian pixel with albedo ρ and unit normal n, under a distant light of
//! direction lᵢ (unit, surface → light) and intensity eᵢ, reads
//!
//! Iᵢ = ρ eᵢ max(0, n·lᵢ).
//!
//! Where the pixel is lit, Iᵢ = Lᵢ·b with Lᵢ = eᵢ lᵢ and b = ρ n. With K ≥ 3 lit
//! samples, b is the least-squares solution of the 3×3 normal equations
//! (Σ Lᵢ Lᵢᵀ) b = Σ Iᵢ Lᵢ; then ρ = ‖b‖ and n = b/‖b‖.
//!
//! Real surfaces break the model in two ways, both handled per pixel when enabled:
//!
//! * **shadows** (attached, n·l ≤ 0, or cast): samples darker than
//!   `shadow_threshold` × the pixel's brightest kept sample are dropped;
//! * **highlights** (specular lobes, saturation): first the brightest
//!   `highlight_fraction` of the samples are dropped; after a first fit, every sample
//!   is re-judged by its residual rᵢ = Iᵢ − Lᵢ·b and kept only when it is predicted
//!   lit (Lᵢ·b > 0) and |rᵢ| ≤ `residual_rejection` · σ̂, with the robust scale
//!   σ̂ = 1.4826 · median |rᵢ| of the kept samples — a trimmed, iteratively
//!   re-selected least squares in the spirit of Barsky & Petrou (2003) and of the
//!   rank-based selection of Mukaigawa et al. (2007).
//!
//! A pixel left with fewer than `min_lights` samples retries with shadow rejection
//! only, then takes its `min_lights` brightest positive samples, and only if still
//! short falls back to all K samples (plain least squares); a pixel whose b vanishes (black) gets n = (0, 0, 1) and
//! ρ = 0. Every mask pixel therefore gets a unit normal; `used_lights` and
//! `residual` say how far to trust it.
//!
//! **A camera's black level** β (a dark offset on every sample: Iᵢ = β + ρ eᵢ max(0,
//! n·lᵢ)) reads as light that no normal explains: a 3% level costs an 8-bit Lambertian
//! blob 0.05° → 2.2°. [`Options::black_level`] takes a known level off every sample;
//! [`estimate_black_level`] measures it from the robust fits by variable projection
//! (β is common to all pixels, each pixel's b is projected out; [`BlackLevelSums`] sums
//! it over row bands of a capture too large to hold whole). A level that is taken off is
//! measured again on the images with it taken off ([`measure_black_level`]): the first
//! measurement keeps shadowed samples, which read β itself, where β is above the shadow
//! threshold, and comes out high (8-bit textured blob: 0.0313 for 0.0300). It cannot be measured
//! when the lights lie on one cone about an axis (a ring at one elevation): the offset
//! is then a tilt of every normal towards that axis. Whether a measured level is taken
//! off is one rule for every caller ([`BlackLevel::is_taken`]; [`BlackLevelChoice`] and
//! [`decide_black_level`] for `auto`, `none` or a given level). [`solve_with_black_level`]
//! decides and solves in one call, and where no level is taken the fits that measured it
//! are the solve's own (one pass over the stack, not two).
//!
//! R. J. Woodham, "Photometric method for determining surface orientation from
//! multiple images", Optical Engineering 19(1), 1980.
//! S. Barsky and M. Petrou, "The 4-source photometric stereo technique for
//! three-dimensional surfaces in the presence of highlights and shadows", PAMI 2003.

use crate::error::{Error, Result};
use crate::image::{GrayImage, Image, ImageStack, Lights, Mask, NormalMap};
use crate::sphere::fit::{accumulate, solve3};
use rayon::prelude::*;

mod black_level;
pub(crate) use black_level::black_terms;
pub use black_level::{
    decide_black_level, estimate_black_level, measure_black_level, solve_with_black_level,
    BlackLevel, BlackLevelChoice, BlackLevelDecision, BlackLevelSums, LEVEL_TOLERANCE,
    MAX_BLACK_LEVEL, REFINE_ROUNDS,
};

/// Settings of [`solve`]. `Default` is the robust solver; [`Options::plain`] is
/// classic least squares over all samples.
#[derive(Clone, Debug)]
pub struct Options {
    /// Drop samples darker than `shadow_threshold` × the pixel's brightest kept sample
    /// and, after the first fit, samples predicted in attached shadow (Lᵢ·b ≤ 0).
    pub reject_shadows: bool,
    /// Shadow level as a fraction of the pixel's brightest kept sample (0..1).
    pub shadow_threshold: f32,
    /// Drop the brightest samples first, then re-judge all samples by their residual.
    pub reject_highlights: bool,
    /// Fraction (0..1) of each pixel's brightest samples dropped before the first fit.
    pub highlight_fraction: f32,
    /// Residual cut, in robust standard deviations, for the re-selection after the
    /// first fit (0 = no re-selection).
    pub residual_rejection: f32,
    /// Re-selection rounds after the first fit.
    pub iterations: usize,
    /// Fewest samples a robust fit may use (≥ 3); below it the pixel uses all K.
    pub min_lights: usize,
    /// The camera's black level (image units), taken off every sample before the fit:
    /// a sensor's dark offset reads as light that no normal explains (a 3% black level
    /// on an 8-bit Lambertian blob: 0.05° → 2.2°). [`estimate_black_level`] measures it
    /// from the images. Default 0.
    pub black_level: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            reject_shadows: true,
            shadow_threshold: 0.05,
            reject_highlights: true,
            highlight_fraction: 0.15,
            residual_rejection: 2.5,
            iterations: 3,
            min_lights: 3,
            black_level: 0.0,
        }
    }
}

impl Options {
    /// Classic least squares over all K samples (no rejection).
    pub fn plain() -> Self {
        Options {
            reject_shadows: false,
            reject_highlights: false,
            residual_rejection: 0.0,
            iterations: 0,
            ..Options::default()
        }
    }

    /// The options the black level is measured with ([`estimate_black_level`]): these
    /// when they reject shadows and highlights, else the robust defaults with this
    /// [`Options::black_level`] — a plain fit keeps the shadows, which the offset's model
    /// (every used sample lit) does not hold.
    pub fn for_black_level(&self) -> Options {
        if self.measures_black_level() {
            self.clone()
        } else {
            Options {
                black_level: self.black_level,
                ..Options::default()
            }
        }
    }

    /// Whether the black level is measured on the fits of these very options
    /// ([`Options::for_black_level`] is a copy of them).
    fn measures_black_level(&self) -> bool {
        self.reject_shadows && self.reject_highlights
    }
}

/// Result of [`solve`]. Outside the mask: normal (0,0,0), albedo 0, residual 0, 0 lights.
#[derive(Clone, Debug)]
pub struct Output {
    /// Unit normals (camera frame) on every mask pixel.
    pub normals: NormalMap,
    /// ρ = ‖b‖, in image units per unit light intensity.
    pub albedo: GrayImage,
    /// RMS residual Iᵢ − Lᵢ·b over the samples used (image units).
    pub residual: GrayImage,
    /// Number of samples used per pixel.
    pub used_lights: Image<u16>,
}

/// Per-pixel Lambertian photometric stereo over the mask (see the module docs).
///
/// Errors: [`Error::LightCount`] for K < 3 or a light count that differs from the
/// number of images; [`Error::SizeMismatch`] / [`Error::EmptyMask`] for a bad mask;
/// [`Error::InvalidInput`] for coplanar lights or `min_lights` < 3.
pub fn solve(stack: &ImageStack, mask: &Mask, lights: &Lights, opts: &Options) -> Result<Output> {
    let eff = check_inputs(stack, mask, lights, opts)?;
    output(stack, &fit_all(stack, mask, &eff, opts, false))
}

/// The output images of every pixel's fit (`fits` from [`fit_all`] on `stack`).
fn output(stack: &ImageStack, fits: &[PixelFit]) -> Result<Output> {
    let (w, h) = (stack.width, stack.height);
    Ok(Output {
        normals: Image::from_vec(w, h, fits.iter().map(|f| f.normal).collect())?,
        albedo: Image::from_vec(w, h, fits.iter().map(|f| f.albedo).collect())?,
        residual: Image::from_vec(w, h, fits.iter().map(|f| f.residual).collect())?,
        used_lights: Image::from_vec(w, h, fits.iter().map(|f| f.used).collect())?,
    })
}

/// Every pixel's fit (outside the mask: [`PixelFit::OUTSIDE`]), on its samples less
/// [`Options::black_level`]; with its terms of [`estimate_black_level`] when `black`.
fn fit_all(
    stack: &ImageStack,
    mask: &Mask,
    eff: &[[f64; 3]],
    opts: &Options,
    black: bool,
) -> Vec<PixelFit> {
    (0..stack.pixels())
        .into_par_iter()
        .map_init(Vec::new, |buf, i| {
            if !mask.data[i] {
                return PixelFit::OUTSIDE;
            }
            let px = stack.pixel_flat(i);
            if opts.black_level == 0.0 {
                return fit_pixel(px, eff, opts, black);
            }
            buf.clear();
            buf.extend(px.iter().map(|v| v - opts.black_level));
            fit_pixel(buf, eff, opts, black)
        })
        .collect()
}

/// Validate and return the effective light vectors Lᵢ = eᵢ lᵢ.
fn check_inputs(
    stack: &ImageStack,
    mask: &Mask,
    lights: &Lights,
    opts: &Options,
) -> Result<Vec<[f64; 3]>> {
    let eff = check_lights(stack.k, lights, opts)?;
    mask.check_size(stack.width, stack.height, "mask")?;
    mask.check_not_empty("mask")?;
    Ok(eff)
}

/// Validate the lights (and `min_lights`) for `k` images and return the effective light
/// vectors Lᵢ = eᵢ lᵢ.
fn check_lights(k: usize, lights: &Lights, opts: &Options) -> Result<Vec<[f64; 3]>> {
    if k < 3 {
        return Err(Error::LightCount {
            what: "Lambertian photometric stereo".into(),
            expected: 3,
            found: k,
            fix: "at least 3 images under 3 non-coplanar lights are needed".into(),
        });
    }
    for (what, n) in [
        ("light directions", lights.directions.len()),
        ("light intensities", lights.intensities.len()),
    ] {
        if n != k {
            return Err(Error::LightCount {
                what: what.into(),
                expected: k,
                found: n,
                fix: "give one light per image, in the order of the images".into(),
            });
        }
    }
    if opts.min_lights < 3 {
        return Err(Error::invalid(
            format!("min_lights = {}", opts.min_lights),
            "a normal and an albedo need at least 3 samples: use min_lights >= 3",
        ));
    }
    let eff: Vec<[f64; 3]> = lights
        .directions
        .iter()
        .zip(&lights.intensities)
        .map(|(d, &e)| {
            [
                d[0] as f64 * e as f64,
                d[1] as f64 * e as f64,
                d[2] as f64 * e as f64,
            ]
        })
        .collect();
    let all: Vec<usize> = (0..eff.len()).collect();
    if least_squares(&eff, &all, |_| 0.0).is_none() {
        return Err(Error::invalid(
            "light directions",
            "the lights are coplanar (or have zero intensity): photometric stereo needs 3 non-coplanar lights",
        ));
    }
    Ok(eff)
}

#[derive(Clone, Copy)]
struct PixelFit {
    normal: [f32; 3],
    albedo: f32,
    residual: f32,
    used: u16,
    /// The pixel's terms of [`estimate_black_level`]: Σ I·u, Σ u (u = P⊥1 over the
    /// samples used) and the residual sum of squares with its degrees of freedom.
    black: [f64; 4],
}

impl PixelFit {
    const OUTSIDE: PixelFit = PixelFit {
        normal: [0.0; 3],
        albedo: 0.0,
        residual: 0.0,
        used: 0,
        black: [0.0; 4],
    };
}

/// Least squares for b over the samples in `sel`; `None` when singular.
fn least_squares(
    eff: &[[f64; 3]],
    sel: &[usize],
    value: impl Fn(usize) -> f64,
) -> Option<[f64; 3]> {
    let mut a = [[0.0f64; 3]; 3];
    let mut rhs = [0.0f64; 3];
    for &i in sel {
        accumulate(&mut a, &mut rhs, eff[i], value(i));
    }
    solve3(a, rhs)
}

/// The robust fit of one pixel (module docs); `black`: with its terms of
/// [`estimate_black_level`] (zeros otherwise).
fn fit_pixel(samples: &[f32], eff: &[[f64; 3]], opts: &Options, black: bool) -> PixelFit {
    let k = samples.len();
    let val = |i: usize| samples[i] as f64;
    let mut sel = initial_selection(samples, opts);
    if sel.len() < opts.min_lights && opts.reject_highlights {
        // few lights: keep the brightest ones rather than fall back to all
        let shadows_only = Options {
            reject_highlights: false,
            ..opts.clone()
        };
        sel = initial_selection(samples, &shadows_only);
    }
    if sel.len() < opts.min_lights {
        sel = brightest(samples, opts.min_lights);
    }
    if sel.len() < opts.min_lights {
        sel = (0..k).collect();
    }
    let mut b = least_squares(eff, &sel, val);
    if opts.residual_rejection > 0.0 {
        for _ in 0..opts.iterations {
            let Some(cur) = b else { break };
            let next = reselect(samples, eff, &sel, cur, opts);
            if next.len() < opts.min_lights || next == sel {
                break;
            }
            let Some(nb) = least_squares(eff, &next, val) else {
                break;
            };
            sel = next;
            b = Some(nb);
        }
    }
    let b = b.unwrap_or([0.0; 3]);
    let rho = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    let normal = if rho > 0.0 && rho.is_finite() {
        [
            (b[0] / rho) as f32,
            (b[1] / rho) as f32,
            (b[2] / rho) as f32,
        ]
    } else {
        [0.0, 0.0, 1.0]
    };
    let ss: f64 = sel.iter().map(|&i| (val(i) - dot(eff[i], b)).powi(2)).sum();
    PixelFit {
        normal,
        albedo: if rho.is_finite() { rho as f32 } else { 0.0 },
        residual: (ss / sel.len().max(1) as f64).sqrt() as f32,
        used: sel.len().min(u16::MAX as usize) as u16,
        black: if black {
            black_terms(eff, &sel, val, ss)
        } else {
            [0.0; 4]
        },
    }
}

/// Drop the brightest fraction, then the shadows relative to the brightest kept sample.
fn initial_selection(samples: &[f32], opts: &Options) -> Vec<usize> {
    let k = samples.len();
    let mut order: Vec<usize> = (0..k).filter(|&i| samples[i].is_finite()).collect();
    order.sort_by(|&a, &b| samples[a].total_cmp(&samples[b]));
    if opts.reject_highlights {
        let drop = (opts.highlight_fraction.clamp(0.0, 1.0) * k as f32).round() as usize;
        let keep = order
            .len()
            .saturating_sub(drop)
            .max(opts.min_lights.min(order.len()));
        order.truncate(keep);
    }
    if opts.reject_shadows {
        let top = order.last().map_or(0.0, |&i| samples[i]);
        let level = opts.shadow_threshold * top;
        order.retain(|&i| samples[i] > level && samples[i] > 0.0);
    }
    order.sort_unstable();
    order
}

/// The `n` brightest positive samples (fewer when fewer are positive).
fn brightest(samples: &[f32], n: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..samples.len())
        .filter(|&i| samples[i].is_finite() && samples[i] > 0.0)
        .collect();
    order.sort_by(|&a, &b| samples[b].total_cmp(&samples[a]));
    order.truncate(n);
    order.sort_unstable();
    order
}

/// Re-judge every sample against the current fit b.
fn reselect(
    samples: &[f32],
    eff: &[[f64; 3]],
    sel: &[usize],
    b: [f64; 3],
    opts: &Options,
) -> Vec<usize> {
    let resid = |i: usize| samples[i] as f64 - dot(eff[i], b);
    let mut abs: Vec<f64> = sel.iter().map(|&i| resid(i).abs()).collect();
    let mid = abs.len() / 2;
    let median = *abs.select_nth_unstable_by(mid, f64::total_cmp).1;
    let rho = dot(b, b).sqrt();
    let sigma = (1.4826 * median).max(1e-4 * rho).max(1e-12);
    let cut = opts.residual_rejection as f64 * sigma;
    let top = sel.iter().map(|&i| samples[i]).fold(0.0f32, f32::max);
    (0..samples.len())
        .filter(|&i| samples[i].is_finite() && resid(i).abs() <= cut)
        .filter(|&i| {
            !opts.reject_shadows
                || (dot(eff[i], b) > 0.0 && samples[i] > opts.shadow_threshold * top)
        })
        .collect()
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
