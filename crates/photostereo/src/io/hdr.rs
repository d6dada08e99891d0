//! Several exposures per light, merged into one linear image (high dynamic range).
//!
//! A dataset brackets its exposures when `exposure_times.txt` is present: each line of
//! `filenames.txt` then names one file per exposure of that light (separated by spaces,
//! tabs or commas), and `exposure_times.txt` gives the relative exposure (shutter time ×
//! gain) of each column: one line for all lights, or one line per light.
//!
//! Each exposure e of a light, with time tₑ, gives per pixel a linear value vₑ (after
//! the response curve); vₑ/tₑ estimates the same radiance. Samples that are clipped
//! (a colour channel at full scale) or near black (below two codes of the file's bit
//! depth, where quantisation dominates) are left out; the others are averaged with
//! weights tₑ², the inverse variance of vₑ/tₑ when the error is quantisation
//! (q²/12 in vₑ): the longest unclipped exposure counts most. Times are taken relative
//! to the shortest, so merged values are in the units of the shortest exposure (1 =
//! its full scale), and go above 1 nowhere. A pixel with no usable sample takes its
//! longest unclipped exposure (all near black) or its shortest (all clipped, still
//! counted as saturated).

use super::raster::{decode_gray_response, Decoded};
use super::response::Response;
use crate::error::{Error, Result};
use crate::image::Image;
use std::path::{Path, PathBuf};

/// The exposure files and the relative times of each light, when `dir` has an
/// `exposure_times.txt` (`None` otherwise). Each line of `filenames.txt` names the files
/// of one light, as many as that light has exposures.
#[allow(clippy::type_complexity)]
pub(crate) fn brackets(
    dir: &Path,
    lines: &[PathBuf],
) -> Result<Option<Vec<(Vec<PathBuf>, Vec<f32>)>>> {
    let times_path = dir.join("exposure_times.txt");
    if !times_path.exists() {
        return Ok(None);
    }
    let list = dir.join("filenames.txt");
    if !list.exists() {
        return Err(Error::NotFound {
            path: list,
            fix: format!(
                "{} needs filenames.txt: one line per light naming its file of each exposure",
                times_path.display()
            ),
        });
    }
    let names = super::text_files::read_filenames(&list)?;
    debug_assert_eq!(names.len(), lines.len());
    let times = read_exposure_times(&times_path, names.len())?;
    let mut out = Vec::with_capacity(names.len());
    for (i, (line, t)) in names.iter().zip(times).enumerate() {
        let files: Vec<PathBuf> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|n| !n.is_empty())
            .map(|n| dir.join(n))
            .collect();
        if files.len() != t.len() {
            return Err(Error::invalid(
                format!(
                    "{}: light {} names {} files, {} gives {} exposures",
                    list.display(),
                    i + 1,
                    files.len(),
                    times_path.display(),
                    t.len()
                ),
                "name one file per exposure on each line of filenames.txt, in the order of \
                 the exposures",
            ));
        }
        out.push((files, t));
    }
    Ok(Some(out))
}

/// Decode the exposures `files` of one light (taken with relative times `times`) and
/// merge them ([`merge`]); `scale` and `response` as for one image.
pub(crate) fn decode_bracket(
    files: &[PathBuf],
    times: &[f32],
    scale: Option<[f32; 3]>,
    response: Response,
) -> Result<Decoded> {
    let shots: Vec<Decoded> = files
        .iter()
        .map(|f| decode_gray_response(f, scale, response))
        .collect::<Result<_>>()?;
    for (f, shot) in files.iter().zip(&shots).skip(1) {
        super::raster::check_consistent((&files[0], &shots[0]), (f, shot))?;
    }
    let black = match shots[0].bit_depth {
        8 | 16 => {
            let full = if shots[0].bit_depth == 8 {
                255.0
            } else {
                65535.0
            };
            let curve = response.resolve(super::raster::format_of(&files[0]));
            let s = scale.unwrap_or([1.0; 3]);
            curve.linearize(2.0 / full) / super::raster::luminance(s)
        }
        _ => 0.0,
    };
    merge(shots, times, black)
}

/// Merge the exposures `shots` (same size, checked by the caller) of one light taken
/// with relative times `times` (> 0). `black` is the near-black level in the units of
/// the decoded values.
pub(crate) fn merge(shots: Vec<Decoded>, times: &[f32], black: f32) -> Result<Decoded> {
    let t_min = times.iter().copied().fold(f32::INFINITY, f32::min);
    let rel: Vec<f32> = times.iter().map(|t| t / t_min).collect();
    // exposures from the shortest to the longest, for the fallbacks
    let mut order: Vec<usize> = (0..shots.len()).collect();
    order.sort_by(|&a, &b| rel[a].total_cmp(&rel[b]));
    let first = &shots[0].image;
    let (w, h) = (first.width, first.height);
    let n = w * h;
    let mut data = Vec::with_capacity(n);
    let mut saturated = Vec::with_capacity(n);
    for i in 0..n {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (e, shot) in shots.iter().enumerate() {
            let v = shot.image.data[i];
            if shot.saturated[i] || v < black {
                continue;
            }
            let wgt = f64::from(rel[e]) * f64::from(rel[e]);
            num += wgt * f64::from(v / rel[e]);
            den += wgt;
        }
        if den > 0.0 {
            data.push((num / den) as f32);
            saturated.push(false);
            continue;
        }
        let longest_unclipped = order.iter().rev().find(|&&e| !shots[e].saturated[i]);
        let e = longest_unclipped.copied().unwrap_or(order[0]);
        data.push(shots[e].image.data[i] / rel[e]);
        saturated.push(longest_unclipped.is_none());
    }
    Ok(Decoded {
        image: Image::from_vec(w, h, data)?,
        bit_depth: shots[0].bit_depth,
        saturated,
    })
}

/// Read `exposure_times.txt`: one line of E relative exposures (for every light), or
/// `lights` lines of E; every value finite and positive. Returns one row per light.
pub(crate) fn read_exposure_times(path: &Path, lights: usize) -> Result<Vec<Vec<f32>>> {
    let rows = super::text_files::parse_rows(path)?;
    for (line, row) in &rows {
        if row.iter().any(|&t| t <= 0.0) {
            return Err(Error::Parse {
                path: path.to_path_buf(),
                line: *line,
                message: "exposures must be positive (relative shutter time × gain)".into(),
            });
        }
    }
    match rows.len() {
        1 => Ok(vec![rows[0].1.clone(); lights]),
        n if n == lights => Ok(rows.into_iter().map(|(_, r)| r).collect()),
        n => Err(Error::LightCount {
            what: path.display().to_string(),
            expected: lights,
            found: n,
            fix: "give one line of exposures (one per column of filenames.txt) for all \
                  lights, or one line per light"
                .into(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shot(values: &[f32], full: f32) -> Decoded {
        let q: Vec<f32> = values
            .iter()
            .map(|v| (v.min(1.0) * full).round() / full)
            .collect();
        Decoded {
            saturated: q.iter().map(|&v| v >= 1.0).collect(),
            image: Image::from_vec(values.len(), 1, q).unwrap(),
            bit_depth: 8,
        }
    }

    #[test]
    fn merged_values_follow_the_radiance_past_both_ends_of_one_exposure() {
        // radiances over three decades, in units of the short exposure's full scale
        let radiance: Vec<f32> = (0..200)
            .map(|i| 10f32.powf(-3.5 + 3.4 * i as f32 / 199.0))
            .collect();
        let bright: Vec<f32> = radiance.iter().map(|r| r * 16.0).collect();
        let merged = merge(
            vec![shot(&radiance, 255.0), shot(&bright, 255.0)],
            &[1.0, 16.0],
            2.0 / 255.0,
        )
        .unwrap();
        for (i, (&m, &r)) in merged.image.data.iter().zip(&radiance).enumerate() {
            // the long exposure clipped: the short one alone (half a code); else mostly
            // the long one (weights 1 : 256), half a code of it, a little more
            let long_clipped = r * 16.0 >= 254.5 / 255.0;
            let tol = if long_clipped {
                0.5 / 255.0
            } else {
                0.5 / 255.0 * 17.0 / 257.0
            };
            assert!((m - r).abs() <= tol * 1.001, "{i}: {m} vs {r}");
            assert!(!merged.saturated[i]);
        }
        // all clipped: the shortest exposure, flagged
        let m = merge(
            vec![shot(&[2.0], 255.0), shot(&[32.0], 255.0)],
            &[1.0, 16.0],
            0.0,
        )
        .unwrap();
        assert_eq!((m.image.data[0], m.saturated[0]), (1.0, true));
    }

    #[test]
    fn exposure_rows_are_checked() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("exposure_times.txt");
        std::fs::write(&p, "1 16\n").unwrap();
        assert_eq!(
            read_exposure_times(&p, 3).unwrap(),
            vec![vec![1.0, 16.0]; 3]
        );
        std::fs::write(&p, "1 16\n1 8\n").unwrap();
        let e = read_exposure_times(&p, 3).unwrap_err().to_string();
        assert!(
            e.contains("exposure_times.txt") && e.contains("expected 3"),
            "{e}"
        );
        std::fs::write(&p, "1 0\n").unwrap();
        let e = read_exposure_times(&p, 3).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("positive"), "{e}");
    }
}
