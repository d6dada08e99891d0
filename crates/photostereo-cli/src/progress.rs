//! An `indicatif` implementation of the library's `Progress` trait.

use indicatif::{ProgressBar, ProgressStyle};
use photostereo::progress::Progress;
use std::sync::Mutex;

/// A progress bar on stderr, silent when `quiet`.
pub struct Bar {
    bar: Mutex<Option<ProgressBar>>,
    quiet: bool,
}

impl Bar {
    /// A bar that draws unless `quiet`.
    pub fn new(quiet: bool) -> Self {
        Bar {
            bar: Mutex::new(None),
            quiet,
        }
    }
}

impl Progress for Bar {
    fn start(&self, message: &str, total: u64) {
        if self.quiet {
            return;
        }
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("{msg:>24} [{bar:30}] {pos}/{len} {elapsed_precise}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        if let Ok(mut slot) = self.bar.lock() {
            if let Some(old) = slot.replace(bar) {
                old.finish_and_clear();
            }
        }
    }

    fn advance(&self, steps: u64) {
        if let Ok(slot) = self.bar.lock() {
            if let Some(bar) = slot.as_ref() {
                bar.inc(steps);
            }
        }
    }

    fn finish(&self) {
        if let Ok(mut slot) = self.bar.lock() {
            if let Some(bar) = slot.take() {
                bar.finish_and_clear();
            }
        }
    }

    /// `[i/n] stage ...` when it starts, `[i/n] stage: 1.23 s` when it ends.
    fn stage(&self, index: usize, total: usize, name: &str, seconds: Option<f64>) {
        if self.quiet {
            return;
        }
        match seconds {
            None => eprintln!("[{index}/{total}] {name} ..."),
            Some(dt) => eprintln!("[{index}/{total}] {name}: {dt:.2} s"),
        }
    }

    fn note(&self, message: &str) {
        if !self.quiet {
            eprintln!("{message}");
        }
    }
}
