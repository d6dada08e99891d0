//! The spatial stage of a run ([`crate::spatial`], run by
//! [`crate::normals::spatial_stage`]), after the lookup or the Lambertian solve: the
//! noise is measured on the target, each pixel gets the angular standard error of its
//! normal from its own data (`normals_sigma`), and — with
//! [`super::Options::spatial`] — pixels whose data say little take their normal from
//! their neighbours (their confidence is multiplied by the share of their own data,
//! `own_share`). Without it only the standard errors are computed. The band-wise run
//! ([`super::banded`]) composes the same steps band by band and reports them here too.

use super::{Estimate, Figure, Options};
use crate::image::{GrayImage, Mask};
use crate::spatial::{self, NoiseModel};

/// What the stage adds to the normals' estimate.
#[derive(Clone, Debug)]
pub(super) struct SpatialInfo {
    /// Noise measured on the target.
    pub noise: NoiseModel,
    /// Angular standard error of each normal from its own data (degrees).
    pub sigma: GrayImage,
    /// Share of each pixel's own data in its normal (spatial stage on).
    pub own_share: Option<GrayImage>,
    /// Figures of the spatial solve (spatial stage on).
    pub stats: Option<spatial::Stats>,
}

/// The stage's name in the timings.
pub(super) fn name(opts: &Options) -> &'static str {
    if opts.spatial.is_some() {
        "spatial stage"
    } else {
        "normals' standard errors"
    }
}

/// What [`crate::normals::spatial_stage`] gave, as the stage reports it (`None` where
/// it computed nothing: a mixture of two tables).
pub(super) fn info_of(out: &mut crate::normals::Output) -> Option<SpatialInfo> {
    Some(SpatialInfo {
        noise: out.noise?,
        sigma: out.normals_sigma.take()?,
        own_share: out.own_share.take(),
        stats: out.spatial.take(),
    })
}

/// Take the spatial stage's normals into `est` (its confidence, where it has one, is
/// multiplied by each pixel's own share) and return what the stage reports.
pub(super) fn adopt(est: &mut Estimate, noise: NoiseModel, sp: spatial::Output) -> SpatialInfo {
    est.normals = sp.normals;
    est.confidence = est
        .confidence
        .as_ref()
        .map(|c| spatial::confidence_after(c, &sp.own_share));
    SpatialInfo {
        noise,
        sigma: sp.sigma_deg,
        own_share: Some(sp.own_share),
        stats: Some(sp.stats),
    }
}

pub(super) fn own_only(noise: NoiseModel, sigma: GrayImage) -> SpatialInfo {
    SpatialInfo {
        noise,
        sigma,
        own_share: None,
        stats: None,
    }
}

/// The report's and `run.json`'s rows of the stage.
pub(super) fn rows(info: &SpatialInfo, mask: &Mask) -> Vec<Figure> {
    let n = info.noise;
    let mut f = vec![
        Figure::new(
            "noise measured on the target",
            format!(
                "σ = √({:.3e}² + {:.3e}·I), ≥ step {:.3e} / √12",
                n.read, n.gain, n.step
            ),
        ),
        Figure::new(
            "mean angular standard error of the normals, own data (°)",
            format!("{:.2}", spatial::mean_in(&info.sigma, mask)),
        ),
    ];
    let row = match &info.stats {
        Some(s) => format!(
            "{} of {} pixels decided by their neighbours ({:.1}%), {} discontinuity cuts, \
             {} kept their own match (their data reject the neighbours' normal)",
            s.decided_by_neighbours,
            s.pixels,
            100.0 * s.decided_by_neighbours as f64 / s.pixels.max(1) as f64,
            s.cut_triples,
            s.kept_own
        ),
        None => "off (every pixel keeps its own normal)".to_string(),
    };
    f.push(Figure::new("spatial stage", row));
    f
}
