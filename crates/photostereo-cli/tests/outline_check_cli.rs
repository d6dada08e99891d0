//! The mask outline's coverage correction is checked on the calibration sphere's own
//! outline before it is applied (`lut::Lookup::outline_check`), and `normals` says what
//! it decided: applied for the Mitsuba renders' area-averaged silhouettes, not applied
//! for DiLiGenT's real ball, whose rim a lens blurs (`run` puts it in its figures); a
//! table written before the sphere's outline was kept says nothing and is corrected as
//! before. Skipped when `../shared`
//! is absent.

use std::path::Path;

use photostereo::io;

mod common;
use common::{photostereo_ok as photostereo, s};

/// The line `normals` prints about the check.
const SAID: &str = "mask outline: coverage correction";

/// `normals TARGET --lut LUT -o DIR/NAME`: the line it prints about the check, or "".
fn outline_line(target: &Path, lut: &Path, out: &Path) -> String {
    let said = photostereo(&["normals", s(target), "--lut", s(lut), "-o", s(out)]);
    let line = said.lines().find(|l| l.starts_with(SAID));
    line.unwrap_or_default().to_string()
}

#[test]
fn normals_says_whether_the_outline_is_corrected_and_why() {
    let test = "normals_says_whether_the_outline_is_corrected_and_why";
    let (Some(sphere), Some(target), Some(ball)) = (
        common::shared::path(test, "data/calib_diffuse"),
        common::shared::path(test, "data/target_diffuse"),
        common::shared::path(test, "data/real/diligent_ball"),
    ) else {
        return;
    };
    let dir = common::scratch("outline-check", "normals");
    let lut = dir.join("diffuse.lut");
    photostereo(&["calibrate", s(&sphere), "-o", s(&lut)]);
    let line = outline_line(&target, &lut, &dir.join("d"));
    // measured 2026-12-08: 282 px, 2.42° plain, 0.05° corrected
    assert!(
        line.contains("correction applied") && line.contains("282 px"),
        "{line}"
    );

    let ball_lut = dir.join("ball.lut");
    let circle = "112.370,112.368,70.751";
    photostereo(&[
        "calibrate",
        s(&ball),
        "--circle",
        circle,
        "-o",
        s(&ball_lut),
    ]);
    let line = outline_line(&ball, &ball_lut, &dir.join("b"));
    // measured 2026-12-08: 399 px, 1.02° plain, 1.05° corrected
    assert!(
        line.contains("correction not applied") && line.contains("399 px"),
        "{line}"
    );

    // `run` gives the same decision as a row of its figures (run.json and the report)
    let out = dir.join("run");
    photostereo(&[
        "run",
        "-q",
        "--sphere",
        s(&sphere),
        s(&target),
        "-o",
        s(&out),
    ]);
    let text = std::fs::read_to_string(out.join("run.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let row = json["figures"]["mask outline coverage correction"].as_str();
    let row = row.unwrap_or_default();
    assert!(
        row.starts_with("applied (on the sphere's own outline, 282 px"),
        "{text}"
    );

    // the same table as written before the outline was kept: no check, no line
    let mut older = io::read_table(&lut).unwrap();
    older.outline = None;
    let old_lut = dir.join("older.lut");
    std::fs::write(&old_lut, older.to_bytes()).unwrap();
    assert_eq!(outline_line(&target, &old_lut, &dir.join("o")), "");
}
