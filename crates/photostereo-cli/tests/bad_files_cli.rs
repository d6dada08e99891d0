//! Files that lie (issue 14): the eleven broken inputs, each through the executable.
//! Every one must end with a non-zero exit, no panic, a message naming the file and the
//! problem, nothing written, under 10 s and 1 GB of peak memory (the child's own
//! maximum resident set, from `wait4`). A `run` killed at random moments must leave no
//! torn file: every output present reads back whole.
//!
//! Each case prints `case | wall s | peak RSS MB | message` (run with `--nocapture`).

mod common;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_photostereo");
/// Limits of the issue: 10 s and 1 GB per case.
const MAX_SECONDS: f64 = 10.0;
const MAX_RSS_MB: f64 = 1000.0;

/// A fresh, empty directory.
fn tmp(name: &str) -> PathBuf {
    common::scratch("bad-files", name)
}

/// What one run of the executable did.
struct Outcome {
    code: Option<i32>,
    signal: Option<i32>,
    stderr: String,
    seconds: f64,
    peak_rss_mb: f64,
}

/// Run the executable and wait for it with `wait4`, which reports the child's own
/// peak resident set size. `kill_after` sends SIGKILL after that delay.
fn run_measured<S: AsRef<OsStr>>(args: &[S], kill_after: Option<Duration>) -> Outcome {
    let err_file = tempfile_path("stderr");
    let child = Command::new(BIN)
        .args(args)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_file).unwrap())
        .spawn()
        .expect("start photostereo");
    let pid = child.id() as libc::pid_t;
    let t0 = Instant::now();
    if let Some(d) = kill_after {
        std::thread::sleep(d);
        // SAFETY: plain syscall on our own child, not yet reaped.
        unsafe { libc::kill(pid, libc::SIGKILL) };
    }
    let mut status = 0;
    // SAFETY: rusage is plain data, filled by the kernel.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: waits for our own child; the pointers are valid for the call.
        let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
        if r == pid {
            break;
        }
        assert_eq!(
            std::io::Error::last_os_error().kind(),
            std::io::ErrorKind::Interrupted
        );
    }
    let seconds = t0.elapsed().as_secs_f64();
    drop(child); // already reaped
    let stderr = std::fs::read_to_string(&err_file).unwrap_or_default();
    let _ = std::fs::remove_file(&err_file);
    Outcome {
        code: libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status)),
        signal: libc::WIFSIGNALED(status).then(|| libc::WTERMSIG(status)),
        stderr,
        seconds,
        // ru_maxrss is in kilobytes on Linux
        peak_rss_mb: usage.ru_maxrss as f64 / 1024.0,
    }
}

fn tempfile_path(tag: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bad-files");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(format!("{tag}-{}", N.fetch_add(1, Ordering::Relaxed)))
}

/// The case must fail cleanly: exit code 1, no panic, every needle in the message,
/// within the limits, and `out` absent or empty.
fn assert_refused<S: AsRef<OsStr>>(case: &str, args: &[S], needles: &[&str], out: &Path) {
    let o = run_measured(args, None);
    let first = o.stderr.lines().last().unwrap_or("");
    println!(
        "{case:<34} | {:.3} s | {:.1} MB | {first}",
        o.seconds, o.peak_rss_mb
    );
    assert_eq!(o.signal, None, "{case}: killed by signal: {}", o.stderr);
    assert!(
        matches!(o.code, Some(c) if c != 0),
        "{case}: exit {:?}",
        o.code
    );
    assert!(!o.stderr.contains("panicked"), "{case}: {}", o.stderr);
    for n in needles {
        assert!(
            o.stderr.contains(n),
            "{case}: message lacks `{n}`: {}",
            o.stderr
        );
    }
    assert!(o.seconds < MAX_SECONDS, "{case}: {:.1} s", o.seconds);
    assert!(
        o.peak_rss_mb < MAX_RSS_MB,
        "{case}: {:.0} MB",
        o.peak_rss_mb
    );
    let left: Vec<_> = std::fs::read_dir(out)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    assert!(left.is_empty(), "{case}: output left behind: {left:?}");
}

/// A 8-light 40² synthetic plastic dataset with its calibration sphere and a table.
fn fixture() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let root = tmp("fixture");
        let ds = root.join("ds");
        let synth = Command::new(BIN)
            .args([
                "-q",
                "synth",
                "--material",
                "plastic",
                "-k",
                "8",
                "--size",
                "40",
            ])
            .arg("--calib-sphere")
            .arg("20")
            .arg("-o")
            .arg(&ds)
            .status()
            .unwrap();
        assert!(synth.success());
        let cal = Command::new(BIN)
            .args(["-q", "calibrate"])
            .arg(ds.join("sphere"))
            .args(["--material", "plastic", "-o"])
            .arg(root.join("good.lut"))
            .status()
            .unwrap();
        assert!(cal.success());
        root
    })
}

/// A copy of the fixture's dataset (images and text files) in `tmp(name)/ds`.
fn dataset_copy(name: &str) -> (PathBuf, PathBuf) {
    let root = tmp(name);
    let ds = root.join("ds");
    std::fs::create_dir_all(&ds).unwrap();
    for e in std::fs::read_dir(fixture().join("ds")).unwrap().flatten() {
        if e.path().is_file() {
            std::fs::copy(e.path(), ds.join(e.file_name())).unwrap();
        }
    }
    (ds, root.join("out"))
}

fn replace_line(file: &Path, line: usize, text: &str) {
    let old = std::fs::read_to_string(file).unwrap();
    let mut lines: Vec<&str> = old.lines().collect();
    lines[line - 1] = text;
    std::fs::write(file, lines.join("\n") + "\n").unwrap();
}

// ------------------------------------------------------------ the two holes

#[test]
fn npy_claiming_100000x100000x3_with_no_data() {
    let root = tmp("npy-huge");
    let path = root.join("huge.npy");
    let mut header =
        "{'descr': '<f4', 'fortran_order': False, 'shape': (100000, 100000, 3), }".to_string();
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    std::fs::write(&path, bytes).unwrap();
    let out = root.join("out");
    let args = [
        OsStr::new("integrate"),
        path.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ];
    assert_refused(
        "npy header (100000,100000,3), no data",
        &args,
        &["huge.npy", "100000, 100000, 3", "holds 0 bytes"],
        &out,
    );
}

/// `normals --lut TABLE` on the fixture, with the table's bytes changed by `damage`.
fn damaged_table(case: &str, name: &str, damage: impl FnOnce(&mut Vec<u8>), needles: &[&str]) {
    let root = tmp(name);
    let mut bytes = std::fs::read(fixture().join("good.lut")).unwrap();
    damage(&mut bytes);
    let lut = root.join(format!("{name}.lut"));
    std::fs::write(&lut, bytes).unwrap();
    let out = root.join("out");
    let ds = fixture().join("ds");
    let args = [
        OsStr::new("normals"),
        ds.as_os_str(),
        "--lut".as_ref(),
        lut.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ];
    let mut all = vec![lut.file_name().unwrap().to_str().unwrap()];
    all.extend_from_slice(needles);
    assert_refused(case, &args, &all, &out);
}

#[test]
fn table_with_64_bytes_flipped_in_its_middle() {
    damaged_table(
        "table, 64 bytes flipped in the middle",
        "flipped",
        |b| {
            let mid = b.len() / 2;
            b[mid - 32..mid + 32].iter_mut().for_each(|x| *x = !*x);
        },
        &["damaged or not a photostereo table", "checksum"],
    );
}

#[test]
fn truncated_table() {
    damaged_table(
        "table, truncated to half",
        "truncated",
        |b| b.truncate(b.len() / 2),
        &["damaged or not a photostereo table"],
    );
}

#[test]
fn table_of_random_bytes() {
    damaged_table(
        "table of random bytes",
        "random",
        |b| {
            let mut x = 0x9e3779b97f4a7c15u64;
            for v in b.iter_mut() {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                *v = x as u8;
            }
        },
        &["damaged or not a photostereo table"],
    );
}

// ------------------------------------------------------------ handled well before

fn run_lambertian(case: &str, ds: &Path, out: &Path, needles: &[&str]) {
    let args = [
        OsStr::new("run"),
        "--lambertian".as_ref(),
        ds.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ];
    assert_refused(case, &args, needles, out);
}

#[test]
fn png_header_claiming_100000x100000() {
    let (ds, out) = dataset_copy("png-huge");
    let path = ds.join("003.png");
    let mut b = std::fs::read(&path).unwrap();
    assert_eq!(&b[12..16], b"IHDR");
    b[16..20].copy_from_slice(&100_000u32.to_be_bytes());
    b[20..24].copy_from_slice(&100_000u32.to_be_bytes());
    let crc = crc32(&b[12..29]);
    b[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(&path, b).unwrap();
    run_lambertian(
        "PNG header claiming 100000x100000",
        &ds,
        &out,
        &["003.png", "100000x100000"],
    );
}

/// CRC-32 (IEEE) of PNG chunks, bit by bit.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

#[test]
fn zero_light_direction() {
    let (ds, out) = dataset_copy("zero-light");
    replace_line(&ds.join("light_directions.txt"), 3, "0 0 0");
    run_lambertian(
        "zero light direction",
        &ds,
        &out,
        &["light_directions.txt", "line 3", "zero-length"],
    );
}

#[test]
fn negative_light_intensity() {
    let (ds, out) = dataset_copy("negative-intensity");
    replace_line(&ds.join("light_intensities.txt"), 2, "-1 -1 -1");
    run_lambertian(
        "negative light intensity",
        &ds,
        &out,
        &["light_intensities.txt", "line 2", "positive"],
    );
}

#[test]
fn filenames_txt_naming_a_missing_image() {
    let (ds, out) = dataset_copy("missing-image");
    replace_line(&ds.join("filenames.txt"), 4, "missing.png");
    run_lambertian(
        "filenames.txt naming a missing image",
        &ds,
        &out,
        &["missing.png", "not found"],
    );
}

#[test]
fn float_tiff_holding_nan() {
    let (ds, out) = dataset_copy("nan-tiff");
    let names: Vec<String> = (1..=8).map(|i| format!("{i:03}.tif")).collect();
    for (i, name) in names.iter().enumerate() {
        let png = ds.join(format!("{:03}.png", i + 1));
        let img = image::open(&png).unwrap().into_rgb32f();
        let mut img = img;
        if i == 4 {
            img.get_pixel_mut(20, 20).0 = [f32::NAN; 3];
        }
        image::DynamicImage::ImageRgb32F(img)
            .save(ds.join(name))
            .unwrap();
        std::fs::remove_file(png).unwrap();
    }
    std::fs::write(ds.join("filenames.txt"), names.join("\n") + "\n").unwrap();
    run_lambertian("float TIFF holding NaN", &ds, &out, &["005.tif", "NaN"]);
}

#[test]
fn output_path_that_is_an_existing_file() {
    let root = tmp("output-file");
    let out = root.join("existing");
    std::fs::write(&out, "not a directory").unwrap();
    let ds = fixture().join("ds");
    let args = [
        OsStr::new("run"),
        "--lambertian".as_ref(),
        ds.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ];
    let empty = root.join("nothing-here");
    assert_refused(
        "output path is an existing file",
        &args,
        &["existing", "is a file, not a directory"],
        &empty,
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "not a directory");
    let names: Vec<_> = std::fs::read_dir(&root)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(names, ["existing"], "only the file that was there");
    let o = run_measured(&args, None);
    assert!(
        !o.stderr.contains("(os error 17): File exists"),
        "{}",
        o.stderr
    );
}

/// Every file of `out` with a final name reads back whole; returns (files, temporaries).
fn check_outputs(out: &Path) -> (usize, usize) {
    let (mut files, mut temps) = (0, 0);
    for e in std::fs::read_dir(out).into_iter().flatten().flatten() {
        let path = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') && name.contains(".tmp-") {
            temps += 1; // an unfinished write, never under the final name
            continue;
        }
        files += 1;
        let ext = path.extension().and_then(|x| x.to_str()).unwrap_or("");
        let whole = match ext {
            "npy" => {
                photostereo::io::read_normals_npy(&path).is_ok()
                    || photostereo::io::read_gray_npy(&path).is_ok()
                    || photostereo::io::read_mask_npy(&path).is_ok()
            }
            "png" => image::open(&path).is_ok(),
            "json" => {
                let text = std::fs::read_to_string(&path).unwrap_or_default();
                serde_json::from_str::<serde_json::Value>(&text).is_ok()
            }
            "html" => {
                std::fs::read_to_string(&path).is_ok_and(|t| t.trim_end().ends_with("</html>"))
            }
            _ => std::fs::metadata(&path).is_ok_and(|m| m.len() > 0),
        };
        assert!(whole, "torn file {}", path.display());
    }
    (files, temps)
}

#[test]
fn run_killed_at_random_moments_leaves_no_torn_file() {
    let root = tmp("killed");
    let ds = root.join("ds");
    let synth = Command::new(BIN)
        .args([
            "-q",
            "synth",
            "--material",
            "lambertian",
            "-k",
            "12",
            "--size",
            "256",
            "-o",
        ])
        .arg(&ds)
        .status()
        .unwrap();
    assert!(synth.success());
    let run_args = |out: &Path| {
        let mut a: Vec<std::ffi::OsString> = vec!["-q".into(), "run".into(), "--lambertian".into()];
        a.extend([
            ds.clone().into_os_string(),
            "-o".into(),
            out.as_os_str().to_owned(),
        ]);
        a
    };
    let whole = run_measured(&run_args(&root.join("whole")), None);
    assert_eq!(whole.code, Some(0), "{}", whole.stderr);
    let (n_whole, _) = check_outputs(&root.join("whole"));
    println!(
        "uninterrupted run: {:.3} s, {:.1} MB, {n_whole} files",
        whole.seconds, whole.peak_rss_mb
    );
    // 12 kill times spread over the run, each jittered by a xorshift draw
    let mut x = 0x2545_f491_4f6c_dd1du64;
    for i in 0..12 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let frac = (i as f64 + (x % 1000) as f64 / 1000.0) / 12.0;
        let delay = Duration::from_secs_f64(whole.seconds * 1.1 * frac);
        let out = root.join(format!("killed-{i}"));
        let o = run_measured(&run_args(&out), Some(delay));
        let (files, temps) = check_outputs(&out);
        println!(
            "killed after {:.3} s: signal {:?}, exit {:?}, {files} whole files, {temps} unfinished temporaries, {:.1} MB",
            delay.as_secs_f64(),
            o.signal,
            o.code,
            o.peak_rss_mb
        );
        assert!(o.signal == Some(libc::SIGKILL) || o.code == Some(0));
        assert!(o.peak_rss_mb < MAX_RSS_MB);
    }
}
