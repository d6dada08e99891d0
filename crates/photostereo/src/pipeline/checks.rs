//! Warnings about the inputs that no figure downstream would show: a given circle off
//! the sphere's rim, a "sphere" that is not one, and a result that the spatial stage
//! decided for most pixels ([`crate::sphere::checks`] does the sphere's measuring).

use super::{Figure, Job, Normals, Options};
use crate::spatial;
use crate::sphere::{self, checks};
use crate::warning::{Warning, WarningCode};

/// Share of the mask decided by their neighbours above which `warnings` says so.
pub const NEIGHBOURS_WARN: f64 = 0.5;

/// The warnings of the sphere check (lookup jobs that detected the sphere) and of the
/// spatial stage, with the figure row of a given circle's check.
pub(super) fn warnings(
    job: &Job,
    circle: Option<&sphere::Detection>,
    stats: Option<&spatial::Stats>,
    opts: &Options,
) -> (Vec<Warning>, Vec<Figure>) {
    let (mut w, mut rows) = (Vec::new(), Vec::new());
    match (&job.normals, circle) {
        (
            Normals::Lookup {
                sphere,
                sphere_mask,
            },
            Some(det),
        ) => {
            // the mask the sphere was searched in (not the folder's with a search window)
            let mask = opts.detect.search_mask(sphere_mask.clone());
            let mask = mask.as_ref();
            if let Some(given) = &opts.detect.circle {
                let d = sphere::DetectOptions {
                    mask: mask.cloned(),
                    ..opts.detect.clone()
                };
                let check = checks::check_given_circle(sphere, given, &d);
                rows.push(Figure::new("given circle check", check.describe()));
                let code = WarningCode::GivenCircleOffRim;
                w.extend(check.warning().map(|m| Warning::new(code, m)));
            } else {
                // a given circle is checked against the one found instead; no figure row,
                // so that the figures equal those of the same sphere's table made beforehand
                w.extend(not_a_sphere(checks::check_shape(det, mask).warning()));
            }
        }
        // a table made beforehand from a detection: the outline of its lit region
        (Normals::Calibrated(_), Some(det)) if det.fitted_on != "given" => {
            w.extend(not_a_sphere(checks::check_shape(det, None).warning()));
        }
        _ => {}
    }
    if let Some(s) = stats {
        let share = s.decided_by_neighbours as f64 / s.pixels.max(1) as f64;
        if share > NEIGHBOURS_WARN {
            let code = WarningCode::MostlyFromNeighbours;
            w.push(Warning::new(code, format!(
                "most pixels decided by their neighbours: the spatial stage gave {:.0}% of the mask's \
                 normals mostly from their neighbours, because their own images say little about them \
                 (dark, shadowed, noisy, or intensities the table does not hold). There the normals are \
                 a smooth guess, not a measurement: see own_share (0 = decided by the neighbours)",
                100.0 * share
            )));
        }
    }
    (w, rows)
}

/// The shape check's warning, with its code.
fn not_a_sphere(message: Option<String>) -> Option<Warning> {
    message.map(|m| Warning::new(WarningCode::NotASphere, m))
}
