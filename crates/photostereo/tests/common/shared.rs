//! The project's shared data and skips that CI can see; used by every test that reads
//! `../shared` (the CLI crate's `tests/common` includes this file with `#[path]`).
//!
//! * The shared folder is `$PHOTOSTEREO_SHARED`, else `../shared` beside the repository,
//!   located from the crate's manifest directory (in a worktree `../shared` is a link).
//! * Absent folder: the test is skipped — it prints `SKIP <test>: <why>` to stderr and
//!   leaves a marker file (one per skipped test) in `$PHOTOSTEREO_SKIP_DIR`, else in
//!   `<target>/tmp/skipped/`, which `.ci/run` counts. With `PHOTOSTEREO_REQUIRE_SHARED=1`
//!   (set by `.ci/run`) an absent folder is a failure instead.
//! * Folder present but a dataset or file in it missing or unreadable: a failure, never
//!   a skip (the data are broken, not absent).

use std::path::{Path, PathBuf};

/// Root of the shared data: `$PHOTOSTEREO_SHARED`, else `<workspace>/../shared`.
pub fn root() -> PathBuf {
    match std::env::var_os("PHOTOSTEREO_SHARED") {
        Some(p) => PathBuf::from(p),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared"),
    }
}

/// `root()/rel` (e.g. `data/real/chrome`) for the test `test`. `None` (a recorded skip)
/// when the shared folder is absent; panics when it is present but `rel` is not, or when
/// `PHOTOSTEREO_REQUIRE_SHARED=1` and the folder is absent.
pub fn path(test: &str, rel: &str) -> Option<PathBuf> {
    let root = root();
    if !root.is_dir() {
        skip(
            test,
            &format!(
                "shared data folder {} not found (set PHOTOSTEREO_SHARED)",
                root.display()
            ),
            "PHOTOSTEREO_REQUIRE_SHARED",
        );
        return None;
    }
    let p = root.join(rel);
    assert!(
        p.exists(),
        "{test}: the shared data folder {} exists but has no {rel}",
        root.display()
    );
    Some(p)
}

/// Read a file of the shared data as text; a failure (naming the file) when it cannot be read.
pub fn read_text(path: &Path) -> String {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read shared data file {}: {e}", path.display()))
}

/// Skip `test` because of `why`: a `SKIP` line on stderr and a marker file, or a panic
/// when the environment variable `require` is `1`.
pub fn skip(test: &str, why: &str, require: &str) {
    if std::env::var(require).is_ok_and(|v| v == "1") {
        panic!("{test}: {why}, and {require}=1 says this test must not be skipped");
    }
    eprintln!("SKIP {test}: {why}");
    let dir = std::env::var_os("PHOTOSTEREO_SKIP_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_TARGET_TMPDIR")).join("skipped"));
    let name: String = test
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    // Best effort: the marker only feeds the CI summary; the SKIP line is already printed.
    if std::fs::create_dir_all(&dir).is_ok() {
        let _ = std::fs::write(dir.join(name), format!("SKIP {test}: {why}\n"));
    }
}
