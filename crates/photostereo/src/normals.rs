//! Normals of a target, one entry point: a lookup in calibration tables ([`crate::lut`])
//! or Lambertian least squares ([`crate::lambertian`]), the noise measured on the
//! target ([`spatial::NoiseModel`]), each normal's angular standard error from its own
//! data, and — unless turned off — the spatial stage ([`crate::spatial`]), where pixels
//! whose data say little take their normal from their neighbours.
//!
//! `photostereo normals`, the pipeline ([`crate::pipeline::solve`]) and Python's
//! `Table.lookup` all run [`solve`]. It is [`pixelwise`] followed by [`spatial_stage`];
//! the two are public so that a caller can time them apart (the pipeline does).
//!
//! ```
//! # use photostereo::{lut, normals, synth, sphere::Circle, progress::NoProgress};
//! let opts = synth::SceneOptions { width: 64, height: 64, ..Default::default() };
//! let sphere = synth::render_calibration_sphere(&opts, 24.0)?;
//! let (w, h) = (sphere.stack.width as f64, sphere.stack.height as f64);
//! let circle = Circle { cx: w / 2.0, cy: h / 2.0, radius: 24.0 };
//! let table = lut::Table::build(&sphere.stack, &circle, &lut::BuildOptions::default())?;
//! // prepared once, reused for every target
//! let lookup = lut::Lookup::new(vec![table], &lut::Options::default())?;
//! let scene = synth::render(&opts)?;
//! let input = normals::Input::Lookup(&lookup);
//! let out = normals::solve(&scene.stack, &scene.mask, &input, &Default::default(), &NoProgress)?;
//! assert!(out.normals_sigma.is_some() && out.own_share.is_some());
//! # Ok::<(), photostereo::Error>(())
//! ```

use crate::error::Result;
use crate::image::{GrayImage, ImageStack, Lights, Mask, NormalMap};
use crate::progress::Progress;
use crate::spatial::{self, NoiseModel};
use crate::warning::{Warning, WarningCode};
use crate::{lambertian, lut};

/// Where the normals come from.
#[derive(Clone, Copy)]
pub enum Input<'a> {
    /// A lookup in one table, or two for a mixture of two materials, with these
    /// options: prepared for this call only ([`lut::solve`]).
    Tables(&'a [lut::Table], &'a lut::Options),
    /// A lookup prepared beforehand ([`lut::Lookup`]), for several targets with the
    /// same tables.
    Lookup(&'a lut::Lookup<'a>),
    /// Lambertian least squares with known lights (unit directions, surface → light);
    /// the options' black level is taken off the samples by the solve and by the
    /// spatial stage's noise measurement alike (no copy of the stack is needed).
    Lambertian(&'a Lights, &'a lambertian::Options),
}

impl Input<'_> {
    /// The lookup's tables (`None` for Lambertian).
    fn tables(&self) -> Option<&[lut::Table]> {
        match self {
            Input::Tables(t, _) => Some(t),
            Input::Lookup(l) => Some(l.tables()),
            Input::Lambertian(..) => None,
        }
    }
}

/// Settings of [`solve`] besides the lookup's or the Lambertian solve's own (in
/// [`Input`]).
#[derive(Clone, Debug)]
pub struct Options {
    /// The spatial stage ([`crate::spatial`]); `None` = off: every pixel keeps its own
    /// normal (the standard errors are still computed). It models one material: with
    /// two tables it does not run and no standard errors are computed (a warning says
    /// so). Default on, with `spatial::Options::default()`.
    pub spatial: Option<spatial::Options>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            spatial: Some(spatial::Options::default()),
        }
    }
}

/// The normals and what comes with them; every image has the target's size, zeros
/// outside the mask.
#[derive(Clone, Debug)]
pub struct Output {
    /// Unit normals, [0, 0, 0] outside the mask.
    pub normals: NormalMap,
    /// Albedo: Lambertian, absolute (image units per unit light); lookup with
    /// normalised matching or the diffuse/specular split, relative to the sphere's.
    pub albedo: Option<GrayImage>,
    /// Lookup only: confidence in [0, 1]; after the spatial stage multiplied by
    /// [`Output::own_share`].
    pub confidence: Option<GrayImage>,
    /// RMS residual of each pixel's own fit (intensity units).
    pub residual: GrayImage,
    /// Mixture weights (a, b), one image per table (two tables only).
    pub weights: Option<Vec<GrayImage>>,
    /// Standard error of the mixture weights (two tables only).
    pub weight_sigma: Option<GrayImage>,
    /// Lookup only: its summary figures.
    pub lookup: Option<lut::Stats>,
    /// Lookup only: the options it ran with ([`lut::options_for`]: with
    /// [`lut::Options::split_if_specular`] on a specular table, `split_specular` is set).
    pub lookup_options: Option<lut::Options>,
    /// Noise measured on the target (after [`spatial_stage`]; `None` for a mixture).
    pub noise: Option<NoiseModel>,
    /// Angular standard error (degrees) of each normal from its own data (after
    /// [`spatial_stage`]; `None` for a mixture).
    pub normals_sigma: Option<GrayImage>,
    /// Share in [0, 1] of each pixel's own data in its normal (1 = its own data
    /// decided it, 0 = its neighbours did); with the spatial stage only.
    pub own_share: Option<GrayImage>,
    /// Figures of the spatial stage (when it ran).
    pub spatial: Option<spatial::Stats>,
    /// What limits the result, with a code a caller can match on.
    pub warnings: Vec<Warning>,
}

/// Normals of the `mask` pixels of `stack`: [`pixelwise`], then [`spatial_stage`].
///
/// Errors: those of [`lut::solve`] / [`lut::Lookup::solve`] (tables that do not fit the
/// target, an empty mask, …), [`lambertian::solve`] and [`spatial::solve`].
pub fn solve(
    stack: &ImageStack,
    mask: &Mask,
    input: &Input,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Output> {
    let out = pixelwise(stack, mask, input, progress)?;
    spatial_stage(stack, mask, input, opts, out)
}

/// The [`pixelwise`] output of a Lambertian solve (for callers that ran it themselves,
/// e.g. with [`lambertian::solve_with_black_level`]).
pub fn from_lambertian(out: lambertian::Output) -> Output {
    Output {
        albedo: Some(out.albedo),
        ..bare(out.normals, out.residual)
    }
}

/// Each pixel's own normal: the lookup or the Lambertian solve, nothing of the noise or
/// of the neighbours yet.
pub fn pixelwise(
    stack: &ImageStack,
    mask: &Mask,
    input: &Input,
    progress: &dyn Progress,
) -> Result<Output> {
    let (out, used) = match input {
        Input::Tables(tables, asked) => (
            lut::solve(stack, mask, tables, asked, progress)?,
            lut::options_for(tables, asked),
        ),
        Input::Lookup(l) => (l.solve(stack, mask, progress)?, l.options().clone()),
        Input::Lambertian(lights, o) => {
            return Ok(from_lambertian(lambertian::solve(stack, mask, lights, o)?));
        }
    };
    Ok(Output {
        albedo: out.albedo,
        confidence: Some(out.confidence),
        weights: out.weights,
        weight_sigma: out.weight_sigma,
        lookup: Some(out.stats),
        lookup_options: Some(used),
        ..bare(out.normals, out.residual)
    })
}

/// An output with the normals and residual only.
fn bare(normals: NormalMap, residual: GrayImage) -> Output {
    Output {
        normals,
        albedo: None,
        confidence: None,
        residual,
        weights: None,
        weight_sigma: None,
        lookup: None,
        lookup_options: None,
        noise: None,
        normals_sigma: None,
        own_share: None,
        spatial: None,
        warnings: Vec::new(),
    }
}

/// After [`pixelwise`] (its `out`, with the same `input`): the noise measured on the
/// target, the standard errors and, with [`Options::spatial`], the spatial stage (the
/// normals it gives replace `out`'s and the confidence is multiplied by each pixel's
/// own share).
pub fn spatial_stage(
    stack: &ImageStack,
    mask: &Mask,
    input: &Input,
    opts: &Options,
    mut out: Output,
) -> Result<Output> {
    if let Input::Lambertian(lights, o) = input {
        return after_lambertian(stack, mask, (lights, o.black_level), opts, out);
    }
    match input.tables() {
        Some([table]) => after_lookup(stack, mask, table, opts, out),
        _ => {
            out.warnings.push(Warning::new(
                WarningCode::SpatialStageSkipped,
                "two tables (a mixture of materials): the spatial stage and the standard \
                 errors model one material, so every pixel keeps its own match; look up \
                 with one table for them",
            ));
            Ok(out)
        }
    }
}

/// The stage after a lookup with one `table`.
fn after_lookup(
    stack: &ImageStack,
    mask: &Mask,
    table: &lut::Table,
    opts: &Options,
    mut out: Output,
) -> Result<Output> {
    let (noise, censor) = NoiseModel::estimate_with_censor(stack, mask);
    let albedo = out.albedo.as_ref();
    match &opts.spatial {
        None => {
            // the lookup's own dark level: the evidence is that of its matches
            let level = out
                .lookup_options
                .as_ref()
                .map_or(lut::Options::default().shadow_level, |o| o.shadow_level);
            let model = (&noise, &censor);
            let refl = spatial::info::Reflectance::new(table, &noise);
            let ev =
                spatial::info::from_table(stack, mask, &refl, &out.normals, albedo, model, level);
            out.normals_sigma = Some(ev.sigma_deg(mask));
            out.noise = Some(noise);
        }
        Some(sp_opts) => {
            let lookup = (&out.normals, albedo);
            let sp = spatial::solve_lookup(stack, mask, table, lookup, &noise, sp_opts)?;
            adopt(&mut out, noise, sp);
        }
    }
    Ok(out)
}

/// The stage after a Lambertian solve with `lights` (its albedo in `out`) on the samples
/// less the black level `black` (its [`lambertian::Options::black_level`]). The evidence
/// reads no sample (only the normals, the albedo and the noise); the noise is measured
/// above the black level, as the solve saw the samples.
fn after_lambertian(
    stack: &ImageStack,
    mask: &Mask,
    (lights, black): (&Lights, f32),
    opts: &Options,
    mut out: Output,
) -> Result<Output> {
    let noise = NoiseModel::estimate_above(stack, mask, black);
    let ones;
    let albedo = match &out.albedo {
        Some(a) => a,
        None => {
            ones = GrayImage::from_fn(mask.width, mask.height, |_, _| 1.0);
            &ones
        }
    };
    let ev = spatial::info::from_lambertian(stack, mask, lights, &out.normals, albedo, &noise);
    match &opts.spatial {
        None => {
            out.normals_sigma = Some(ev.sigma_deg(mask));
            out.noise = Some(noise);
        }
        Some(sp_opts) => {
            let sp = spatial::solve(&ev, mask, sp_opts)?;
            adopt(&mut out, noise, sp);
        }
    }
    Ok(out)
}

/// Take the spatial stage's normals into `out` (its confidence, where it has one,
/// multiplied by each pixel's own share).
fn adopt(out: &mut Output, noise: NoiseModel, sp: spatial::Output) {
    out.normals = sp.normals;
    out.confidence = out
        .confidence
        .as_ref()
        .map(|c| spatial::confidence_after(c, &sp.own_share));
    out.noise = Some(noise);
    out.normals_sigma = Some(sp.sigma_deg);
    out.own_share = Some(sp.own_share);
    out.spatial = Some(sp.stats);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;
    use crate::sphere::Circle;
    use crate::synth;

    /// A 64² plastic blob and its sphere's table (radius 24).
    fn scene() -> (synth::Scene, lut::Table) {
        let opts = synth::SceneOptions {
            width: 64,
            height: 64,
            noise_sigma: 0.005,
            ..Default::default()
        };
        let sphere = synth::render_calibration_sphere(&opts, 24.0).unwrap();
        let (w, h) = (sphere.stack.width as f64, sphere.stack.height as f64);
        let circle = Circle {
            cx: w / 2.0,
            cy: h / 2.0,
            radius: 24.0,
        };
        let table = lut::Table::build(&sphere.stack, &circle, &Default::default()).unwrap();
        (synth::render(&opts).unwrap(), table)
    }

    #[test]
    fn a_prepared_lookup_gives_what_the_tables_give() {
        let (s, table) = scene();
        let tables = vec![table];
        let lo = lut::Options::default();
        let opts = Options::default();
        let a = solve(
            &s.stack,
            &s.mask,
            &Input::Tables(&tables, &lo),
            &opts,
            &NoProgress,
        );
        let lookup = lut::Lookup::new(&tables[..], &lo).unwrap();
        let b = solve(
            &s.stack,
            &s.mask,
            &Input::Lookup(&lookup),
            &opts,
            &NoProgress,
        );
        let (a, b) = (a.unwrap(), b.unwrap());
        assert_eq!(a.normals.data, b.normals.data);
        assert_eq!(a.confidence.unwrap().data, b.confidence.unwrap().data);
        assert_eq!(a.normals_sigma.unwrap().data, b.normals_sigma.unwrap().data);
        assert_eq!(a.spatial.unwrap(), b.spatial.unwrap());
        assert!(a.warnings.is_empty());
    }

    #[test]
    fn without_the_spatial_stage_each_pixel_keeps_its_match() {
        let (s, table) = scene();
        let tables = [table];
        let lo = lut::Options::default();
        let input = Input::Tables(&tables, &lo);
        let own = pixelwise(&s.stack, &s.mask, &input, &NoProgress).unwrap();
        let opts = Options { spatial: None };
        let out = spatial_stage(&s.stack, &s.mask, &input, &opts, own.clone()).unwrap();
        assert_eq!(out.normals.data, own.normals.data);
        assert_eq!(out.confidence.unwrap().data, own.confidence.unwrap().data);
        assert!(out.own_share.is_none() && out.spatial.is_none());
        // the standard errors are there, finite and positive on the mask
        let sigma = out.normals_sigma.unwrap();
        let inside = s.mask.data.iter().zip(&sigma.data).filter(|(&m, _)| m);
        assert!(inside.clone().all(|(_, &v)| v.is_finite() && v > 0.0));
        assert!(out.noise.is_some());
    }

    #[test]
    fn a_mixture_skips_the_stage_and_says_so() {
        let (s, table) = scene();
        let tables = [table.clone(), table];
        let lo = lut::Options::default();
        let input = Input::Tables(&tables, &lo);
        let out = solve(&s.stack, &s.mask, &input, &Options::default(), &NoProgress).unwrap();
        assert!(out.weights.is_some() && out.normals_sigma.is_none() && out.noise.is_none());
        assert_eq!(out.warnings.len(), 1);
        assert_eq!(out.warnings[0].code, WarningCode::SpatialStageSkipped);
    }

    #[test]
    fn lambertian_gets_the_stage_too() {
        let opts = synth::SceneOptions {
            width: 48,
            height: 48,
            material: synth::Material::Lambertian { albedo: 0.8 },
            noise_sigma: 0.01,
            ..Default::default()
        };
        let s = synth::render(&opts).unwrap();
        let lo = lambertian::Options::default();
        let input = Input::Lambertian(&s.lights, &lo);
        let out = solve(&s.stack, &s.mask, &input, &Options::default(), &NoProgress).unwrap();
        assert!(out.albedo.is_some() && out.confidence.is_none() && out.lookup.is_none());
        let st = out.spatial.unwrap();
        assert_eq!(st.pixels, s.mask.count());
        assert!(out.own_share.is_some() && out.normals_sigma.is_some());
    }
}
