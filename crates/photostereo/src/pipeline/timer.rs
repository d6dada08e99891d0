//! The timer that runs the stages of [`super::solve`] (apart from the stages
//! themselves, so that each stage's file can use it without importing the others).

use crate::error::Result;
use crate::progress::Progress;
use std::time::Instant;

/// Runs named stages, reporting `stage(i, n, name, …)` to the progress and timing each.
pub(super) struct Stages<'a> {
    pub list: Vec<(String, f64)>,
    total: usize,
    progress: &'a dyn Progress,
}

impl<'a> Stages<'a> {
    pub fn new(total: usize, progress: &'a dyn Progress) -> Self {
        Stages {
            list: Vec::new(),
            total,
            progress,
        }
    }

    /// The progress the stages report to.
    pub fn progress(&self) -> &'a dyn Progress {
        self.progress
    }

    /// Run stage `name`; its errors are wrapped with "stage 'name' failed".
    pub fn run<T>(&mut self, name: &str, f: impl FnOnce(&dyn Progress) -> Result<T>) -> Result<T> {
        let i = self.list.len() + 1;
        let total = self.total.max(i);
        self.progress.stage(i, total, name, None);
        let t0 = Instant::now();
        let out = f(self.progress).map_err(|e| e.context(format!("stage '{name}' failed")))?;
        let dt = t0.elapsed().as_secs_f64();
        crate::io::memtrace::mark(&format!("stage '{name}'"));
        self.progress.stage(i, total, name, Some(dt));
        self.list.push((name.to_string(), dt));
        Ok(out)
    }
}
