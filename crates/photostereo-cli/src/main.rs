//! `photostereo`: photometric stereo from the command line.
//!
//! One file per subcommand; each exposes `Args` (clap) and `run`.

use clap::{Parser, Subcommand};

mod advice;
mod bench;
mod black_level;
mod calibrate;
mod demo;
mod eval;
mod integrate;
mod interreflect;
mod lights;
mod normals;
#[allow(dead_code)] // used by the long-running subcommands as they land
mod progress;
mod run;
mod synth;

/// Recover 3-D shape of shiny objects from images under several lights.
#[derive(Parser, Debug)]
#[command(name = "photostereo", version, about, long_about = None)]
struct Cli {
    /// Print nothing but errors (no progress bars, no tables).
    #[arg(short, long, global = true)]
    quiet: bool,

    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a synthetic dataset with ground truth (DiLiGenT layout).
    Synth(synth::Args),
    /// Compare a normal map (and optionally depth) with ground truth.
    Eval(eval::Args),
    /// Detect the calibration sphere and build a lookup table.
    Calibrate(calibrate::Args),
    /// Estimate light directions from a matte or chrome sphere.
    Lights(lights::Args),
    /// Estimate normals of a target (lookup table or Lambertian).
    Normals(normals::Args),
    /// Integrate a normal map into a depth map (and mesh).
    Integrate(integrate::Args),
    /// Remove interreflections (Nayar–Ikeuchi–Kanade iteration).
    Interreflect(interreflect::Args),
    /// Whole pipeline on a dataset: normals → depth → mesh → report.
    Run(run::Args),
    /// Run the pipeline on built-in synthetic data and print accuracy.
    Demo(demo::Args),
    /// Print speed figures of the main kernels.
    Bench(bench::Args),
}

/// Options shared by every subcommand.
#[derive(Clone, Copy, Debug)]
pub struct Global {
    /// No progress, no tables.
    pub quiet: bool,
}

/// Let a closed stdout end the process the way it ends `cat` or `ls`.
///
/// Rust ignores SIGPIPE, so `println!` to a pipe whose reader has gone (`photostereo
/// calibrate ... | head -1`) panics with "failed printing to stdout". Every output file
/// is written atomically (temporary name, then rename), so dying here leaves none torn.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: `signal` with a valid signal number and `SIG_DFL` only resets that
    // signal's disposition; it runs first thing in `main`, before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn main() {
    restore_default_sigpipe();
    let cli = Cli::parse();
    let global = Global { quiet: cli.quiet };
    let result = match cli.command {
        Command::Synth(a) => synth::run(a, global),
        Command::Eval(a) => eval::run(a, global),
        Command::Calibrate(a) => calibrate::run(a, global),
        Command::Lights(a) => lights::run(a, global),
        Command::Normals(a) => normals::run(a, global),
        Command::Integrate(a) => integrate::run(a, global),
        Command::Interreflect(a) => interreflect::run(a, global),
        Command::Run(a) => run::run(a, global),
        Command::Demo(a) => demo::run(a, global),
        Command::Bench(a) => bench::run(a, global),
    };
    if let Err(err) = result {
        eprintln!("error: {}", error_message(&err));
        if let Some(hint) = advice::advice(&err) {
            eprintln!("hint: {hint}");
        }
        std::process::exit(1);
    }
}

/// The error and its causes joined by ": ", leaving out a cause that the message before it
/// already quotes (library errors often print their source too).
fn error_message(err: &anyhow::Error) -> String {
    let mut parts: Vec<String> = Vec::new();
    for cause in err.chain() {
        let s = cause.to_string();
        if !parts.last().is_some_and(|p| p.contains(&s)) {
            parts.push(s);
        }
    }
    parts.join(": ")
}

/// Refuse an output directory that is an existing file, before any work is done.
/// The value of `--response` (see [`photostereo::io::Response`]).
pub(crate) fn parse_response(s: &str) -> Result<photostereo::io::Response, String> {
    s.parse()
        .map_err(|e: photostereo::error::Error| e.to_string())
}

pub fn check_output_dir(dir: &std::path::Path) -> anyhow::Result<()> {
    if dir.exists() && !dir.is_dir() {
        anyhow::bail!(
            "{}: is a file, not a directory; give -o a directory (it is created) or a path that does not exist yet",
            dir.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    use clap::CommandFactory;

    /// Words of a shell command line (single quotes group; `#` starts a comment).
    fn words(line: &str) -> Vec<String> {
        let line = line.split(" #").next().unwrap_or(line);
        let mut out = Vec::new();
        let (mut cur, mut quoted, mut any) = (String::new(), false, false);
        for ch in line.chars() {
            match ch {
                '\'' => (quoted, any) = (!quoted, true),
                c if c.is_whitespace() && !quoted => {
                    if any {
                        out.push(std::mem::take(&mut cur));
                        any = false;
                    }
                }
                c => (cur, any) = (cur + &c.to_string(), true),
            }
        }
        if any {
            out.push(cur);
        }
        out
    }

    /// Every `photostereo …` line of the README's shell blocks and of every `--help`.
    fn example_lines() -> Vec<String> {
        let readme = include_str!("../../../README.md");
        let mut lines: Vec<String> = readme
            .lines()
            .map(|l| l.trim().replace("cargo run --release -- ", "photostereo "))
            .filter(|l| l.starts_with("photostereo "))
            .collect();
        let mut cli = Cli::command();
        for sub in cli.get_subcommands_mut() {
            let help = sub.render_long_help().to_string();
            lines.extend(
                help.lines()
                    .map(str::trim)
                    .filter(|l| l.starts_with("photostereo "))
                    .map(String::from),
            );
        }
        lines
    }

    /// The examples parse: every flag they use exists and takes what they give it (running
    /// them on data is the job of `tests/first_hour.rs`).
    #[test]
    fn every_example_of_the_readme_and_the_help_parses() {
        let lines = example_lines();
        assert!(lines.len() >= 25, "only {} examples found", lines.len());
        for line in &lines {
            if let Err(e) = Cli::try_parse_from(words(line)) {
                panic!("`{line}` does not parse:\n{e}");
            }
        }
    }

    #[test]
    fn a_cause_quoted_by_its_message_is_not_repeated() {
        let io = std::io::Error::from_raw_os_error(17);
        let err = anyhow::Error::new(io).context("out: File exists (os error 17)");
        assert_eq!(error_message(&err), "out: File exists (os error 17)");
        let err = anyhow::anyhow!("root cause").context("loading x");
        assert_eq!(error_message(&err), "loading x: root cause");
    }
}
