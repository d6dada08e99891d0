//! The dataset's text files: `filenames.txt`, `light_directions.txt`,
//! `light_intensities.txt` and the numeric tables they share (no image decoding here, so
//! that [`super::dataset`], [`super::hdr`] and [`super::lights_file`] all build on it).

use super::{read_text, write_text};
use crate::error::{Error, Result};
use crate::image::{normalize, Lights};
use std::cmp::Ordering;
use std::fmt::Write as _;
use std::path::Path;

/// File names from `filenames.txt`: one per line; blank lines and `#` comments skipped.
pub(crate) fn read_filenames(path: &Path) -> Result<Vec<String>> {
    let text = read_text(path)?;
    Ok(text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(str::to_string)
        .collect())
}

/// Compare names so that runs of digits compare by value (`2.png` < `10.png`).
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut x, mut y) = (a.as_bytes(), b.as_bytes());
    while !x.is_empty() && !y.is_empty() {
        if x[0].is_ascii_digit() && y[0].is_ascii_digit() {
            let dx = x.iter().take_while(|c| c.is_ascii_digit()).count();
            let dy = y.iter().take_while(|c| c.is_ascii_digit()).count();
            let (nx, ny) = (trim_zeros(&x[..dx]), trim_zeros(&y[..dy]));
            let ord = nx.len().cmp(&ny.len()).then(nx.cmp(ny));
            if ord != Ordering::Equal {
                return ord;
            }
            (x, y) = (&x[dx..], &y[dy..]);
        } else {
            if x[0] != y[0] {
                return x[0].cmp(&y[0]);
            }
            (x, y) = (&x[1..], &y[1..]);
        }
    }
    x.len().cmp(&y.len()).then_with(|| a.cmp(b))
}

fn trim_zeros(d: &[u8]) -> &[u8] {
    let z = d.iter().take_while(|&&c| c == b'0').count();
    &d[z..]
}

/// Parse the numeric lines of a text table (blank lines and `#` comments skipped;
/// numbers separated by spaces, tabs or commas). Returns (line number, values).
pub(crate) fn parse_rows(path: &Path) -> Result<Vec<(usize, Vec<f32>)>> {
    let text = read_text(path)?;
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut values = Vec::new();
        for token in line.split(|c: char| c.is_whitespace() || c == ',') {
            if token.is_empty() {
                continue;
            }
            let v: f32 = token.parse().map_err(|_| parse_error(path, i, token))?;
            if !v.is_finite() {
                return Err(parse_error(path, i, token));
            }
            values.push(v);
        }
        rows.push((i + 1, values));
    }
    Ok(rows)
}

fn parse_error(path: &Path, line: usize, token: &str) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        line: line + 1,
        message: format!("`{token}` is not a finite number"),
    }
}

/// Read `light_directions.txt`: one `x y z` line per light (surface → light, camera
/// frame). Directions are normalised; intensities are set to 1.
pub fn read_lights(path: &Path) -> Result<Lights> {
    let mut dirs = Vec::new();
    for (line, v) in parse_rows(path)? {
        let bad = |message: String| Error::Parse {
            path: path.to_path_buf(),
            line,
            message,
        };
        if v.len() != 3 {
            return Err(bad(format!("{} numbers, expected 3 (x y z)", v.len())));
        }
        let d = [v[0], v[1], v[2]];
        let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if norm.is_nan() || norm <= 1e-12 {
            return Err(bad("zero-length light direction".into()));
        }
        dirs.push(normalize(d));
    }
    Ok(Lights::from_directions(dirs))
}

/// Read `light_intensities.txt`: one value or an `R G B` triple per line (a single
/// value v becomes `[v, v, v]`); every value must be positive.
pub fn read_intensities(path: &Path) -> Result<Vec<[f32; 3]>> {
    let mut out = Vec::new();
    for (line, v) in parse_rows(path)? {
        let bad = |message: String| Error::Parse {
            path: path.to_path_buf(),
            line,
            message,
        };
        let t = match v.as_slice() {
            [a] => [*a; 3],
            [r, g, b] => [*r, *g, *b],
            _ => return Err(bad(format!("{} numbers, expected 1 or 3", v.len()))),
        };
        if t.iter().any(|&x| x <= 0.0) {
            return Err(bad("intensities must be positive".into()));
        }
        out.push(t);
    }
    Ok(out)
}

/// Write `light_directions.txt` (one `x y z` line per light, 9 decimals).
pub fn write_light_directions(path: &Path, lights: &Lights) -> Result<()> {
    let mut s = String::new();
    for d in &lights.directions {
        let _ = writeln!(s, "{:.9} {:.9} {:.9}", d[0], d[1], d[2]);
    }
    write_text(path, &s)
}

/// Write `light_intensities.txt` (one `v v v` line per light, as DiLiGenT).
pub fn write_intensities(path: &Path, lights: &Lights) -> Result<()> {
    let mut s = String::new();
    for v in &lights.intensities {
        let _ = writeln!(s, "{v} {v} {v}");
    }
    write_text(path, &s)
}
