//! Progress reporting without a UI dependency.
//!
//! Long stages take a `&dyn Progress`; the command-line tool passes an `indicatif`
//! bar, tests and library users pass [`NoProgress`].

/// Receives progress of a long computation. Implementations must be cheap and thread-safe.
pub trait Progress: Sync {
    /// Start a new phase of `total` steps, described by `message`.
    fn start(&self, message: &str, total: u64);
    /// `steps` more steps are done.
    fn advance(&self, steps: u64);
    /// The phase is over.
    fn finish(&self) {}
    /// Stage `index` (1-based) of `total` of a pipeline starts (`seconds` = `None`) or
    /// has ended after `seconds` (see [`crate::pipeline`]).
    fn stage(&self, _index: usize, _total: usize, _name: &str, _seconds: Option<f64>) {}
    /// A one-line note for the user as it happens (where the lights came from, a warning,
    /// one row per iteration of a loop).
    fn note(&self, _message: &str) {}
}

/// A [`Progress`] that ignores everything.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _message: &str, _total: u64) {}
    fn advance(&self, _steps: u64) {}
}
