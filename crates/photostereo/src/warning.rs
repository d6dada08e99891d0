//! Warnings that come with a result: how far not to trust it, and why. Each has a
//! [`WarningCode`] a caller can match on and a message in data terms (what is wrong
//! with the data and what would fix it); front ends add their own advice.

use serde::{Deserialize, Serialize};

/// What a [`Warning`] is about.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WarningCode {
    /// The spatial stage did not run (e.g. a mixture of two tables).
    SpatialStageSkipped,
    /// Most of the mask has a lookup confidence below 0.5: the sphere's intensities do
    /// not cover the target's (another material, other lights or exposures).
    LowConfidence,
    /// Interreflection removal on images whose radiance scale nobody gave.
    ImageScaleUnknown,
    /// A given sphere circle does not follow the sphere's rim.
    GivenCircleOffRim,
    /// The calibration "sphere"'s outline leaves its circle: not a sphere.
    NotASphere,
    /// The chrome sphere's brightest spots are too wide for mirror highlights.
    NotAMirror,
    /// Most pixels took their normal from their neighbours in the spatial stage.
    MostlyFromNeighbours,
    /// Target pixels where the sphere is searched (one folder) were left out of the mask.
    SphereLeftOutOfMask,
    /// Anything not (yet) given its own code.
    Other,
}

/// A warning: its code and its message.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Warning {
    /// What it is about.
    pub code: WarningCode,
    /// What is wrong and what would fix it, in words.
    pub message: String,
}

impl Warning {
    /// A warning of `code` saying `message`.
    pub fn new(code: WarningCode, message: impl Into<String>) -> Self {
        Warning {
            code,
            message: message.into(),
        }
    }
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}
