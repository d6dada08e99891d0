//! A reader that goes away (`photostereo ... | head -1`) ends the process quietly, as it
//! ends `cat`: no panic message, no "failed printing to stdout".
#![cfg(unix)]

use std::os::unix::process::ExitStatusExt;
use std::path::PathBuf;
use std::process::{Command, Stdio};

#[test]
fn closed_stdout_ends_without_a_panic() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("closed-pipe");
    let _ = std::fs::remove_dir_all(&dir);
    let mut child = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args(["synth", "--size", "48", "-k", "6", "-o"])
        .arg(&dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start photostereo");
    // Close the read end before the child writes its first line.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait for photostereo");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "stderr: {stderr}");
    assert!(!stderr.contains("failed printing"), "stderr: {stderr}");
    // Either the write raced ahead of the close (exit 0) or SIGPIPE ended it (signal 13).
    let ok = out.status.success() || out.status.signal() == Some(libc::SIGPIPE);
    assert!(ok, "status {:?}, stderr: {stderr}", out.status);
}
