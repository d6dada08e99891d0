//! The camera's black level: measured from the images by variable projection
//! ([`estimate_black_level`], or band by band with [`BlackLevelSums`]), and the one rule
//! that decides whether a measured level is taken off ([`BlackLevel::is_taken`]), shared
//! by every Lambertian path (`photostereo normals` and `run`, the pipeline, Python).

use super::{
    check_inputs, check_lights, dot, fit_all, least_squares, output, Options, Output, PixelFit,
};
use crate::error::{Error, Result};
use crate::image::{ImageStack, Lights, Mask};

/// Largest black level taken off, as a fraction of full scale: cameras' are a few
/// percent; a larger offset is light of the scene (ambient light, a lit background), not
/// the sensor's, and taking it off would darken real shading.
pub const MAX_BLACK_LEVEL: f32 = 0.25;

/// Most re-measurements of a level taken off ([`measure_black_level`]). Three were enough
/// on every capture tried (8- and 16-bit blobs with cast shadows, 3% level).
pub const REFINE_ROUNDS: usize = 4;

/// A re-measured correction smaller than this fraction of full scale ends the
/// refinement ([`measure_black_level`]): a fortieth of an 8-bit step. On the 8-bit blob
/// of the module docs a level off by 0.8e-4 (what one more round would take off) moves the
/// mean normal error by about 0.001°.
pub const LEVEL_TOLERANCE: f32 = 1e-4;

/// The camera's black level estimated from the images ([`estimate_black_level`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlackLevel {
    /// The level (image units) found above the [`Options::black_level`] already taken
    /// off.
    pub value: f32,
    /// Its standard error (image units), from the fits' residuals.
    pub standard_error: f32,
    /// Pixels that carried it (fits on at least four samples).
    pub pixels: usize,
}

impl BlackLevel {
    /// Whether the level is positive and at least [`BlackLevel::SIGNIFICANCE`] standard
    /// errors from 0.
    pub fn is_significant(&self) -> bool {
        self.value > 0.0 && self.value >= Self::SIGNIFICANCE * self.standard_error
    }

    /// Standard errors a level must stand above 0 to be taken.
    pub const SIGNIFICANCE: f32 = 5.0;

    /// Whether the level is taken off: significant ([`BlackLevel::is_significant`]) and
    /// at most [`MAX_BLACK_LEVEL`] of `full_scale` (the images' full scale in the units
    /// the level was measured in: 1 for images as read, the image scale after one).
    pub fn is_taken(&self, full_scale: f32) -> bool {
        self.is_significant() && self.value <= MAX_BLACK_LEVEL * full_scale
    }
}

/// What to do about the camera's black level before a Lambertian solve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum BlackLevelChoice {
    /// Measure it ([`estimate_black_level`]) and take it off when
    /// [`BlackLevel::is_taken`]: a clean capture without an offset is left as it is.
    #[default]
    Auto,
    /// Take nothing off (beyond [`Options::black_level`]).
    None,
    /// Take off this level, a fraction of full scale in [0, [`MAX_BLACK_LEVEL`]).
    Given(f32),
}

impl BlackLevelChoice {
    /// Errors: [`Error::InvalidInput`] for a given level outside [0,
    /// [`MAX_BLACK_LEVEL`]) (or not finite).
    pub fn check(&self) -> Result<()> {
        match *self {
            BlackLevelChoice::Given(v) if !(0.0..MAX_BLACK_LEVEL).contains(&v) => {
                Err(Error::invalid(
                    format!("black level {v}"),
                    format!(
                        "give a level in [0, {MAX_BLACK_LEVEL}) as a fraction of full scale \
                         (e.g. 0.03), or let it be measured"
                    ),
                ))
            }
            _ => Ok(()),
        }
    }
}

/// The black level a [`BlackLevelChoice`] came to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlackLevelDecision {
    /// The level to set as [`Options::black_level`] (image units).
    pub level: f32,
    /// What was measured ([`BlackLevelChoice::Auto`] only).
    pub measured: Option<BlackLevel>,
    /// The images' full scale in image units (the unit of "fraction of full scale").
    pub full_scale: f32,
}

impl BlackLevelDecision {
    /// The decision for a `choice` that needs no measurement (`None` for
    /// [`BlackLevelChoice::Auto`]): `base` is the [`Options::black_level`] already set.
    pub fn without_measuring(choice: BlackLevelChoice, base: f32, full_scale: f32) -> Option<Self> {
        let level = match choice {
            BlackLevelChoice::Auto => return None,
            BlackLevelChoice::None => base,
            BlackLevelChoice::Given(v) => v * full_scale,
        };
        Some(BlackLevelDecision {
            level,
            measured: None,
            full_scale,
        })
    }

    /// The decision of [`BlackLevelChoice::Auto`] on the level `measured` above `base`
    /// (the [`Options::black_level`] it was measured with): taken off when
    /// [`BlackLevel::is_taken`].
    pub fn from_measured(measured: BlackLevel, base: f32, full_scale: f32) -> Self {
        let taken = measured.is_taken(full_scale);
        BlackLevelDecision {
            level: if taken { base + measured.value } else { base },
            measured: Some(measured),
            full_scale,
        }
    }

    /// The line that says what was found, e.g. "black level: 0.0313 of full scale
    /// (standard error 1.4e-4) measured from the images; taken off".
    pub fn describe(&self) -> String {
        format!("black level: {}", self.summary())
    }

    /// [`Self::describe`] without its "black level: " (a report's row).
    pub fn summary(&self) -> String {
        let fs = self.full_scale;
        match self.measured {
            Some(b) => format!(
                "{:.4} of full scale (standard error {:.1e}) measured from the images; {}",
                b.value / fs,
                b.standard_error / fs,
                if b.is_taken(fs) {
                    "taken off"
                } else {
                    "none taken off"
                }
            ),
            None if self.level > 0.0 => {
                format!("{:.4} of full scale, given; taken off", self.level / fs)
            }
            None => "none taken off (not measured)".to_string(),
        }
    }
}

/// The [`Options::black_level`] to solve with under `choice`, for a stack held whole:
/// [`estimate_black_level`] for [`BlackLevelChoice::Auto`] (on the robust fits,
/// [`Options::for_black_level`]), then [`BlackLevelDecision::from_measured`].
/// `full_scale`: the images' full scale in the stack's units (1 for images as read).
///
/// Errors: [`BlackLevelChoice::check`]'s, and [`estimate_black_level`]'s.
pub fn decide_black_level(
    choice: BlackLevelChoice,
    (stack, mask, lights): (&ImageStack, &Mask, &Lights),
    opts: &Options,
    full_scale: f32,
) -> Result<BlackLevelDecision> {
    choice.check()?;
    let base = opts.black_level;
    if let Some(d) = BlackLevelDecision::without_measuring(choice, base, full_scale) {
        return Ok(d);
    }
    let measure = |level: f32| {
        let o = Options {
            black_level: level,
            ..opts.clone()
        };
        Ok((
            estimate_black_level(stack, mask, lights, &o.for_black_level())?,
            (),
        ))
    };
    Ok(measure_black_level(base, full_scale, measure)?.0)
}

/// The level decided by [`BlackLevelChoice::Auto`] above `base` (the level already
/// taken off; `full_scale` in image units): `measure(level)` measures the level above
/// `level` in one pass over the images ([`estimate_black_level`]'s sums, whole or by
/// bands) and returns what the caller keeps of that pass (the fits, for
/// [`solve_with_black_level`]). A first pass at `base`; when its level is taken off
/// ([`BlackLevelDecision::from_measured`]), the level is measured again on the images
/// with it taken off, and the correction found is added, until a correction does not
/// lower the level by at least [`LEVEL_TOLERANCE`] of full scale (not added) or after
/// [`REFINE_ROUNDS`]. The decision's measurement is then the level found in total above
/// `base`, re-decided by [`BlackLevel::is_taken`] with the standard error of the last
/// pass that measured it. Returns the decision and what the pass at the decided level
/// returned, when one was made there (always when no level is taken).
///
/// Why measure again: the first measurement selects each pixel's lit samples on the
/// images as read, where the shadowed samples read the level itself. A 3% level lies
/// above the shadow threshold (5% of a pixel's brightest sample) wherever the albedo is
/// low, so samples in cast and attached shadow are kept as lit, and they pull the
/// estimate up: 0.0313 of full scale for a true 0.0300 on an 8-bit blob with cast shadows
/// (mean normal error 0.100°, against 0.051° without a level), 0.0310 in 16 bits. Once
/// the level is off, those samples read about 0 and the selection drops them; the second
/// measurement takes the bias off (8-bit: 0.0301, 0.051°; 16-bit: 0.0300, 0.000°; `synth
/// --material lambertian --albedo-texture --black-level 0.03`, 256², then `normals
/// --lambertian`).
///
/// Why only downwards: the bias taken off is upward, and a positive correction says that
/// the images hold light the Lambertian model does not explain, which measuring again
/// would keep taking off as if it were the camera's. On the real photographs of
/// `../shared/data/real` (`run --chrome`), where the first measurement already finds
/// 0.014–0.114 of full scale, every correction was positive and, followed, climbed
/// towards the largest level allowed (cat 0.107 → 0.219, horse 0.114 → 0.247); those
/// runs keep their first measurement. On the renders every correction was negative.
///
/// Errors: those of `measure`.
pub fn measure_black_level<T>(
    base: f32,
    full_scale: f32,
    mut measure: impl FnMut(f32) -> Result<(BlackLevel, T)>,
) -> Result<(BlackLevelDecision, Option<T>)> {
    let (measured, pass) = measure(base)?;
    let first = BlackLevelDecision::from_measured(measured, base, full_scale);
    if first.level == base {
        return Ok((first, Some(pass)));
    }
    drop(pass); // before the refinement's own passes (the fits of a whole stack)
    refine_black_level(first, base, measure)
}

/// The refinement of [`measure_black_level`] after its `first` decision: the rounds of
/// measuring again, with what the pass at the decided level returned.
///
/// Errors: those of `measure`.
fn refine_black_level<T>(
    first: BlackLevelDecision,
    base: f32,
    mut measure: impl FnMut(f32) -> Result<(BlackLevel, T)>,
) -> Result<(BlackLevelDecision, Option<T>)> {
    let (Some(mut found), true) = (first.measured, first.level != base) else {
        return Ok((first, None));
    };
    let fs = first.full_scale;
    let mut level = first.level;
    let mut kept = None;
    for _ in 0..REFINE_ROUNDS {
        let (m, pass) = measure(level)?;
        let next = (level + m.value).clamp(base, base + MAX_BLACK_LEVEL * fs);
        // only downwards (the bias taken off is upward; a correction that is not a
        // number ends it too)
        let moves = m.value <= -LEVEL_TOLERANCE * fs;
        if moves || m.value.abs() < LEVEL_TOLERANCE * fs {
            // the standard error of a level this pass measured (not of one it refused)
            found.standard_error = m.standard_error;
        }
        if !moves || next == level {
            kept = Some(pass);
            break;
        }
        level = next;
    }
    found.value = level - base;
    let mut decision = BlackLevelDecision::from_measured(found, base, fs);
    if decision.level == base {
        // no longer taken off (the last pass's standard error): that pass was at another level
        return Ok((decision, None));
    }
    decision.level = level; // the level measured at, not base + (level − base) rounded
    Ok((decision, kept))
}

/// [`super::solve`] with the black level that `choice` comes to, and the decision, as
/// [`decide_black_level`] then a solve with its level would give them, bit for bit. Where
/// the level is measured on the solve's own fits ([`BlackLevelChoice::Auto`] with options
/// that reject shadows and highlights, the default) and none is taken, those fits are the
/// solve's: one pass over the stack instead of two, so that measuring costs a clean
/// capture nothing (a clean 1024² 8-bit blob, `normals --lambertian` as a whole process:
/// `auto` took 1.0–1.5 s against 0.9–1.1 s for `none` before, docs/benchmarks.md).
///
/// Errors: as [`decide_black_level`] and [`super::solve`].
pub fn solve_with_black_level(
    choice: BlackLevelChoice,
    (stack, mask, lights): (&ImageStack, &Mask, &Lights),
    opts: &Options,
    full_scale: f32,
) -> Result<(Output, BlackLevelDecision)> {
    let with_level = |d: BlackLevelDecision| {
        let o = Options {
            black_level: d.level,
            ..opts.clone()
        };
        Ok((super::solve(stack, mask, lights, &o)?, d))
    };
    if choice != BlackLevelChoice::Auto || !opts.measures_black_level() {
        return with_level(decide_black_level(
            choice,
            (stack, mask, lights),
            opts,
            full_scale,
        )?);
    }
    let eff = check_inputs(stack, mask, lights, opts)?;
    let measure = |level: f32| {
        let o = Options {
            black_level: level,
            ..opts.clone()
        };
        let fits = fit_all(stack, mask, &eff, &o, true);
        let mut sums = BlackLevelSums::with_lights(eff.clone(), &o);
        sums.add_fits(&fits);
        Ok((sums.finish(), fits))
    };
    match measure_black_level(opts.black_level, full_scale, measure)? {
        (decision, Some(fits)) => Ok((output(stack, &fits)?, decision)),
        (decision, None) => with_level(decision),
    }
}

/// Estimate a black level β common to all images (a camera's dark offset: every sample
/// reads β + ρ e max(0, n·l)) from the robust fits of [`super::solve`]. With the samples
/// of pixel p that its fit used, Iₚ = β·1 + Lₚ bₚ; projecting out bₚ (variable
/// projection, P⊥ = I − Lₚ(LₚᵀLₚ)⁻¹Lₚᵀ, u = P⊥1) leaves β = Σₚ⟨Iₚ, uₚ⟩ / Σₚ⟨1, uₚ⟩, with
/// variance σ²/Σₚ⟨1, uₚ⟩ (σ² the pooled residual variance). Pixels need four samples.
/// When the lights lie on a cone about one axis (a ring at one elevation), 1 is in the
/// span of the lights and β cannot be told from the normals' tilt: the standard error is
/// then infinite. The sums are [`BlackLevelSums`]'s, over the whole stack at once.
///
/// Errors: as [`super::solve`].
pub fn estimate_black_level(
    stack: &ImageStack,
    mask: &Mask,
    lights: &Lights,
    opts: &Options,
) -> Result<BlackLevel> {
    check_inputs(stack, mask, lights, opts)?;
    let mut sums = BlackLevelSums::new(lights, opts)?;
    sums.add(stack, mask)?;
    Ok(sums.finish())
}

/// The sums of [`estimate_black_level`] accumulated over row bands of a capture too large
/// to hold whole: β is a ratio of sums over pixels, and each pixel's terms depend on its
/// own samples only, so bands fed in order (top to bottom) give the estimate of the
/// whole stack bit for bit (the pixels are added in the same order).
#[derive(Clone, Debug)]
pub struct BlackLevelSums {
    eff: Vec<[f64; 3]>,
    opts: Options,
    /// [Σ I·u, Σ u, residual sum of squares, degrees of freedom].
    sum: [f64; 4],
    pixels: usize,
}

impl BlackLevelSums {
    /// Empty sums for images under `lights`, fitted with `opts` (its
    /// [`Options::black_level`] already taken off each sample).
    ///
    /// Errors: as [`super::solve`] for the lights and `min_lights`.
    pub fn new(lights: &Lights, opts: &Options) -> Result<Self> {
        let eff = check_lights(lights.directions.len(), lights, opts)?;
        Ok(Self::with_lights(eff, opts))
    }

    /// Empty sums for the effective light vectors `eff` (checked already).
    fn with_lights(eff: Vec<[f64; 3]>, opts: &Options) -> Self {
        BlackLevelSums {
            eff,
            opts: opts.clone(),
            sum: [0.0; 4],
            pixels: 0,
        }
    }

    /// Add the pixels of `band` inside `band_mask` (the mask's rows of the band; it may
    /// hold no pixel).
    ///
    /// Errors: [`Error::LightCount`] for a band of another K than the lights;
    /// [`Error::SizeMismatch`] for a mask of another size than the band.
    pub fn add(&mut self, band: &ImageStack, band_mask: &Mask) -> Result<()> {
        if band.k != self.eff.len() {
            return Err(Error::LightCount {
                what: "light directions".into(),
                expected: band.k,
                found: self.eff.len(),
                fix: "give one light per image, in the order of the images".into(),
            });
        }
        band_mask.check_size(band.width, band.height, "mask")?;
        self.add_fits(&fit_all(band, band_mask, &self.eff, &self.opts, true));
        Ok(())
    }

    /// Add the terms of `fits` (from `fit_all` with the terms, in pixel order).
    fn add_fits(&mut self, fits: &[PixelFit]) {
        for f in fits.iter().filter(|f| f.black[1] > 0.0) {
            (self.sum.iter_mut().zip(f.black)).for_each(|(a, b)| *a += b);
            self.pixels += 1;
        }
    }

    /// The estimate of the pixels added so far.
    pub fn finish(&self) -> BlackLevel {
        let [num, den, ss, dof] = self.sum;
        // a sum of u's under 1e-6 per pixel: 1 is (nearly) in the lights' span
        let identified = den > 1e-6 * self.pixels as f64;
        let value = if identified { num / den } else { 0.0 };
        let variance = if dof > 0.0 { ss / dof } else { f64::INFINITY };
        let se = if identified {
            (variance / den).sqrt()
        } else {
            f64::INFINITY
        };
        BlackLevel {
            value: value as f32,
            standard_error: se as f32,
            pixels: self.pixels,
        }
    }
}

/// A pixel's terms of [`estimate_black_level`] over the samples `sel` with residual sum
/// of squares `ss`: [Σ I·u, Σ u, ss, dof] (u = P⊥1; zeros with fewer than 4 samples).
pub(crate) fn black_terms(
    eff: &[[f64; 3]],
    sel: &[usize],
    value: impl Fn(usize) -> f64,
    ss: f64,
) -> [f64; 4] {
    if sel.len() < 4 {
        return [0.0; 4];
    }
    let Some(c) = least_squares(eff, sel, |_| 1.0) else {
        return [0.0; 4];
    };
    let (mut num, mut den) = (0.0, 0.0);
    for &i in sel {
        let u = 1.0 - dot(eff[i], c);
        num += value(i) * u;
        den += u;
    }
    [num, den, ss, (sel.len() - 3) as f64]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measured(value: f32) -> BlackLevel {
        BlackLevel {
            value,
            standard_error: 1e-5,
            pixels: 100,
        }
    }

    /// The first decision on a level `value` measured above 0 (full scale 1).
    fn first(value: f32) -> BlackLevelDecision {
        BlackLevelDecision::from_measured(measured(value), 0.0, 1.0)
    }

    #[test]
    fn a_level_not_taken_is_not_measured_again() {
        let never = |_: f32| -> Result<(BlackLevel, ())> { panic!("measured again") };
        let (d, kept) = refine_black_level(first(1e-6), 0.0, never).unwrap();
        assert_eq!((d.level, kept), (0.0, None));
    }

    #[test]
    fn the_corrections_are_added_until_one_is_below_the_tolerance() {
        // measured at 0.0313, then 0.0300 (−1.3e-3), then −5e-5: stop at 0.0300, keep
        // that pass (the fits the solve reuses)
        let mut calls = Vec::new();
        let measure = |level: f32| {
            calls.push(level);
            let step = if calls.len() == 1 { -1.3e-3 } else { -5e-5 };
            Ok((measured(step), calls.len()))
        };
        let (d, kept) = refine_black_level(first(0.0313), 0.0, measure).unwrap();
        assert_eq!(kept, Some(2));
        assert_eq!(d.level, 0.0313 - 1.3e-3);
        assert_eq!(calls, vec![0.0313, d.level]);
        assert!(d.measured.unwrap().value == d.level && d.describe().ends_with("taken off"));
    }

    #[test]
    fn a_refinement_that_does_not_settle_stops_after_its_rounds() {
        // every pass finds 1e-3 less: REFINE_ROUNDS passes, none of them at the final level
        let mut n = 0;
        let measure = |_: f32| {
            n += 1;
            Ok((measured(-1e-3), ()))
        };
        let (d, kept) = refine_black_level(first(0.03), 0.0, measure).unwrap();
        assert_eq!((n, kept), (REFINE_ROUNDS, None));
        assert!((d.level - (0.03 - REFINE_ROUNDS as f32 * 1e-3)).abs() < 1e-6);
        // a correction upwards is not followed: the level stays, with its pass
        let up = |_: f32| Ok((measured(1e-3), ()));
        let (d, kept) = refine_black_level(first(0.03), 0.0, up).unwrap();
        assert_eq!((d.level, kept), (0.03, Some(())));
        // a correction that is not a number ends it at the level measured at
        let nan = |_: f32| Ok((measured(f32::NAN), ()));
        let (d, kept) = refine_black_level(first(0.03), 0.0, nan).unwrap();
        assert_eq!((d.level, kept), (0.03, Some(())));
        // and one that would leave the allowed range is clamped to it
        let down = |_: f32| Ok((measured(-1.0), ()));
        let (d, kept) = refine_black_level(first(0.03), 0.0, down).unwrap();
        assert_eq!((d.level, kept), (0.0, None));
    }
}
