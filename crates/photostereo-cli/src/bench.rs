//! `photostereo bench`: speed figures of the main kernels, one table row per kernel.
//!
//! Every row is an entry of [`ROWS`]: a name, what it measures, and a function that
//! builds its input (untimed) and returns a closure to time. To add a kernel (lookup,
//! interreflection, ...), add one [`Row`] there.

use crate::Global;
use photostereo::image::pixel_to_xy;
use photostereo::integrate::{fft_floor, integrate_gradients, Method, Options};
use photostereo::{GrayImage, Mask};
use std::time::Instant;

/// Arguments of `photostereo bench`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  photostereo bench --size 2048 --lsq-size 1024 --repeat 3\n  photostereo bench --only fc,dct"
)]
pub struct Args {
    /// Width and height of the grid for the FFT/DCT rows (pixels).
    #[arg(long, default_value_t = 2048)]
    pub size: usize,
    /// Width and height of the image whose disk mask the lsq row integrates (pixels).
    #[arg(long, default_value_t = 1024)]
    pub lsq_size: usize,
    /// Timed runs per row; the table shows the fastest.
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Comma-separated row names to run (default: all).
    #[arg(long, value_delimiter = ',', value_parser = clap::builder::PossibleValuesParser::new(ROW_NAMES))]
    pub only: Vec<String>,
}

/// A prepared, timeable job and the number of pixels it processes.
pub struct Job {
    /// Pixels processed per run (for Mpx/s).
    pub pixels: usize,
    /// The work to time.
    pub run: Box<dyn FnMut() -> anyhow::Result<()>>,
}

/// One row of the table.
pub struct Row {
    /// Short name (also the `--only` key).
    pub name: &'static str,
    /// What is measured.
    pub what: &'static str,
    /// Print the time as a multiple of the `fft-floor` row (same grid size).
    pub vs_floor: bool,
    /// Build the input (not timed) and return the job.
    pub prepare: fn(&Args) -> anyhow::Result<Job>,
}

/// The names of [`ROWS`], in order (the values `--only` accepts).
pub const ROW_NAMES: [&str; 8] = [
    "fft-floor",
    "fc",
    "fc-reflect",
    "dct",
    "path",
    "lsq",
    "lookup",
    "lookup-cold",
];

/// The rows, in print order. The first is the FFT floor the Fourier rows are compared to.
pub const ROWS: &[Row] = &[
    Row {
        name: "fft-floor",
        vs_floor: true,
        what: "one forward + one inverse 2-D real FFT (size²)",
        prepare: |a| {
            let img = sphere_gradients(a.size, a.size).0;
            Ok(Job {
                pixels: img.len(),
                run: Box::new(move || {
                    std::hint::black_box(fft_floor(&img));
                    Ok(())
                }),
            })
        },
    },
    Row {
        name: "fc",
        vs_floor: true,
        what: "Frankot–Chellappa, periodic (size²)",
        prepare: |a| integration_job(a.size, Method::FrankotChellappa { reflect: false }, false),
    },
    Row {
        name: "fc-reflect",
        vs_floor: true,
        what: "Frankot–Chellappa on the mirrored 2×size grid",
        prepare: |a| integration_job(a.size, Method::FrankotChellappa { reflect: true }, false),
    },
    Row {
        name: "dct",
        vs_floor: true,
        what: "DCT Poisson, Neumann (size²)",
        prepare: |a| integration_job(a.size, Method::Dct, false),
    },
    Row {
        name: "path",
        vs_floor: true,
        what: "two-path integration (size²)",
        prepare: |a| integration_job(a.size, Method::Path, false),
    },
    Row {
        name: "lsq",
        vs_floor: false,
        what: "masked lsq (multigrid CG), disk in lsq-size²",
        prepare: |a| integration_job(a.lsq_size, Method::Lsq, true),
    },
    Row {
        name: "lookup",
        vs_floor: false,
        what: "lookup-table normals, 1024² shiny vase (mask px), K=16, table r=150, prepared lut::Lookup",
        prepare: |_| lookup_job(true),
    },
    Row {
        name: "lookup-cold",
        vs_floor: false,
        what: "the same, one lut::solve call (index, rim model, radii built inside the timing)",
        prepare: |_| lookup_job(false),
    },
];

/// A rendered 1024² shiny-plastic vase under 16 lights and the table of a rendered
/// radius-150 sphere of the same material. `prepared`: the table's [`photostereo::lut::Lookup`]
/// (search index, isolation radii, rim model) is built before the timing, as a KD-tree
/// library's tree is built before its queries are timed; otherwise each run is one
/// [`photostereo::lut::solve`] call that builds them.
fn lookup_job(prepared: bool) -> anyhow::Result<Job> {
    use photostereo::lut;
    use photostereo::sphere::Circle;
    use photostereo::synth::{self, SceneOptions, Shape, ShapeKind};
    let opts = SceneOptions {
        width: 1024,
        height: 1024,
        shape: Shape::preset(ShapeKind::Vase, 1024, 1024),
        lights: synth::default_lights(16),
        ..SceneOptions::default()
    };
    let scene = synth::render(&opts)?;
    let radius = 150.0;
    let sphere = synth::render_calibration_sphere(&opts, radius)?;
    let circle = Circle {
        cx: sphere.stack.width as f64 / 2.0,
        cy: sphere.stack.height as f64 / 2.0,
        radius,
    };
    let tables = vec![lut::Table::build(
        &sphere.stack,
        &circle,
        &lut::BuildOptions::default(),
    )?];
    let progress = photostereo::progress::NoProgress;
    let opts = lut::Options::default();
    let pixels = scene.mask.count();
    let run: Box<dyn FnMut() -> anyhow::Result<()>> = if prepared {
        let lookup = lut::Lookup::new(tables, &opts)?;
        Box::new(move || {
            let out = lookup.solve(&scene.stack, &scene.mask, &progress)?;
            std::hint::black_box(out);
            Ok(())
        })
    } else {
        Box::new(move || {
            let out = lut::solve(&scene.stack, &scene.mask, &tables, &opts, &progress)?;
            std::hint::black_box(out);
            Ok(())
        })
    };
    Ok(Job { pixels, run })
}

/// Gradients of a sphere cap covering the grid (radius 0.8 × width).
fn sphere_gradients(w: usize, h: usize) -> (GrayImage, GrayImage) {
    photostereo::synth::sphere_cap_gradients(w, h, 0.8 * w as f64)
}

fn integration_job(size: usize, method: Method, disk: bool) -> anyhow::Result<Job> {
    let (p, q) = sphere_gradients(size, size);
    let mask = if disk {
        let rad = 0.48 * size as f64;
        Mask::from_fn(size, size, |r, c| {
            let (x, y) = pixel_to_xy(r, c, size, size);
            x * x + y * y < rad * rad
        })
    } else {
        Mask::full(size, size)
    };
    let opts = Options {
        method,
        ..Options::default()
    };
    Ok(Job {
        pixels: mask.count(),
        run: Box::new(move || {
            std::hint::black_box(integrate_gradients(&p, &q, &mask, &opts)?);
            Ok(())
        }),
    })
}

/// CPU time (user + system, all threads) of this process in seconds, from
/// `/proc/self/stat` (Linux; 10 ms resolution). `None` elsewhere.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Run the subcommand.
pub fn run(args: Args, _global: Global) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.size >= 2 && args.lsq_size >= 2,
        "--size and --lsq-size must be at least 2"
    );
    let repeat = args.repeat.max(1);
    println!(
        "{:<12} {:>11} {:>10} {:>10} {:>9} {:>8}  what",
        "row", "pixels", "best s", "cpu s/run", "Mpx/s", "x floor"
    );
    let mut floor: Option<f64> = None;
    for row in ROWS {
        if !args.only.is_empty() && !args.only.iter().any(|o| o == row.name) {
            continue;
        }
        let mut job = (row.prepare)(&args)?;
        (job.run)()?; // warm-up (plans, page faults)
        let mut best = f64::INFINITY;
        let cpu0 = cpu_seconds();
        for _ in 0..repeat {
            let t = Instant::now();
            (job.run)()?;
            best = best.min(t.elapsed().as_secs_f64());
        }
        let cpu = match (cpu0, cpu_seconds()) {
            (Some(a), Some(b)) => format!("{:.3}", (b - a) / repeat as f64),
            _ => "-".into(),
        };
        if row.name == "fft-floor" {
            floor = Some(best);
        }
        let ratio = match (floor, row.vs_floor) {
            (Some(f), true) => format!("{:.2}", best / f),
            _ => "-".into(),
        };
        println!(
            "{:<12} {:>11} {:>10.4} {:>10} {:>9.1} {:>8}  {}",
            row.name,
            job.pixels,
            best,
            cpu,
            job.pixels as f64 / best / 1e6,
            ratio,
            row.what
        );
    }
    println!(
        "threads: {}; best s = fastest wall time of {repeat} runs, cpu s/run = CPU time of all threads (a bound on the wall time of an idle machine)",
        rayon::current_num_threads()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    #[test]
    fn row_names_match_the_rows() {
        let names: Vec<&str> = ROWS.iter().map(|r| r.name).collect();
        assert_eq!(names, ROW_NAMES);
    }

    #[test]
    fn only_rejects_an_unknown_row_and_lists_the_names() {
        let err = Cli::try_parse_from(["bench", "--only", "fc,foo"])
            .err()
            .expect("unknown row must be an error")
            .to_string();
        assert!(err.contains("foo"), "{err}");
        for name in ROW_NAMES {
            assert!(err.contains(name), "{name} missing from: {err}");
        }
        let ok = Cli::try_parse_from(["bench", "--only", "fc,dct"]).unwrap();
        assert_eq!(ok.args.only, ["fc", "dct"]);
    }
}
