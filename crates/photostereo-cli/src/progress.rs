//! An `indicatif` implementation of the library's `Progress` trait.
//!
//! On a terminal: a progress bar on stderr, notes printed above it. When stderr is not a
//! terminal (a log file, a pipe, CI), bars would print nothing, so each phase logs plain
//! lines instead: its start, about every tenth of its steps (every step for short loops
//! such as iterations) at most once a second, and its end with the elapsed time.

use indicatif::{ProgressBar, ProgressStyle};
use photostereo::progress::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Instant;

/// A phase being logged as lines.
struct Phase {
    message: String,
    total: u64,
    done: u64,
    started: Instant,
    last_line: Instant,
    last_logged: u64,
}

/// A progress bar on stderr (log lines when stderr is not a terminal), silent when `quiet`.
pub struct Bar {
    bar: Mutex<Option<ProgressBar>>,
    phase: Mutex<Option<Phase>>,
    quiet: bool,
    lines: bool,
}

impl Bar {
    /// A bar that draws unless `quiet`; log lines instead when stderr is not a terminal.
    pub fn new(quiet: bool) -> Self {
        Bar {
            bar: Mutex::new(None),
            phase: Mutex::new(None),
            quiet,
            lines: !std::io::stderr().is_terminal(),
        }
    }
}

/// Whether a phase at `done` of `total` steps deserves a log line after `last` was logged.
fn worth_a_line(done: u64, total: u64, last: u64, since_last_s: f64) -> bool {
    if done >= total {
        return false; // the end line says it
    }
    if total <= 20 {
        return done > last;
    }
    let tenth = total.div_ceil(10);
    done / tenth > last / tenth && since_last_s >= 1.0
}

/// Seconds left at `done` of `total` steps after `spent` seconds, at the pace so far.
fn time_left(spent: f64, done: u64, total: u64) -> f64 {
    if done == 0 {
        return f64::NAN;
    }
    spent * total.saturating_sub(done) as f64 / done as f64
}

impl Progress for Bar {
    fn start(&self, message: &str, total: u64) {
        if self.quiet {
            return;
        }
        if self.lines {
            eprintln!("{message}: started ({total} steps)");
            let now = Instant::now();
            if let Ok(mut slot) = self.phase.lock() {
                *slot = Some(Phase {
                    message: message.to_string(),
                    total,
                    done: 0,
                    started: now,
                    last_line: now,
                    last_logged: 0,
                });
            }
            return;
        }
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(
                "{msg:>24} [{bar:30}] {pos}/{len} {elapsed_precise} ({eta} left)",
            )
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
        if self.lines {
            if let Ok(mut slot) = self.phase.lock() {
                if let Some(p) = slot.as_mut() {
                    p.done += steps;
                    let since = p.last_line.elapsed().as_secs_f64();
                    if worth_a_line(p.done, p.total, p.last_logged, since) {
                        let spent = p.started.elapsed().as_secs_f64();
                        eprintln!(
                            "{}: {}/{} ({spent:.1} s, about {:.0} s left)",
                            p.message,
                            p.done,
                            p.total,
                            time_left(spent, p.done, p.total)
                        );
                        p.last_logged = p.done;
                        p.last_line = Instant::now();
                    }
                }
            }
            return;
        }
        if let Ok(slot) = self.bar.lock() {
            if let Some(bar) = slot.as_ref() {
                bar.inc(steps);
            }
        }
    }

    fn finish(&self) {
        if let Ok(mut slot) = self.phase.lock() {
            if let Some(p) = slot.take() {
                eprintln!(
                    "{}: done ({:.1} s)",
                    p.message,
                    p.started.elapsed().as_secs_f64()
                );
            }
        }
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

    fn note(&self, line: &str) {
        if self.quiet {
            return;
        }
        match self.bar.lock().ok().as_ref().and_then(|s| s.as_ref()) {
            Some(bar) => bar.println(line),
            None => eprintln!("{line}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{time_left, worth_a_line};

    #[test]
    fn time_left_is_the_pace_so_far() {
        // 3 of 12 bands in 30 s: 90 s left
        assert_eq!(time_left(30.0, 3, 12), 90.0);
        assert_eq!(time_left(30.0, 12, 12), 0.0);
        assert!(time_left(5.0, 0, 12).is_nan());
    }

    #[test]
    fn short_loops_log_every_step_long_ones_every_tenth() {
        // 10 iterations: every step but the last (the end line covers it).
        let logged: Vec<u64> = (1..=10)
            .filter(|&d| worth_a_line(d, 10, d - 1, 0.0))
            .collect();
        assert_eq!(logged, (1..10).collect::<Vec<_>>());
        // 4096 kernel rows, steps of one, a second apart: one line per tenth (410 rows).
        let mut last = 0;
        let mut lines = 0;
        for d in 1..=4096 {
            if worth_a_line(d, 4096, last, 2.0) {
                lines += 1;
                last = d;
            }
        }
        assert_eq!(lines, 9);
        // Faster than a line a second: nothing.
        assert!(!worth_a_line(500, 4096, 0, 0.2));
    }
}
