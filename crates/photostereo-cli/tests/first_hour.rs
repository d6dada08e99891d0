//! A new user's first hour (issue 15): the commands that used to stop with a dead end.
//!
//! Interreflection removal on the default 256² and on 512² images chooses its facet
//! block itself in every entry point (`synth`, `interreflect`, `run`); `bench --only`
//! rejects a row name it does not know and lists the ones it does.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn out_dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("first-hour-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn photostereo(args: &[&str], paths: &[&Path]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_photostereo"));
    cmd.args(args);
    for p in paths {
        cmd.arg(p);
    }
    cmd.output().expect("run photostereo")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `synth --interreflections` (the `synth --help` bowl) at `size`, then `interreflect` on it.
fn bowl_with_interreflections(size: usize) -> PathBuf {
    let dir = out_dir(&format!("bowl{size}"));
    let s = size.to_string();
    let o = photostereo(
        &[
            "-q",
            "synth",
            "--shape",
            "bowl",
            "--material",
            "lambertian",
            "-k",
            "8",
            "--interreflections",
            "--size",
            &s,
            "-o",
        ],
        &[&dir],
    );
    assert!(o.status.success(), "synth at {size}²: {}", text(&o));
    dir
}

#[test]
fn interreflections_choose_their_facet_block_at_256_and_512() {
    let mut data256 = PathBuf::new();
    for (size, block) in [(256, 4), (512, 8)] {
        let data = bowl_with_interreflections(size);
        if size == 256 {
            data256 = data.clone();
        }
        let out = out_dir(&format!("ir{size}"));
        let o = photostereo(
            &["interreflect", "--max-iter", "1", "--azimuths", "16"],
            &[&data, Path::new("-o"), &out],
        );
        let t = text(&o);
        assert!(o.status.success(), "interreflect at {size}²: {t}");
        // The full-image bowl mask: the smallest block with at most 4096 cells.
        let want = format!("facets of {block}×{block} px");
        assert!(t.contains(&want), "{size}²: no '{want}' in:\n{t}");
        assert!(out.join("convergence.png").is_file());
    }
    // `run` goes through the same automatic choice (256², one pass of the pipeline).
    let data = data256;
    let out = out_dir("run256");
    let o = photostereo(
        &["-q", "run", "--lambertian", "--interreflections"],
        &[&data, Path::new("-o"), &out],
    );
    assert!(
        o.status.success(),
        "run --interreflections at 256²: {}",
        text(&o)
    );
    let json = std::fs::read_to_string(out.join("run.json")).unwrap();
    assert!(json.contains("facets of 4×4 px"), "{json}");
}

#[test]
fn bench_only_rejects_unknown_rows_and_help_lists_them() {
    let o = photostereo(&["bench", "--only", "foo"], &[]);
    assert!(!o.status.success(), "bench --only foo must fail");
    let t = text(&o);
    assert!(t.contains("foo") && t.contains("fc-reflect"), "{t}");
    let help = text(&photostereo(&["bench", "--help"], &[]));
    for row in [
        "fft-floor",
        "fc",
        "fc-reflect",
        "dct",
        "path",
        "lsq",
        "lookup",
    ] {
        assert!(help.contains(row), "bench --help lacks {row}:\n{help}");
    }
}
