//! The whole job from paths (`photostereo run`): by row bands ([`super::banded`]) when
//! the images allow it, else loaded whole ([`super::load`]), then [`super::solve`] and
//! [`super::write_outputs_with`]. Kept apart from both loaders so that neither imports
//! the other's caller.

use std::path::Path;

use super::load::{Inputs, Run};
use super::{Figure, Options};
use crate::error::Result;
use crate::io;
use crate::progress::Progress;

/// The whole job: [`load`](fn@super::load), [`super::solve`], [`super::write_outputs`] into `out`.
///
/// Without interreflection removal (a global iteration on the whole stack) the target's
/// images are read by row bands within the memory budget [`Options::memory`]
/// ([`crate::plan`]); the results are those of [`load`](fn@super::load) and [`super::solve`]. Bracketed
/// exposures and non-linear images are loaded whole (no memory plan).
pub fn run(inputs: &Inputs, out: &Path, opts: &Options, progress: &dyn Progress) -> Result<Run> {
    // bracketed exposures and non-linear (JPEG) images are merged / linearised by the
    // whole-stack loader only
    if !opts.interreflections && io::readable_by_bands(&inputs.target, inputs.response) {
        return super::banded::run(inputs, out, opts, progress);
    }
    let loaded = super::load::load(inputs, opts, progress)?;
    let mut opts = opts.clone();
    opts.nik.scale_known |= loaded.scale_known;
    // a black level given as a fraction of full scale is of the images before the scale
    let full_scale = loaded.image_scale.map_or(1.0, |(s, _)| s);
    let mut output = super::solve_scaled(&loaded.job, &opts, full_scale, progress)?;
    if let Some((scale, from)) = loaded.image_scale {
        output.figures.push(Figure::new(
            "image scale (images ×)",
            format!("{scale} ({from})"),
        ));
    }
    // run.json's figures record how the images were linearised
    output
        .figures
        .push(Figure::new("image response", loaded.response.to_string()));
    output.chrome = loaded.chrome.clone();
    for w in &loaded.warnings {
        progress.note(&format!("warning: {w}"));
    }
    output.warnings.extend(loaded.warnings.iter().cloned());
    let written = super::write_outputs_with(
        out,
        &loaded.titles,
        &loaded.job,
        &output,
        &loaded.stages,
        &opts.exports,
    )?;
    Ok(Run {
        output,
        report: written.report,
        summary: written.summary,
    })
}
