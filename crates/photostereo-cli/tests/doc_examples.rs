//! Every command the README shows and every `--help` example runs as shown (issues 15, 29).
//!
//! The commands are extracted, not copied: the README's ```` ```sh ```` blocks, and the
//! `Example:` / `Examples…:` section of each subcommand's `--help` (the subcommands are read
//! from `photostereo --help`). The `--help` examples run **in sequence from an empty folder**
//! (subcommands in the order of [`CHAIN`]): each uses only what an earlier example wrote, as
//! a new user typing them one after the other would. The README's commands run in a sandbox
//! laid out like a fresh clone (`<sandbox>/repo` is the working directory, `<sandbox>/shared`
//! the shared data) where the folders its "your own data" lines name (`SPHERE_DIR`,
//! `TARGET_DIR`) were rendered first. Each must exit 0 and write what its `-o` / `--mesh`
//! names. `photostereo` and `cargo run --release --` run this build's executable;
//! `scripts/test-all.sh` (the suite that runs this test) and `pip install
//! ./crates/photostereo-py` (run by `scripts/test-all.sh`) are not run here, and a command
//! of any other program fails the test until it is taught here.
//!
//! A command that reads `../shared` or `real/` (the real photographs) is skipped with a
//! printed message when the shared folder is absent (see `common::shared`).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

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
            .skip_while(|l| !(l.trim().starts_with("Example") && l.trim().ends_with(':')))
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

/// An empty working folder `<dir>/repo` as a new user has it, beside `<dir>/shared` (a
/// link to the shared data, when present). Returns `<dir>/repo`.
fn sandbox(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("doc-examples-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    let repo = dir.join("repo");
    std::fs::create_dir_all(&repo).unwrap();
    let shared = common::shared::root();
    if shared.is_dir() {
        let shared = shared.canonicalize().unwrap();
        std::os::unix::fs::symlink(&shared, dir.join("shared")).unwrap();
        std::os::unix::fs::symlink(shared.join("data/real"), repo.join("real")).unwrap();
    }
    repo
}

/// The folders the README's "your own data" lines name: a shiny vase (`TARGET_DIR`) and
/// its sphere (`SPHERE_DIR`, r 100), with the dataset's own lights.
fn readme_fixtures(repo: &Path) {
    let t0 = Instant::now();
    run_ok(
        repo,
        &[
            "-q",
            "synth",
            "--shape",
            "vase",
            "--material",
            "plastic",
            "--size",
            "128",
            "--calib-sphere",
            "60",
            "-o",
            "TARGET_DIR",
        ],
    );
    std::fs::rename(repo.join("TARGET_DIR/sphere"), repo.join("SPHERE_DIR")).unwrap();
    eprintln!(
        "sandbox {}: data made in {:.1} s",
        repo.display(),
        t0.elapsed().as_secs_f64()
    );
}

/// The order in which the subcommands' `--help` examples run: each uses only what the
/// examples before it wrote (synth makes the data, calibrate the tables, ...).
const CHAIN: [&str; 10] = [
    "synth",
    "calibrate",
    "lights",
    "normals",
    "integrate",
    "eval",
    "interreflect",
    "run",
    "demo",
    "bench",
];

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
        common::shared::skip(
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
    readme_fixtures(&repo);
    for line in &lines {
        run_example("readme_commands_run_as_shown", &repo, line);
    }
}

#[test]
fn help_examples_run_in_sequence_from_an_empty_folder() {
    let examples = help_commands();
    // measured: 31 examples over 10 subcommands
    assert!(examples.len() >= 25, "help examples: {examples:?}");
    for (sub, _) in &examples {
        assert!(
            CHAIN.contains(&sub.as_str()),
            "`{sub}` is not in CHAIN: place it"
        );
    }
    let repo = sandbox("help");
    for sub in CHAIN {
        for (_, line) in examples.iter().filter(|(s, _)| s == sub) {
            run_example(
                "help_examples_run_in_sequence_from_an_empty_folder",
                &repo,
                line,
            );
        }
    }
}
