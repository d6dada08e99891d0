//! The lookup on data the project did not make: the Mitsuba renders of `../shared/data`
//! (sphere of radius 100 px → bumpy blob, Lambertian and GGX plastic) and DiLiGenT's
//! ball looked up in a table of itself at 0.75× (`../shared/data/real/diligent_ball`,
//! see its README). Each test prints the mean angular error by band of the true
//! normal's angle from the view axis, beside the table's plain nearest entry, and the
//! rank correlation (Spearman) between confidence and error; each skips with a note
//! when the shared data is absent.

mod common;
use photostereo::image::{ImageStack, Mask, NormalMap};
use photostereo::io::{self, LoadOptions};
use photostereo::lut::{self, BuildOptions, Method, Options, Output, Table};
use photostereo::progress::NoProgress;
use photostereo::sphere::{self, Circle, DetectOptions};
use photostereo::{eval, normals};

use common::lut_score::{print, score, Score};
use common::resample::{rescale, sphere_truth};

fn dataset(test: &str, rel: &str) -> Option<io::Dataset> {
    let dir = common::shared::path(test, &format!("data/{rel}"))?;
    Some(io::load_dataset(&dir, &LoadOptions::default()).unwrap())
}

fn solve(stack: &ImageStack, mask: &Mask, table: &Table, method: Method) -> Output {
    let opts = Options {
        method,
        ..Options::default()
    };
    lut::solve(stack, mask, std::slice::from_ref(table), &opts, &NoProgress).unwrap()
}

/// The refined lookup and the plain nearest entry, scored and printed.
fn compare(
    name: &str,
    stack: &ImageStack,
    mask: &Mask,
    truth: &NormalMap,
    t: &Table,
) -> [Score; 2] {
    let refined = score(&solve(stack, mask, t, Method::Refined), truth, mask);
    let nearest = score(&solve(stack, mask, t, Method::Nearest), truth, mask);
    print(&format!("{name}, refined"), &refined);
    print(&format!("{name}, nearest entry"), &nearest);
    for b in 0..4 {
        assert!(
            refined.bands[b] <= nearest.bands[b],
            "{name}: band {b} refined {:.3}° worse than the nearest entry {:.3}°",
            refined.bands[b],
            nearest.bands[b]
        );
    }
    // confidence ranks the errors (measured −0.25 … −0.66)
    assert!(
        refined.spearman < -0.15,
        "{name}: spearman {:.2}",
        refined.spearman
    );
    [refined, nearest]
}

fn table(stack: &ImageStack, circle: &Circle) -> Table {
    Table::build(stack, circle, &BuildOptions::default()).unwrap()
}

/// The Mitsuba renders: sphere r = 100 → blob, with the true circle and the circle the
/// detector finds; and the same sphere at half size (r = 50) by area averaging.
#[test]
fn mitsuba_renders_by_band() {
    for material in ["diffuse", "roughplastic"] {
        let (Some(calib), Some(target)) = (
            dataset("mitsuba_renders_by_band", &format!("calib_{material}")),
            dataset("mitsuba_renders_by_band", &format!("target_{material}")),
        ) else {
            return;
        };
        let dir = &target.dir;
        let truth = io::read_normals_npy(&dir.join("normal_gt.npy")).unwrap();
        let mask = target.mask.clone().unwrap();
        let true_circle = Circle {
            cx: 128.0,
            cy: 128.0,
            radius: 100.0,
        };
        let found = sphere::detect(&calib.stack, &DetectOptions::default())
            .unwrap()
            .circle;
        println!("{material}: circle found {found:?}");
        // measured (true / found circle, r 50): diffuse 0.061 / 0.059 / 0.072°,
        // rough plastic 0.056 / 0.095 / 0.126° (issue 10's targets: < 0.15° and < 0.30°)
        let t = table(&calib.stack, &true_circle);
        let [s, _] = compare(
            &format!("{material}, true circle"),
            &target.stack,
            &mask,
            &truth,
            &t,
        );
        assert!(s.mean < 0.12, "{material}: {:.3}°", s.mean);
        let t = table(&calib.stack, &found);
        let [s, _] = compare(
            &format!("{material}, found circle"),
            &target.stack,
            &mask,
            &truth,
            &t,
        );
        assert!(s.mean < 0.15, "{material}: {:.3}°", s.mean);
        let small = rescale(&calib.stack, &true_circle, 0.5, 256, 256);
        let half = Circle {
            radius: 50.0,
            ..true_circle
        };
        let t = table(&small, &half);
        let [s, _] = compare(
            &format!("{material}, sphere r 50"),
            &target.stack,
            &mask,
            &truth,
            &t,
        );
        assert!(s.mean < 0.25, "{material}: {:.3}°", s.mean);
    }
}

/// DiLiGenT's ball at 0.75× looked up in the table of the original photographs, both
/// on the circle of the true normals; truth analytic from the scaled circle, mask =
/// pixels whose centre lies ≥ 0.71 px inside it (no background in the footprint).
#[test]
fn diligent_ball_rescaled_by_band() {
    let Some(ball) = dataset("diligent_ball_rescaled_by_band", "real/diligent_ball") else {
        return;
    };
    let circle = Circle {
        cx: 112.370,
        cy: 112.368,
        radius: 70.751,
    };
    let t = table(&ball.stack, &circle);
    let s = 0.75;
    let (w, h) = (ball.stack.width, ball.stack.height);
    let small = rescale(&ball.stack, &circle, s, w, h);
    let scaled = Circle {
        radius: circle.radius * s,
        ..circle
    };
    let (mask, truth) = sphere_truth(&scaled, w, h, 0.71);
    let [s, _] = compare("DiLiGenT ball 0.75×", &small, &mask, &truth, &t);
    // the default pipeline (lookup, then the spatial stage), as `photostereo normals`
    // runs it: measured 0.078° (0.083° before the prior's local scale); issue 24's
    // target < 0.08°
    let lookup_opts = Options::default();
    let input = normals::Input::Tables(std::slice::from_ref(&t), &lookup_opts);
    let out = normals::solve(
        &small,
        &mask,
        &input,
        &normals::Options::default(),
        &NoProgress,
    );
    let default = eval::angular_errors(&out.unwrap().normals, &truth, &mask).unwrap();
    println!(
        "DiLiGenT ball 0.75×, default pipeline: mean {:.4}°",
        default.mean
    );
    assert!(default.mean < 0.08, "{:.4}°", default.mean);
    // measured: mean 0.082°, 0.02% of pixels over 2°, with the table's automatic blur
    // scaled for K = 96 lights (0.55 px; 0.258° and 0.44% with the K-blind 1.35 px;
    // 0.357°, 2.88% before the rim model and the certificate); issue 10's target < 0.15°
    assert!(s.mean < 0.15 && s.over2 < 0.002, "{s:?}");
    // the table on the circle the detector finds (no mask given), same target and truth
    let found = sphere::detect(&ball.stack, &DetectOptions::default())
        .unwrap()
        .circle;
    let t = table(&ball.stack, &found);
    let f = score(&solve(&small, &mask, &t, Method::Refined), &truth, &mask);
    print(&format!("DiLiGenT ball 0.75×, circle found {found:?}"), &f);
    // measured 0.779° (bands 0.53 / 1.43 / 2.46 / 2.87°) on the circle found
    // (112.340, 112.139, r 71.495: +0.74 px in radius); issue 10's target < 0.25° is
    // missed with that circle, the lookup itself gives 0.082° on the truth's
    assert!(f.mean < 1.5, "{f:?}");
}

/// The 16-bit scale of a render (`"scale"` in its `meta.json`).
fn render_scale(dir: &std::path::Path) -> f64 {
    let meta = std::fs::read_to_string(dir.join("meta.json")).unwrap();
    let at = meta.find("\"scale\":").expect("scale in meta.json") + 8;
    let end = meta[at..].find([',', '}']).unwrap() + at;
    meta[at..end].trim().parse().unwrap()
}

/// Textured albedo on the Mitsuba plastic (issue 10, item 4): the blob's diffuse
/// render (Lambert 0.7, scaled by κ to the plastic's diffuse level) times 16-px albedo
/// patches of 1.0 / 0.45, plus the rest of the plastic render (its highlight, and the
/// difference between the plastic's Fresnel-weighted diffuse lobe and Lambert's, which
/// does not scale with the patches: an approximation of a textured plastic). Normalised matching against the diffuse/specular split, both on
/// the plastic sphere's table with the true circle.
#[test]
fn mitsuba_textured_plastic_split() {
    let test = "mitsuba_textured_plastic_split";
    let (Some(calib), Some(plastic), Some(diffuse)) = (
        dataset(test, "calib_roughplastic"),
        dataset(test, "target_roughplastic"),
        dataset(test, "target_diffuse"),
    ) else {
        return;
    };
    let ratio = (render_scale(&plastic.dir) / render_scale(&diffuse.dir)) as f32;
    // the plastic's diffuse lobe is about κ × the Lambert 0.7 render (Fresnel
    // transmission): κ = median ratio of the two over brightly lit samples
    let mut ratios: Vec<f32> = (0..plastic.stack.pixels())
        .flat_map(|i| {
            let (p, d) = (plastic.stack.pixel_flat(i), diffuse.stack.pixel_flat(i));
            p.iter()
                .zip(d)
                .filter(|(_, &d)| d > 0.3)
                .map(|(p, d)| p / (d * ratio))
                .collect::<Vec<_>>()
        })
        .collect();
    let mid = ratios.len() / 2;
    let kappa = *ratios.select_nth_unstable_by(mid, f32::total_cmp).1;
    println!("plastic diffuse / Lambert 0.7: κ = {kappa:.3}");
    let ratio = ratio * kappa;
    let mut target = plastic.stack.clone();
    let w = target.width;
    for i in 0..target.pixels() {
        let (r, c) = (i / w, i % w);
        let tex = if (r / 16 + c / 16) % 2 == 0 {
            1.0
        } else {
            0.45
        };
        for (t, d) in target
            .pixel_flat_mut(i)
            .iter_mut()
            .zip(diffuse.stack.pixel_flat(i))
        {
            *t += (tex - 1.0) * d * ratio;
        }
    }
    let truth = io::read_normals_npy(&plastic.dir.join("normal_gt.npy")).unwrap();
    let mask = plastic.mask.clone().unwrap();
    let circle = Circle {
        cx: 128.0,
        cy: 128.0,
        radius: 100.0,
    };
    let t = [table(&calib.stack, &circle)];
    let run = |stack: &ImageStack, split: bool| {
        let opts = Options {
            normalize: true,
            split_specular: split,
            ..Options::default()
        };
        let out = lut::solve(stack, &mask, &t, &opts, &NoProgress).unwrap();
        score(&out, &truth, &mask)
    };
    let (plain, split) = (run(&target, false), run(&target, true));
    print("textured plastic, normalised", &plain);
    print("textured plastic, diffuse/specular split", &split);
    print("untextured plastic, split", &run(&plastic.stack, true));
    // measured: normalised 1.761° (bands 1.52 / 2.25 / 2.33 / 2.95°), split 0.462°
    // (0.27 / 0.79 / 0.84 / 1.80°; issue 10's target < 0.45°); untextured, split 0.048°
    // (0.010 / 0.019 / 0.055 / 0.97°): the textured errors come mostly from the
    // construction (Lambert-shaped texture on a Fresnel-shaped diffuse lobe)
    assert!(split.mean < 0.7 && split.bands[0] < 0.5, "{split:?}");
    assert!(split.bands[3] < 3.0, "{split:?}");
    assert!(
        split.mean < 0.5 * plain.mean,
        "{:.3}° vs {:.3}°",
        split.mean,
        plain.mean
    );
}

/// A physically textured plastic: the Mitsuba blob rendered with the plastic's diffuse
/// reflectance textured (albedo patches 0.11–0.85 against the sphere's 0.5; the case
/// `target_roughplastic_tex`, material `roughplastic_tex`, of `render_shared.py`, whose
/// `CASES` table does not list it: add the line
/// `'target_roughplastic_tex': ('blob', 'roughplastic_tex', 2, 'roughplastic')` and render
/// `--cases target_roughplastic_tex`). Read from `$PHOTOSTEREO_TEXTURED_PLASTIC`, else the
/// copy in `tests/data/mitsuba_textured_plastic` (see its README).
/// Looked up in the shared plastic sphere's table (true circle), normalised and split.
#[test]
fn mitsuba_rendered_textured_plastic() {
    let test = "mitsuba_rendered_textured_plastic";
    let Some(calib) = dataset(test, "calib_roughplastic") else {
        return;
    };
    let dir = std::env::var_os("PHOTOSTEREO_TEXTURED_PLASTIC")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/mitsuba_textured_plastic")
        });
    if !dir.is_dir() {
        let why = format!(
            "no textured plastic render at {} (see the test's docs to render it)",
            dir.display()
        );
        common::shared::skip(test, &why, "PHOTOSTEREO_REQUIRE_TEXTURED");
        return;
    }
    let target = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    let truth = io::read_normals_npy(&dir.join("normal_gt.npy")).unwrap();
    let mask = target.mask.clone().unwrap();
    let circle = Circle {
        cx: 128.0,
        cy: 128.0,
        radius: 100.0,
    };
    let t = [table(&calib.stack, &circle)];
    let run = |split: bool| {
        let opts = Options {
            normalize: true,
            split_specular: split,
            ..Options::default()
        };
        let out = lut::solve(&target.stack, &mask, &t, &opts, &NoProgress).unwrap();
        score(&out, &truth, &mask)
    };
    let (plain, split) = (run(false), run(true));
    print("rendered textured plastic, normalised", &plain);
    print("rendered textured plastic, split", &split);
    // measured: normalised 0.735° (bands 0.93 / 0.057 / 0.20 / 1.54°: issue 10's 0.74°),
    // split 0.242° (0.265 / 0.085 / 0.108 / 0.88°); issue 10's target < 0.45°
    assert!(split.mean < 0.45 && split.bands[0] < 0.5, "{split:?}");
    assert!(split.mean < 0.5 * plain.mean, "{split:?} {plain:?}");
}

/// The silhouette of an area-averaged render (Mitsuba: 8 × 8 samples a pixel, mask =
/// coverage ≥ ½): the outline pixels are partly background, dimmer than any table entry
/// of their normal. With `outline_coverage` (default) their tuple is corrected for the
/// coverage its brightness-free match shows; without it, it is matched as it is.
#[test]
fn mitsuba_silhouette_pixels_are_corrected_for_coverage() {
    for (material, on_max, off_min) in [("diffuse", 0.1, 1.5), ("roughplastic", 1.5, 1.5)] {
        let (Some(calib), Some(target)) = (
            dataset("mitsuba_silhouette", &format!("calib_{material}")),
            dataset("mitsuba_silhouette", &format!("target_{material}")),
        ) else {
            return;
        };
        let truth = io::read_normals_npy(&target.dir.join("normal_gt.npy")).unwrap();
        let mask = target.mask.clone().unwrap();
        let outline = Mask {
            data: (0..mask.data.len())
                .map(|i| mask.data[i] && lut::outline::on_outline_at(&mask, i))
                .collect(),
            ..mask.clone()
        };
        let found = sphere::detect(&calib.stack, &DetectOptions::default()).unwrap();
        let t = table(&calib.stack, &found.circle);
        // the lookup checks the correction on the sphere's own outline first, and keeps
        // it here (measured 2026-12-08, circle found: diffuse 2.42° plain → 0.05°
        // corrected, rough plastic 1.96° → 1.07°, 282 of the sphere's outline pixels)
        let lookup = lut::Lookup::new(std::slice::from_ref(&t), &Options::default()).unwrap();
        let check = lookup
            .outline_check()
            .expect("a fresh table has its outline sample");
        println!("{material}: the sphere's own outline {check:?}");
        assert!(check.helps() && check.pixels > 200, "{material}: {check:?}");
        let mut errs = Vec::new();
        for on in [true, false] {
            let opts = Options {
                outline_coverage: on,
                ..Options::default()
            };
            let tables = std::slice::from_ref(&t);
            let out = lut::solve(&target.stack, &mask, tables, &opts, &NoProgress).unwrap();
            let edge = eval::angular_errors(&out.normals, &truth, &outline).unwrap();
            let all = eval::angular_errors(&out.normals, &truth, &mask).unwrap();
            errs.push((edge.mean, all.mean));
        }
        println!("{material}: outline pixels / whole mask, corrected {errs:?} (then plain)");
        // measured 2026-12-05: diffuse outline 0.03° against 2.36° plain (whole mask
        // 0.013° / 0.061°); rough plastic 1.06° / 1.92° (0.051° / 0.069°)
        let [(edge_on, all_on), (edge_off, all_off)] = [errs[0], errs[1]];
        assert!(
            edge_on < on_max && edge_off > off_min,
            "{material}: {errs:?}"
        );
        assert!(all_on < 0.8 * all_off, "{material}: {errs:?}");
    }
}
