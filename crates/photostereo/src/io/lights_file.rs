//! Light files of other tools, read as this crate's [`Lights`]:
//!
//! * **`.lp`** (RTIBuilder, CNR's Relight, highlight-RTI domes): the first line is the
//!   number of images N, then N lines `filename x y z` with the light *direction*
//!   (surface → light; x right, y up, z toward the camera, as here). The file names
//!   often are absolute paths of the machine that made the file (`C:\rti\img01.jpg`):
//!   only the last path component is kept and images are matched by it.
//! * **AliceVision / Meshroom `lights.json`**: `{"lights": [{"lightId" or "viewId": n,
//!   "intensity": [r, g, b], "direction": [x, y, z]}, ...]}`. Its ids are the views of
//!   an SfM file this crate does not read, so the lights are taken in the order of the
//!   array, one per image in image order.
//! * anything else: `light_directions.txt` style, one `x y z` line per image.
//!
//! [`read_lights_for`] reads any of them and returns the lights in the order of a
//! dataset's images.

use super::text_files::read_lights;
use super::{read_text, write_text};
use crate::error::{Error, Result};
use crate::image::{normalize, Lights};
use std::fmt::Write as _;
use std::path::Path;

/// A light file read with the image each light goes with, when it says so.
#[derive(Clone, Debug)]
pub struct LightFile {
    /// Unit directions (surface → light), intensities 1.
    pub lights: Lights,
    /// The image file name (last path component) of each light (`.lp`), else `None`.
    pub names: Option<Vec<String>>,
    /// RGB intensity of each light (`lights.json`), else `None`.
    pub intensities: Option<Vec<[f32; 3]>>,
}

/// What kind of light file a path is, by its name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightFormat {
    /// RTIBuilder / Relight `.lp`.
    Lp,
    /// AliceVision `lights.json` (any `.json`).
    AliceVisionJson,
    /// One `x y z` line per image.
    Text,
}

impl LightFormat {
    /// The format of `path`, by its extension (`.lp`, `.json`, else text).
    pub fn of(path: &Path) -> Self {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("lp") => LightFormat::Lp,
            Some("json") => LightFormat::AliceVisionJson,
            _ => LightFormat::Text,
        }
    }
}

/// Read a light file of any supported format (see the module docs), by its extension.
pub fn read_light_file(path: &Path) -> Result<LightFile> {
    match LightFormat::of(path) {
        LightFormat::Lp => read_lp(path),
        LightFormat::AliceVisionJson => read_alicevision_json(path),
        LightFormat::Text => Ok(LightFile {
            lights: read_lights(path)?,
            names: None,
            intensities: None,
        }),
    }
}

/// The lights of a light file in the order of the images `names` (file names): an
/// `.lp` is matched by file name, the other formats must hold one light per image, in
/// image order.
pub fn read_lights_for(path: &Path, names: &[String]) -> Result<Lights> {
    if !path.is_file() {
        return Err(Error::NotFound {
            path: path.to_path_buf(),
            fix: format!(
                "give a light file for the {} images: `x y z` lines, an RTI `.lp` file or an \
                 AliceVision lights.json",
                names.len()
            ),
        });
    }
    let file = read_light_file(path)?;
    let mut lights = match &file.names {
        Some(lp_names) => reorder(path, &file.lights, lp_names, names)?,
        None => file.lights.clone(),
    };
    if lights.len() != names.len() {
        return Err(Error::LightCount {
            what: path.display().to_string(),
            expected: names.len(),
            found: lights.len(),
            fix: format!("give one light per image ({} images)", names.len()),
        });
    }
    if let Some(t) = &file.intensities {
        lights.intensities = t.iter().map(|v| super::raster::luminance(*v)).collect();
    }
    Ok(lights)
}

/// The lights of `lp_names` picked in the order of the images `names`.
pub(crate) fn reorder(
    path: &Path,
    lights: &Lights,
    lp_names: &[String],
    names: &[String],
) -> Result<Lights> {
    let mut dirs = Vec::with_capacity(names.len());
    for name in names {
        let base = base_name(name);
        let Some(i) = lp_names.iter().position(|n| n == base) else {
            return Err(Error::invalid(
                format!("{}: no light for the image {name}", path.display()),
                "list every image of the dataset in the light file (file names are matched \
                 without their folders)",
            ));
        };
        dirs.push(lights.directions[i]);
    }
    Ok(Lights::from_directions(dirs))
}

/// The last component of a path written on any system (`/` or `\` separators).
pub fn base_name(path: &str) -> &str {
    path.rsplit(['/', '\\']).next().unwrap_or(path)
}

/// Read an RTIBuilder / Relight `.lp` file (see the module docs).
///
/// Errors: a first line that is not a count, a count that disagrees with the number of
/// light lines, a line without a name and three numbers, a zero direction.
pub fn read_lp(path: &Path) -> Result<LightFile> {
    let text = read_text(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let bad = |line: usize, message: String| Error::Parse {
        path: path.to_path_buf(),
        line,
        message,
    };
    let Some((first, count_text)) = lines.next() else {
        return Err(bad(1, "empty file; expected the number of images".into()));
    };
    let count: usize = count_text.parse().map_err(|_| {
        bad(
            first,
            format!("`{count_text}` is not the number of images (first line of an .lp file)"),
        )
    })?;
    let mut names = Vec::new();
    let mut dirs = Vec::new();
    for (line, l) in lines {
        let (name, d) = parse_lp_line(l).map_err(|m| bad(line, m))?;
        names.push(base_name(&name).to_string());
        dirs.push(d);
    }
    if names.len() != count {
        return Err(Error::LightCount {
            what: path.display().to_string(),
            expected: count,
            found: names.len(),
            fix: format!(
                "the first line says {count} images but {} light lines follow: make them agree",
                names.len()
            ),
        });
    }
    Ok(LightFile {
        lights: Lights::from_directions(dirs),
        names: Some(names),
        intensities: None,
    })
}

/// `filename x y z` (the name may hold spaces: the last three tokens are the numbers).
fn parse_lp_line(line: &str) -> std::result::Result<(String, [f32; 3]), String> {
    let tokens: Vec<&str> = line.split_whitespace().collect();
    if tokens.len() < 4 {
        return Err(format!(
            "{} fields, expected `filename x y z`",
            tokens.len()
        ));
    }
    let n = tokens.len();
    let mut d = [0f32; 3];
    for (v, t) in d.iter_mut().zip(&tokens[n - 3..]) {
        *v = t
            .parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("`{t}` is not a finite number"))?;
    }
    check_direction(d)?;
    Ok((tokens[..n - 3].join(" "), d))
}

fn check_direction(d: [f32; 3]) -> std::result::Result<(), String> {
    let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if norm.is_nan() || norm <= 1e-12 {
        return Err("zero-length light direction".into());
    }
    Ok(())
}

/// Read an AliceVision `lights.json` (see the module docs).
pub fn read_alicevision_json(path: &Path) -> Result<LightFile> {
    let text = read_text(path)?;
    let bad = |message: String| Error::Decode {
        path: path.to_path_buf(),
        message,
    };
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let Some(list) = value.get("lights").and_then(|l| l.as_array()) else {
        return Err(bad(
            "no \"lights\" array (expected {\"lights\": [{\"direction\": [x, y, z], \
             \"intensity\": [r, g, b]}, ...]})"
                .into(),
        ));
    };
    let mut dirs = Vec::with_capacity(list.len());
    let mut intensities = Vec::with_capacity(list.len());
    for (i, light) in list.iter().enumerate() {
        let at = |m: String| bad(format!("light {} (index {i}): {m}", light_id(light, i)));
        let d = triple(light, "direction").map_err(at)?;
        check_direction(d).map_err(at)?;
        let t = match light.get("intensity") {
            None => [1.0; 3],
            Some(_) => triple(light, "intensity").map_err(at)?,
        };
        if t.iter().any(|&v| v <= 0.0) {
            return Err(at("intensities must be positive".into()));
        }
        dirs.push(normalize(d));
        intensities.push(t);
    }
    Ok(LightFile {
        lights: Lights::from_directions(dirs),
        names: None,
        intensities: Some(intensities),
    })
}

fn light_id(light: &serde_json::Value, i: usize) -> String {
    ["lightId", "viewId"]
        .iter()
        .find_map(|k| light.get(*k).map(|v| v.to_string()))
        .unwrap_or_else(|| (i + 1).to_string())
}

/// A field of three finite numbers (a single number v stands for `[v, v, v]`).
fn triple(light: &serde_json::Value, key: &str) -> std::result::Result<[f32; 3], String> {
    let v = light
        .get(key)
        .ok_or_else(|| format!("no \"{key}\" field"))?;
    let nums: Vec<f64> = match v {
        serde_json::Value::Number(n) => vec![n.as_f64().unwrap_or(f64::NAN); 3],
        serde_json::Value::Array(a) => a.iter().map(|x| x.as_f64().unwrap_or(f64::NAN)).collect(),
        _ => vec![],
    };
    if nums.len() != 3 || nums.iter().any(|x| !x.is_finite()) {
        return Err(format!("\"{key}\" must be three finite numbers"));
    }
    Ok([nums[0] as f32, nums[1] as f32, nums[2] as f32])
}

/// Write an `.lp` file: the count, then `name x y z` per light (6 decimals, as
/// RTIBuilder writes them). `names` are the image file names, one per light.
pub fn write_lp(path: &Path, names: &[String], lights: &Lights) -> Result<()> {
    if names.len() != lights.len() {
        return Err(Error::LightCount {
            what: path.display().to_string(),
            expected: names.len(),
            found: lights.len(),
            fix: "give one light per image".into(),
        });
    }
    let mut s = format!("{}\n", names.len());
    for (n, d) in names.iter().zip(&lights.directions) {
        let _ = writeln!(s, "{n} {:.6} {:.6} {:.6}", d[0], d[1], d[2]);
    }
    write_text(path, &s)
}

/// The one light file of another tool in a dataset folder, if any: a single `*.lp`, or
/// `lights.json`. Two `.lp` files are an error (which one is meant?).
pub fn find_light_file(dir: &Path) -> Result<Option<std::path::PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut lps = Vec::new();
    for entry in entries.flatten() {
        let p = entry.path();
        if p.is_file() && LightFormat::of(&p) == LightFormat::Lp {
            lps.push(p);
        }
    }
    lps.sort();
    match lps.len() {
        0 => {
            let json = dir.join("lights.json");
            Ok(json.is_file().then_some(json))
        }
        1 => Ok(lps.pop()),
        _ => Err(Error::invalid(
            format!(
                "{}: several .lp light files ({})",
                dir.display(),
                lps.iter()
                    .map(|p| base_name(&p.to_string_lossy()).to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            "keep one .lp file in the dataset folder, or write light_directions.txt",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `text` written to `name` in `dir` (a scratch folder removed at the end of the test).
    fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn lp_names_lose_their_foreign_folders_and_directions_are_normalised() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            "a.lp",
            "3\r\nC:\\rti\\my shot 1.JPG 0 0 2\r\n/home/u/2.jpg 0.6 0 0.8\r\n3.jpg -0.6 0 0.8\r\n",
        );
        let f = read_lp(&p).unwrap();
        assert_eq!(f.names.unwrap(), ["my shot 1.JPG", "2.jpg", "3.jpg"]);
        assert_eq!(f.lights.directions[0], [0.0, 0.0, 1.0]);
        assert_eq!(f.lights.directions[2], [-0.6, 0.0, 0.8]);
    }

    #[test]
    fn lp_round_trips_and_reorders_to_the_images() {
        let dir = tempfile::tempdir().unwrap();
        let lights =
            Lights::from_directions(vec![[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, 0.6, 0.8]]);
        let names: Vec<String> = ["a.png", "b.png", "c.png"].map(String::from).to_vec();
        let p = write(&dir, "rt.lp", "");
        write_lp(&p, &names, &lights).unwrap();
        let back = read_lights_for(&p, &["c.png".into(), "a.png".into(), "b.png".into()]).unwrap();
        assert_eq!(back.directions[0], lights.directions[2]);
        assert_eq!(back.directions[1], lights.directions[0]);
        let missing = read_lights_for(&p, &["d.png".into(), "a.png".into(), "b.png".into()]);
        let e = missing.unwrap_err().to_string();
        assert!(e.contains("rt.lp") && e.contains("d.png"), "{e}");
    }

    #[test]
    fn lp_errors_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_lp(&write(&dir, "c.lp", "2\na.jpg 0 0 1\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("c.lp") && e.contains("expected 2") && e.contains("found 1"),
            "{e}"
        );
        let e = read_lp(&write(&dir, "z.lp", "1\na.jpg 0 0 0\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("zero-length"), "{e}");
        let e = read_lp(&write(&dir, "n.lp", "1\na.jpg 0 x 1\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("`x`"), "{e}");
        let e = read_lp(&write(&dir, "f.lp", "1\n0 0 1\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("filename x y z"), "{e}");
    }

    #[test]
    fn alicevision_json_directions_and_intensities() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            "lights.json",
            r#"{"lights": [{"lightId": 4, "intensity": [2, 1, 1], "direction": [0, 0, 3]},
                           {"viewId": 9, "intensity": 0.5, "direction": [0.6, 0, 0.8]}]}"#,
        );
        let f = read_alicevision_json(&p).unwrap();
        assert_eq!(f.lights.directions, vec![[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]]);
        assert_eq!(f.intensities.unwrap(), vec![[2.0, 1.0, 1.0], [0.5; 3]]);
        let bad = write(
            &dir,
            "bad.json",
            r#"{"lights": [{"lightId": 7, "direction": [0, 0, 0]}]}"#,
        );
        let e = read_alicevision_json(&bad).unwrap_err().to_string();
        assert!(
            e.contains("bad.json") && e.contains("light 7") && e.contains("zero"),
            "{e}"
        );
        let e = read_alicevision_json(&write(&dir, "x.json", "{}"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"lights\""), "{e}");
    }
}
