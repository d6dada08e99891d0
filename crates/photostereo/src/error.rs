//! The one error type of the library.
//!
//! Every variant carries the facts a user needs to fix the problem: the file,
//! what was expected and what was found, and (in `fix`) what to do about it, in terms
//! of the data: the library knows no command-line flags or keywords. A setting of the
//! call that is wrong is named by [`Setting`] in [`Error::Setting`], so that each front
//! end (the CLI, the Python module) can add its own name for it.

use std::path::PathBuf;

/// Result alias used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in photostereo. New variants may be added: match with
/// a `_` arm.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file or directory could not be read or written. (`cause` is not the error's
    /// `source()`: the message already holds it, and printing the chain would say it twice.)
    #[error("{path}: {cause}")]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },

    /// A required file or directory does not exist.
    #[error("{path}: not found; {fix}")]
    NotFound { path: PathBuf, fix: String },

    /// A file exists but could not be decoded (not an image, corrupt npy, ...).
    #[error("{path}: cannot decode: {message}")]
    Decode { path: PathBuf, message: String },

    /// A text file (light directions, intensities, file list) has a bad line.
    #[error("{path}, line {line}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },

    /// Two things that must have the same pixel size do not.
    #[error("{what}: size {found_w}x{found_h} differs from the expected {expected_w}x{expected_h}; {fix}")]
    SizeMismatch {
        what: String,
        expected_w: usize,
        expected_h: usize,
        found_w: usize,
        found_h: usize,
        fix: String,
    },

    /// The number of lights (images, directions, intensities, table entries) disagrees.
    #[error("{what}: expected {expected} lights, found {found}; {fix}")]
    LightCount {
        what: String,
        expected: usize,
        found: usize,
        fix: String,
    },

    /// The mask selects no pixel at all.
    #[error("{what}: the mask selects no pixel; {fix}")]
    EmptyMask { what: String, fix: String },

    /// No calibration sphere could be found in the images.
    #[error("no sphere found in {what}: {reason}; {fix}")]
    SphereNotFound {
        what: String,
        reason: String,
        fix: String,
    },

    /// A lookup table does not fit the target it is applied to.
    #[error("lookup table {what} does not match the target: {reason}")]
    TableMismatch { what: String, reason: String },

    /// A setting of the call (not the data) is missing, out of range or in conflict
    /// with another; `setting` says which, for a front end to name its own flag.
    #[error("{what}: {fix}")]
    Setting {
        setting: Setting,
        what: String,
        fix: String,
    },

    /// Any other invalid argument or data, with the fix.
    #[error("{what}: {fix}")]
    InvalidInput { what: String, fix: String },

    /// An error of a step, with what was being done (e.g. a pipeline stage). (`inner`
    /// is not the error's `source()`: the message already holds it, and printing the
    /// chain would say it twice.)
    #[error("{context}: {inner}")]
    Context { context: String, inner: Box<Error> },
}

/// The settings an [`Error::Setting`] is about. New ones may be added: match with a
/// `_` arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Setting {
    /// How the normals are obtained: a calibration sphere of the target's material
    /// (lookup table), or Lambertian photometric stereo; exactly one of them.
    Method,
    /// The data given (light directions, a chrome sphere, an image scale,
    /// interreflection removal) are for Lambertian photometric stereo, which was not
    /// asked for.
    Lambertian,
    /// The file of light directions (K lines `x y z`, one per image in image order).
    LightsFile,
    /// Light directions are needed and the dataset has none (no
    /// `light_directions.txt`): a file of them, or a chrome sphere to calibrate them.
    Lights,
    /// The factor that brings the images to radiance units.
    ImageScale,
    /// The calibration sphere's circle (centre x, y and radius, pixels).
    Circle,
    /// Where the calibration sphere is searched: a region or a mask of the images.
    SphereSearch,
    /// The side (pixels) of the facet blocks of the interreflection model.
    FacetBlock,
    /// The memory budget of a run (bytes; [`crate::plan`]).
    Memory,
    /// The smoothing scale of the curvature maps (pixels; [`crate::curvature`]).
    CurvatureScale,
}

impl Error {
    /// Shorthand for [`Error::Setting`].
    pub fn setting(setting: Setting, what: impl Into<String>, fix: impl Into<String>) -> Self {
        Error::Setting {
            setting,
            what: what.into(),
            fix: fix.into(),
        }
    }

    /// Shorthand for [`Error::InvalidInput`].
    pub fn invalid(what: impl Into<String>, fix: impl Into<String>) -> Self {
        Error::InvalidInput {
            what: what.into(),
            fix: fix.into(),
        }
    }

    /// Wrap the error with what was being done ([`Error::Context`]).
    pub fn context(self, context: impl Into<String>) -> Self {
        Error::Context {
            context: context.into(),
            inner: Box::new(self),
        }
    }

    /// The innermost error below any [`Error::Context`] wrappers (what to classify by).
    pub fn root(&self) -> &Error {
        match self {
            Error::Context { inner, .. } => inner.root(),
            other => other,
        }
    }

    /// Shorthand for [`Error::Io`].
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            cause: source,
        }
    }
}
