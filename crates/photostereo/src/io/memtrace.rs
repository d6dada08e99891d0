//! Where a run's memory goes: with the environment variable `PHOTOSTEREO_MEMORY_TRACE`
//! set, [`mark`] writes to stderr the peak resident memory since the previous mark and
//! the resident memory now (Linux `/proc/self/status`, `VmHWM` and `VmRSS`), then resets
//! the peak (`/proc/self/clear_refs`), so that each line is the peak of the code between
//! two marks. For measuring (docs/benchmarks.md, "Big captures"); off by default, and a
//! no-op where `/proc` is not there. The reset also resets what `/usr/bin/time -v`
//! reports as the maximum resident set size: measure the run's peak without the trace.

use std::fs;
use std::sync::OnceLock;

fn enabled() -> bool {
    static ON: OnceLock<bool> = OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("PHOTOSTEREO_MEMORY_TRACE").is_some())
}

/// `VmHWM` and `VmRSS` of this process, MiB.
fn status() -> Option<(u64, u64)> {
    let text = fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.starts_with(name))?;
        line.split_whitespace().nth(1)?.parse::<u64>().ok()
    };
    Some((field("VmHWM:")? / 1024, field("VmRSS:")? / 1024))
}

/// Trace line `label` (see the module docs).
pub fn mark(label: &str) {
    if !enabled() {
        return;
    }
    if let Some((peak, now)) = status() {
        eprintln!("memory trace: {label}: peak {peak} MiB since the last mark, now {now} MiB");
        // "5" resets the peak to the current resident memory (Linux ≥ 4.0)
        let _ = fs::write("/proc/self/clear_refs", "5");
    }
}
