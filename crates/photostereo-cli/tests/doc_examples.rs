//! Every command the README shows and every `--help` example runs as shown (issue 15).
//!
//! The commands are extracted, not copied: the README's ```` ```sh ```` blocks, and the
//! `Example:` / `Examples:` section of each subcommand's `--help` (the subcommands are read
//! from `photostereo --help`). Each runs in a sandbox laid out like a fresh clone
//! (`<sandbox>/repo` is the working directory, `<sandbox>/shared` the shared data) where
//! small synthetic data were rendered first at the paths the examples name (`data/vase`,
//! `data/sphere`, `sphere.lut`, `normals.npy`, `SPHERE_DIR`, ...). Each must exit 0 and write
//! what its `-o` / `--mesh` names. `photostereo` and `cargo run --release --` run this
//! build's executable; `scripts/test-all.sh` (the suite that runs this test) and
//! `pip install ./crates/photostereo-py` (run by `scripts/test-all.sh`) are not run here, and
//! a command of any other program fails the test until it is taught here.
//!
//! A command that reads `../shared` or `real/` (the real photographs) is skipped with a
//! printed message when the shared folder is absent (see `shared_data`).

#[path = "../../photostereo/tests/shared_data/mod.rs"]
mod shared_data;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use photostereo::image::ImageStack;
use photostereo::io;

const BIN: &str = env!("CARGO_BIN_EXE_photostereo");

/// Split a shell line into words: '…' and "…" quoting, `#` comments, no expansion.
fn shell_words(line: &str) -> Vec<String> {
    let (mut words, mut cur, mut quote, mut started) = (Vec::new(), String::new(), None, false);
    for ch in line.chars() {
        match (quote, ch) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => cur.push(c),
            (None, '\'' | '"') => {
                quote = Some(ch);
                started = true;
            }
            (None, '#') if !started => break,
            (None, c) if c.is_whitespace() => {
                if started {
                    words.push(std::mem::take(&mut cur));
                    started = false;
                }
            }
            (None, c) => {
                cur.push(c);
                started = true;
            }
        }
    }
    assert!(quote.is_none(), "unclosed quote in `{line}`");
    if started {
        words.push(cur);
    }
    words
}

/// The command lines of the README's ```sh blocks (comments and blank lines dropped).
fn readme_commands() -> Vec<String> {
    let readme = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md");
    let text = std::fs::read_to_string(&readme).expect("read README.md");
    let mut out = Vec::new();
    let mut in_sh = false;
    for line in text.lines() {
        let t = line.trim();
        if let Some(lang) = t.strip_prefix("```") {
            in_sh = !in_sh && matches!(lang, "sh" | "bash" | "shell" | "console");
            continue;
        }
        if in_sh && !shell_words(t).is_empty() {
            out.push(t.trim_start_matches("$ ").to_string());
        }
    }
    out
}

fn help_of(args: &[&str]) -> String {
    let o = Command::new(BIN)
        .args(args)
        .output()
        .expect("run photostereo");
    assert!(o.status.success(), "photostereo {args:?} failed");
    String::from_utf8(o.stdout).expect("help is UTF-8")
}

/// The examples of every subcommand's `--help`, as (subcommand, line).
fn help_commands() -> Vec<(String, String)> {
    let top = help_of(&["--help"]);
    let subs: Vec<String> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|s| s != "help")
        .collect();
    assert!(
        subs.len() >= 9,
        "subcommands of photostereo --help: {subs:?}"
    );
    let mut out = Vec::new();
    for sub in subs {
        let help = help_of(&[&sub, "--help"]);
        let examples: Vec<String> = help
            .lines()
            .skip_while(|l| !matches!(l.trim(), "Example:" | "Examples:"))
            .skip(1)
            .take_while(|l| !l.trim().is_empty())
            .map(|l| l.trim().to_string())
            .collect();
        assert!(
            examples.iter().any(|e| e.starts_with("photostereo ")),
            "`photostereo {sub} --help` has no example"
        );
        out.extend(examples.into_iter().map(|e| (sub.clone(), e)));
    }
    out
}

fn run_ok(dir: &Path, args: &[&str]) {
    let o = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run photostereo");
    assert!(
        o.status.success(),
        "fixture `photostereo {}` failed:\n{}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

fn copy(dir: &Path, from: &str, to: &str) {
    std::fs::copy(dir.join(from), dir.join(to))
        .unwrap_or_else(|e| panic!("copy {from} to {to}: {e}"));
}

/// `data/scene`: a shiny sphere (r 80, centre (110, 120)) and a blob side by side in one
/// 430 × 240 image under 16 lights, for `calibrate --sphere-region 10,20,200,200`.
fn scene(repo: &Path) {
    run_ok(
        repo,
        &[
            "-q",
            "synth",
            "--shape",
            "blob",
            "-k",
            "16",
            "--size",
            "200",
            "--calib-sphere",
            "80",
            "-o",
            "fx/blob",
        ],
    );
    let load = |p: &str| io::load_dataset(&repo.join(p), &Default::default()).unwrap();
    let (blob, sphere) = (load("fx/blob"), load("fx/blob/sphere"));
    let (w, h, k) = (430, 240, blob.stack.k);
    let mut s = ImageStack {
        width: w,
        height: h,
        k,
        data: vec![0.0; w * h * k],
        names: blob.stack.names.clone(),
    };
    // the sphere's 164² image at (28, 38): its centre (82, 82) lands on (110, 120)
    for (src, (x0, y0)) in [(&sphere.stack, (28, 38)), (&blob.stack, (230, 20))] {
        for r in 0..src.height {
            for c in 0..src.width {
                let i = ((y0 + r) * w + x0 + c) * k;
                s.data[i..i + k].copy_from_slice(src.pixel(r, c));
            }
        }
    }
    let lights = blob.lights.expect("synth writes light_directions.txt");
    io::write_dataset(&repo.join("data/scene"), &s, &lights, None, 16).unwrap();
}

/// A sandbox like a fresh clone: `<dir>/repo` with the data the examples name, and
/// `<dir>/shared` (a link to the shared data, when present). Returns `<dir>/repo`.
fn sandbox(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("doc-examples-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    let repo = dir.join("repo");
    std::fs::create_dir_all(repo.join("data")).unwrap();
    let shared = shared_data::root();
    if shared.is_dir() {
        let shared = shared.canonicalize().unwrap();
        std::os::unix::fs::symlink(&shared, dir.join("shared")).unwrap();
        std::os::unix::fs::symlink(shared.join("data/real"), repo.join("real")).unwrap();
    }
    let t0 = Instant::now();
    let synth = |args: &[&str]| {
        let mut a = vec!["-q", "synth", "-k", "16"];
        a.extend_from_slice(args);
        run_ok(&repo, &a);
    };
    // a shiny vase and its sphere (r 100: circle 102, 102, 100 in its 204² images)
    synth(&[
        "--shape",
        "vase",
        "--material",
        "plastic",
        "--size",
        "256",
        "--noise",
        "0.01",
        "--calib-sphere",
        "100",
        "-o",
        "fx/vase",
    ]);
    std::fs::rename(repo.join("fx/vase/sphere"), repo.join("data/sphere")).unwrap();
    for d in ["data/vase", "data/target", "TARGET_DIR"] {
        copy_dir(&repo.join("fx/vase"), &repo.join(d));
    }
    copy_dir(&repo.join("data/sphere"), &repo.join("SPHERE_DIR"));
    // Lambertian (diffuse) and metal (specular) spheres under the same lights
    synth(&[
        "--shape",
        "vase",
        "--material",
        "lambertian",
        "--size",
        "64",
        "--calib-sphere",
        "100",
        "-o",
        "fx/lam",
    ]);
    copy_dir(&repo.join("fx/lam/sphere"), &repo.join("data/matte_ball"));
    synth(&[
        "--shape",
        "sphere",
        "--material",
        "metal",
        "--size",
        "128",
        "-o",
        "data/chrome",
    ]);
    synth(&[
        "--shape",
        "bowl",
        "--material",
        "lambertian",
        "--size",
        "64",
        "--interreflections",
        "-o",
        "data/bowl",
    ]);
    synth(&[
        "--shape",
        "vgroove",
        "--material",
        "lambertian",
        "--size",
        "64",
        "--interreflections",
        "-o",
        "data/vgroove_interreflect",
    ]);
    scene(&repo);
    run_ok(
        &repo,
        &["-q", "calibrate", "data/sphere", "-o", "sphere.lut"],
    );
    run_ok(
        &repo,
        &["-q", "calibrate", "fx/lam/sphere", "-o", "diffuse.lut"],
    );
    run_ok(
        &repo,
        &["-q", "calibrate", "data/chrome", "-o", "specular.lut"],
    );
    run_ok(
        &repo,
        &[
            "-q",
            "run",
            "--sphere",
            "data/sphere",
            "data/target",
            "-o",
            "out",
        ],
    );
    copy(&repo, "data/target/light_directions.txt", "lights.txt");
    for f in ["normal_gt.npy", "depth_gt.npy", "mask.png"] {
        copy(&repo, &format!("data/target/{f}"), &format!("data/{f}"));
    }
    for f in ["normals.npy", "confidence.npy"] {
        copy(&repo, &format!("out/{f}"), f);
    }
    copy(&repo, "data/target/mask.png", "mask.png");
    std::fs::write(repo.join("K.txt"), "600 0 127.5\n0 600 127.5\n0 0 1\n").unwrap();
    eprintln!(
        "sandbox {}: data made in {:.1} s",
        repo.display(),
        t0.elapsed().as_secs_f64()
    );
    repo
}

/// The arguments of `line` for this build's executable, or why it is not run here.
fn photostereo_args(line: &str) -> Result<Vec<String>, String> {
    let w = shell_words(line);
    match w.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
        ["photostereo", ..] => Ok(w[1..].to_vec()),
        ["cargo", "run", "--release", "--", ..] => Ok(w[4..].to_vec()),
        ["scripts/test-all.sh", ..] => Err("the whole suite, which runs this test".into()),
        ["pip", "install", "./crates/photostereo-py", ..] => {
            Err("run by scripts/test-all.sh (it installs the package into a venv)".into())
        }
        _ => panic!("`{line}`: a command this test does not know how to run; teach it here"),
    }
}

/// Run `line` in `repo`: exit 0, and the files named by -o/--output/--out/--mesh exist.
fn run_example(test: &str, repo: &Path, line: &str) {
    let args = match photostereo_args(line) {
        Ok(a) => a,
        Err(why) => {
            eprintln!("not run here: `{line}`: {why}");
            return;
        }
    };
    let needs_shared = args
        .iter()
        .any(|a| a.starts_with("../shared") || a.starts_with("real/"));
    if needs_shared && !repo.join("../shared").exists() {
        let why = format!("`{line}` reads the shared data, which is absent");
        shared_data::skip(
            &format!("{test} {line}"),
            &why,
            "PHOTOSTEREO_REQUIRE_SHARED",
        );
        return;
    }
    let t0 = Instant::now();
    let o = Command::new(BIN)
        .args(&args)
        .current_dir(repo)
        .output()
        .expect("run photostereo");
    assert!(
        o.status.success(),
        "`{line}` failed (exit {:?}):\n{}{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    for pair in args.windows(2) {
        if matches!(pair[0].as_str(), "-o" | "--output" | "--out" | "--mesh") {
            assert!(
                repo.join(&pair[1]).exists(),
                "`{line}` did not write {}",
                pair[1]
            );
        }
    }
    eprintln!("ok {:6.1} s  {line}", t0.elapsed().as_secs_f64());
}

#[test]
fn shell_words_split_like_sh() {
    assert_eq!(
        shell_words("photostereo calibrate d -o s.lut --material 'red plastic'  # note"),
        [
            "photostereo",
            "calibrate",
            "d",
            "-o",
            "s.lut",
            "--material",
            "red plastic"
        ]
    );
    assert!(shell_words("# only a comment").is_empty());
}

#[test]
fn readme_commands_run_as_shown() {
    let lines = readme_commands();
    // measured: 11 command lines (demo, test-all.sh, six of the quick start, three runs)
    assert!(lines.len() >= 10, "README commands: {lines:?}");
    let repo = sandbox("readme");
    for line in &lines {
        run_example("readme_commands_run_as_shown", &repo, line);
    }
}

#[test]
fn help_examples_run_as_shown() {
    let examples = help_commands();
    // measured: 24 examples over 10 subcommands
    assert!(examples.len() >= 20, "help examples: {examples:?}");
    let repo = sandbox("help");
    for (_, line) in &examples {
        run_example("help_examples_run_as_shown", &repo, line);
    }
}
