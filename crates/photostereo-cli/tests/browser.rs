//! End-to-end: open generated reports in headless Chromium, wait for the 3-D view, take a
//! screenshot and check that the surface was drawn and that no script reported an error.
//!
//! Needs `chromium` (Debian package; `.ci/run` installs it) or a browser named by
//! `PHOTOSTEREO_CHROMIUM`. Where none is found the tests are skipped (a `SKIP` line and a
//! marker that `.ci/run` counts, see `common::shared`), or fail under
//! `PHOTOSTEREO_REQUIRE_BROWSER=1`.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use photostereo::image::{gradient_to_normal, pixel_to_xy, Image, ImageStack, Lights, Mask};
use photostereo::report::{raster::ColorMap, Report};

const WINDOW: (u32, u32) = (1280, 900);
/// Background of the 3-D view (#1b1e24 in the page's style and the viewer's scene).
const VIEW_BG: [u8; 3] = [0x1b, 0x1e, 0x24];

/// The browser for `test`, or `None`: a skip (see `common::shared`), or a failure under
/// `PHOTOSTEREO_REQUIRE_BROWSER=1` (set by `.ci/run`).
fn browser(test: &str) -> Option<PathBuf> {
    let found = chromium();
    if found.is_none() {
        common::shared::skip(
            test,
            "no chromium found (apt-get install chromium, or set PHOTOSTEREO_CHROMIUM)",
            "PHOTOSTEREO_REQUIRE_BROWSER",
        );
    }
    found
}

fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("PHOTOSTEREO_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    [
        "chromium",
        "chromium-browser",
        "google-chrome",
        "google-chrome-stable",
    ]
    .iter()
    .flat_map(|name| std::env::split_paths(&path).map(move |d| d.join(name)))
    .find(|p| p.is_file())
}

/// Run the browser on `page` with `extra` flags; returns (stdout, stderr). Killed after 90 s.
fn run_browser(browser: &Path, page: &Path, extra: &[String], profile: &Path) -> (String, String) {
    let mut cmd = Command::new(browser);
    cmd.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--no-first-run",
        "--no-default-browser-check",
        "--disable-extensions",
        "--hide-scrollbars",
        "--mute-audio",
        "--enable-logging=stderr",
        "--v=0",
        "--virtual-time-budget=20000",
    ])
    .arg(format!("--window-size={},{}", WINDOW.0, WINDOW.1))
    .arg(format!("--user-data-dir={}", profile.display()))
    .args(extra)
    .arg(format!("file://{}", page.display()))
    .stdin(Stdio::null());
    let out_path = profile.with_extension("stdout");
    let err_path = profile.with_extension("stderr");
    cmd.stdout(std::fs::File::create(&out_path).expect("stdout file"));
    cmd.stderr(std::fs::File::create(&err_path).expect("stderr file"));
    let mut child = cmd.spawn().expect("start the browser");
    let t0 = Instant::now();
    while child.try_wait().expect("wait for the browser").is_none() {
        if t0.elapsed() > Duration::from_secs(90) {
            let _ = child.kill();
            panic!(
                "the browser did not finish within 90 s on {}",
                page.display()
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
    (read(&out_path), read(&err_path))
}

/// What the page and its screenshot say.
struct Seen {
    viewer: String,
    errors: usize,
    dom: String,
    log_errors: Vec<String>,
    shot: image::RgbImage,
}

fn attr(dom: &str, name: &str) -> Option<String> {
    let key = format!("{name}=\"");
    let start = dom.find(&key)? + key.len();
    let end = dom[start..].find('"')? + start;
    Some(dom[start..end].to_string())
}

fn open(browser: &Path, page: &Path, tag: &str) -> Seen {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("browser-{tag}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (dom, log1) = run_browser(
        browser,
        page,
        &["--dump-dom".into()],
        &dir.join("profile-dom"),
    );
    let shot_path = dir.join("screenshot.png");
    let (_, log2) = run_browser(
        browser,
        page,
        &[format!("--screenshot={}", shot_path.display())],
        &dir.join("profile-shot"),
    );
    let shot = image::open(&shot_path)
        .unwrap_or_else(|e| panic!("no screenshot at {}: {e}\n{log2}", shot_path.display()))
        .to_rgb8();
    let log_errors = format!("{log1}\n{log2}")
        .lines()
        .filter(|l| l.contains("Uncaught") || (l.contains("CONSOLE") && l.contains("rror")))
        .map(str::to_string)
        .collect();
    Seen {
        viewer: attr(&dom, "data-viewer").unwrap_or_default(),
        errors: attr(&dom, "data-errors")
            .and_then(|e| e.parse().ok())
            .unwrap_or(usize::MAX),
        dom,
        log_errors,
        shot,
    }
}

/// Pixels of the 3-D view: the bounding box of the view's background colour, and how many
/// pixels in it are surface (far from that colour), with how many distinct grey levels.
fn surface_pixels(shot: &image::RgbImage) -> (usize, usize, usize) {
    let near = |p: &[u8; 3], q: [u8; 3]| p.iter().zip(q).all(|(a, b)| a.abs_diff(b) <= 3);
    let (mut r0, mut r1, mut c0, mut c1) = (u32::MAX, 0, u32::MAX, 0);
    for (c, r, p) in shot.enumerate_pixels() {
        if near(&p.0, VIEW_BG) {
            (r0, r1, c0, c1) = (r0.min(r), r1.max(r), c0.min(c), c1.max(c));
        }
    }
    if r0 > r1 {
        return (0, 0, 0);
    }
    let (mut surface, mut levels) = (0, [false; 256]);
    for r in r0..=r1 {
        for c in c0..=c1 {
            let p = shot.get_pixel(c, r).0;
            if p.iter().zip(VIEW_BG).any(|(a, b)| a.abs_diff(b) > 12) {
                surface += 1;
                levels[((u32::from(p[0]) + u32::from(p[1]) + u32::from(p[2])) / 3) as usize] = true;
            }
        }
    }
    let area = ((r1 - r0 + 1) * (c1 - c0 + 1)) as usize;
    (area, surface, levels.iter().filter(|&&l| l).count())
}

/// A bumpy dome with a dimple and striped albedo, meshed straight from its height field.
fn synthetic_report() -> String {
    let (w, h) = (160, 120);
    let height = |x: f64, y: f64| {
        let rho2 = (x * x + y * y) / 50.0f64.powi(2);
        if rho2 >= 1.0 {
            return f64::NAN;
        }
        40.0 * (1.0 - rho2).sqrt() + 3.0 * (x / 6.0).sin() * (y / 9.0).cos()
            - 14.0 * (-((x - 18.0).powi(2) + (y + 8.0).powi(2)) / 120.0).exp()
    };
    let depth = Image::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        height(x, y) as f32
    });
    let mask: Mask = depth.map(|z| z.is_finite());
    let normals = Image::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        let p = (height(x + 0.5, y) - height(x - 0.5, y)) as f32;
        let q = (height(x, y + 0.5) - height(x, y - 0.5)) as f32;
        gradient_to_normal(p, q)
    });
    let albedo = Image::from_fn(w, h, |_, c| if (c / 12) % 2 == 0 { 0.9 } else { 0.55 });
    let lights =
        Lights::from_directions(vec![[0.3, 0.2, 0.93], [-0.4, 0.1, 0.91], [0.0, -0.5, 0.87]]);
    let images: Vec<_> = lights
        .directions
        .iter()
        .map(|l| {
            Image::from_fn(w, h, |r, c| {
                let n = normals.get(r, c);
                let shade = n[0] * l[0] + n[1] * l[1] + n[2] * l[2];
                if *mask.get(r, c) {
                    albedo.get(r, c) * shade.max(0.0)
                } else {
                    0.0
                }
            })
        })
        .collect();
    let stack = ImageStack::from_images(&images).unwrap();
    let mut report = Report::new("synthetic dome");
    report.subtitle("browser test: analytic height field");
    report.inputs(&stack);
    report.normals(&normals, Some(&mask)).unwrap();
    report.albedo(&albedo, Some(&mask)).unwrap();
    report
        .scalar("confidence", &albedo, Some(&mask), ColorMap::Viridis)
        .unwrap();
    report
        .depth(&depth)
        .figure("pixels", mask.count().to_string());
    report.surface(&depth, Some(&albedo)).unwrap();
    report.to_html().unwrap()
}

fn check_rendered(seen: &Seen, what: &str) {
    assert_eq!(
        seen.viewer, "ready",
        "{what}: 3-D view not ready; DOM:\n{:.3000}",
        seen.dom
    );
    assert_eq!(
        seen.errors, 0,
        "{what}: the page reported script errors:\n{:.3000}",
        seen.dom
    );
    assert!(
        seen.log_errors.is_empty(),
        "{what}: console errors: {:?}",
        seen.log_errors
    );
    let (area, surface, levels) = surface_pixels(&seen.shot);
    eprintln!("{what}: view {area} px, surface {surface} px, {levels} grey levels");
    assert!(
        area > 200_000,
        "{what}: the 3-D view covers only {area} px of the screenshot"
    );
    assert!(
        surface * 20 > area,
        "{what}: only {surface} of {area} view pixels show a surface"
    );
    assert!(
        levels >= 40,
        "{what}: the surface has {levels} grey levels: not shaded"
    );
}

#[test]
fn synthetic_report_shows_a_shaded_surface_without_errors() {
    let Some(browser) = browser("synthetic_report_shows_a_shaded_surface_without_errors") else {
        return;
    };
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let page = dir.join("synthetic-report.html");
    std::fs::write(&page, synthetic_report()).unwrap();
    let seen = open(&browser, &page, "synthetic");
    check_rendered(&seen, "synthetic report");

    // The checks catch a broken page: the same report with a failing script.
    let broken =
        synthetic_report().replace("</body>", "<script>no_such_function();</script></body>");
    let bad_page = dir.join("broken-report.html");
    std::fs::write(&bad_page, broken).unwrap();
    let (dom, log) = run_browser(
        &browser,
        &bad_page,
        &["--dump-dom".into()],
        &dir.join("profile-bad"),
    );
    assert_eq!(
        attr(&dom, "data-errors").as_deref(),
        Some("1"),
        "the error was not counted"
    );
    assert!(
        log.contains("Uncaught ReferenceError"),
        "the browser log missed the error:\n{log}"
    );
}

/// The relighting view shades the normals under the start light as the Lambertian model
/// says (mean grey level against the one computed here), without script errors.
#[test]
fn relighting_view_draws_the_lambertian_shading() {
    let Some(browser) = browser("relighting_view_draws_the_lambertian_shading") else {
        return;
    };
    let (w, h, radius) = (128, 128, 50.0f64);
    let normal = |r: usize, c: usize| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        let z2 = radius * radius - x * x - y * y;
        (z2 > 0.0).then(|| {
            [
                (x / radius) as f32,
                (y / radius) as f32,
                (z2.sqrt() / radius) as f32,
            ]
        })
    };
    let normals = Image::from_fn(w, h, |r, c| normal(r, c).unwrap_or([0.0; 3]));
    let mask: Mask = Image::from_fn(w, h, |r, c| normal(r, c).is_some());
    let mut report = Report::new("relighting");
    report.relight(&normals, None, Some(&mask)).unwrap();
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let page = dir.join("relight-report.html");
    std::fs::write(&page, report.to_html().unwrap()).unwrap();
    let seen = open(&browser, &page, "relight");
    assert_eq!(attr(&seen.dom, "data-relight").as_deref(), Some("drawn"));
    assert!(
        seen.errors == 0 && seen.log_errors.is_empty(),
        "script errors"
    );
    let [lx, ly] = photostereo::report::relight::START_LIGHT.map(f64::from);
    let lz = (1.0 - lx * lx - ly * ly).sqrt();
    let light = attr(&seen.dom, "data-relight-light").unwrap_or_default();
    assert_eq!(light, format!("{lx:.3},{ly:.3},{lz:.3}"));
    // no albedo: grey 204 (0.8 of white) times the cosine
    let (mut sum, mut count) = (0.0, 0usize);
    for n in normals.data.iter().filter(|n| n[2] > 0.0) {
        let shade = f64::from(n[0]) * lx + f64::from(n[1]) * ly + f64::from(n[2]) * lz;
        sum += (204.0 * shade.max(0.0)).round();
        count += 1;
    }
    let expected = sum / count as f64;
    let drawn: f64 = attr(&seen.dom, "data-relight-mean")
        .unwrap()
        .parse()
        .unwrap();
    eprintln!("relighting: mean grey {drawn} drawn, {expected:.2} expected");
    assert!(
        (drawn - expected).abs() < 1.0,
        "drawn {drawn}, expected {expected:.2}"
    );
    // the screenshot shows the shaded sphere: many grey levels, brightest up and right
    let levels: std::collections::HashSet<u8> = seen
        .shot
        .pixels()
        .filter(|p| p.0[0] == p.0[1] && p.0[1] == p.0[2])
        .map(|p| p.0[0])
        .collect();
    assert!(levels.len() > 100, "{} grey levels on screen", levels.len());
}

/// The README's first command: `photostereo demo`, then both of its reports in the browser.
#[test]
fn demo_reports_show_shaded_surfaces_without_errors() {
    let Some(browser) = browser("demo_reports_show_shaded_surfaces_without_errors") else {
        return;
    };
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("demo");
    let _ = std::fs::remove_dir_all(&out);
    let status = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args(["--quiet", "demo", "-o"])
        .arg(&out)
        .status()
        .expect("run photostereo demo");
    assert!(status.success(), "photostereo demo failed");
    for scene in ["vase", "bowl"] {
        let page = out.join(scene).join("report.html");
        assert!(page.is_file(), "no report at {}", page.display());
        let seen = open(&browser, &page, &format!("demo-{scene}"));
        check_rendered(&seen, &format!("demo {scene} report"));
    }
    to_docs("browser-demo-bowl/screenshot.png", "view-demo-bowl.png");
    for plot in ["profiles.png", "convergence.png"] {
        let src = out.join("bowl").join(plot);
        assert!(src.is_file(), "no {}", src.display());
        if std::env::var_os("PHOTOSTEREO_DOCS").is_some() {
            std::fs::copy(&src, docs_dir().join(format!("plot-{plot}"))).unwrap();
        }
    }
}

fn docs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs")
}

/// With `PHOTOSTEREO_DOCS=1`, copy a screenshot (relative to the test's temporary
/// directory) into `docs/` under `name`: how the README's pictures are made.
fn to_docs(shot: &str, name: &str) {
    if std::env::var_os("PHOTOSTEREO_DOCS").is_some() {
        let src = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(shot);
        std::fs::copy(&src, docs_dir().join(name))
            .unwrap_or_else(|e| panic!("copying {} to docs: {e}", src.display()));
    }
}

/// Real photographs: Lambertian photometric stereo with lights calibrated from the chrome
/// sphere gives a surface that the report draws.
#[test]
fn real_buddha_report_shows_a_shaded_surface_without_errors() {
    let Some(browser) = browser("real_buddha_report_shows_a_shaded_surface_without_errors") else {
        return;
    };
    let Some(real) = common::shared::path(
        "real_buddha_report_shows_a_shaded_surface_without_errors",
        "data/real",
    ) else {
        return;
    };
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("buddha");
    let _ = std::fs::remove_dir_all(&out);
    let status = Command::new(env!("CARGO_BIN_EXE_photostereo"))
        .args(["--quiet", "run", "--chrome"])
        .arg(real.join("chrome"))
        .arg(real.join("buddha"))
        .arg("-o")
        .arg(&out)
        .status()
        .expect("run photostereo run");
    assert!(status.success(), "photostereo run on the buddha failed");
    let seen = open(&browser, &out.join("report.html"), "buddha");
    check_rendered(&seen, "buddha report");
    // The view starts facing the object and fitted to the panel (measured: 93k of 694k).
    let (area, surface, _) = surface_pixels(&seen.shot);
    eprintln!("buddha, first view: the surface fills {surface} of {area} view pixels");
    assert!(surface * 10 > area, "the object fills little of the view");
    // `#view=side` opens on the side view (the front/side/top buttons' views).
    let side = open(&browser, &out.join("report.html#view=side"), "buddha-side");
    // Seen edge-on a relief is thin (measured: 21k of 694k view pixels): no coverage test.
    assert_eq!(side.viewer, "ready", "side view not ready");
    assert!(
        side.errors == 0 && side.log_errors.is_empty(),
        "side view: script errors"
    );
    let (_, surface, levels) = surface_pixels(&side.shot);
    assert!(
        surface > 7_000 && levels >= 40,
        "side view: {surface} px, {levels} levels"
    );
    assert!(
        side.dom.contains("data-view=\"side\""),
        "the side view was not selected"
    );
    to_docs("browser-buddha/screenshot.png", "view-buddha-front.png");
    // the relighting view of the run's normals and albedo, on a page of its own
    let normals = photostereo::io::read_normals_npy(&out.join("normals.npy")).unwrap();
    let albedo = photostereo::io::read_gray_npy(&out.join("albedo.npy")).unwrap();
    let mask: Mask = normals.map(|n| *n != [0.0; 3]);
    let mut report = Report::new("buddha: relighting");
    report
        .relight(&normals, Some(&albedo), Some(&mask))
        .unwrap();
    let page = out.join("relight.html");
    std::fs::write(&page, report.to_html().unwrap()).unwrap();
    let relit = open(&browser, &page, "buddha-relight");
    assert_eq!(attr(&relit.dom, "data-relight").as_deref(), Some("drawn"));
    assert!(
        relit.errors == 0 && relit.log_errors.is_empty(),
        "relighting: script errors"
    );
    to_docs(
        "browser-buddha-relight/screenshot.png",
        "view-buddha-relight.png",
    );
    to_docs("browser-buddha-side/screenshot.png", "view-buddha-side.png");
}
