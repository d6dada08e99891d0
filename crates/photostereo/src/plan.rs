//! The memory plan of a run, made from the images' headers before any pixel is read.
//!
//! A run from paths ([`crate::pipeline::run`]) reads the target's light images by row
//! bands ([`crate::io::bands`]): the per-pixel stages (lookup or Lambertian solve, the
//! noise and the evidence of the spatial stage) see one band of K images at a time,
//! while the products that integration, meshing and the spatial solve need live on the
//! whole H×W grid. So the memory of a run is
//!
//! need = grid bytes (H·W × [`GRID_BYTES_PER_PIXEL`]) + fixed bytes (decoders, images
//! that cannot be read by rows, the calibration sphere) + band rows × bytes per band row
//!
//! and the band height is the largest that keeps the need within the budget (the whole
//! image when it fits: then it is read once). A capture whose need at one row per band
//! is over the budget is refused before any pixel is read, with the amount it needs.
//!
//! [`GRID_BYTES_PER_PIXEL`] and [`RUN_BYTES`] are measured, not derived: after the
//! integration stopped holding the gradient planes through its solve, the peaks of
//! `run --sphere` on the vase of docs/benchmarks.md ("Big captures"), less the band and
//! the fixed bytes, were 1098 MiB at 4096² (68.6 B per pixel), 335 MiB at 2048² and
//! 161 MiB at 1024²: a size-independent ~100 MiB (program, table and index) plus about
//! 64 B per pixel, which 64 B per pixel and 128 MiB cover at the three sizes (the plan
//! 1.2 / 0.64 / 0.39 GiB against 1.37 / 0.59 / 0.36 GiB measured with its bands).
//! Before that cut the figures were higher; the history: the highest peak resident
//! memory outside the reading of bands, less the fixed bytes, per pixel of the grid,
//! with a margin. Since
//! the spatial stage stores per mask pixel (issue 26) that peak is the integration's
//! (dense f64 least squares on the H×W grid, beside the normals, their maps and the
//! ground truth): 546 MiB at 2048² (119 B per pixel) and 1904 MiB at 4096² (114 B per
//! pixel), measured 2026-12-03 with `PHOTOSTEREO_MEMORY_TRACE`; the spatial stage's
//! grid (about 65 B per pixel) plus a band stays under it. It covers the lookup's maps,
//! the spatial stage, integration, the mesh (capped, [`crate::mesh::MeshOptions`]), the
//! curvature, the ground truth and the pictures of the report.

use crate::error::{Error, Result, Setting};
use crate::io::StackHeader;
use std::fmt;

/// Bytes per pixel of the H×W grid at the peak of a run (measured; module docs).
pub const GRID_BYTES_PER_PIXEL: u64 = 64;
/// Bytes of a run whatever its size: the program, the lookup table and its index, the
/// report's pieces (measured; module docs).
pub const RUN_BYTES: u64 = 128 << 20;
/// Bytes per pixel of a band beside its K float samples: the lookup's or the evidence's
/// outputs for the band (normals, confidence, residual, albedo, counts; u, A, g).
pub const BAND_BYTES_PER_PIXEL: u64 = 40;
/// Rows each image is converted at a time while a band is assembled.
const CHUNK_ROWS: u64 = 16;

/// What a run needs and how it will read the images.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The budget planned for, bytes.
    pub budget: u64,
    /// Image rows per band (the image height: one band).
    pub band_rows: usize,
    /// Number of bands.
    pub bands: usize,
    /// Bytes of the H×W grid products.
    pub grid_bytes: u64,
    /// Bytes that do not depend on the band height: decoders, images decoded whole,
    /// other datasets held in memory (the calibration sphere).
    pub fixed_bytes: u64,
    /// Bytes per row of a band (K float samples and the band's outputs per pixel).
    pub row_bytes: u64,
    /// Estimated peak, bytes: grid + fixed + band rows × row bytes.
    pub peak_bytes: u64,
    /// Images that cannot be read by rows (decoded once, kept at their bit depth).
    pub whole_images: usize,
}

impl Plan {
    /// The least memory the run can be done in (bands of one row), bytes.
    pub fn minimum_bytes(&self) -> u64 {
        self.grid_bytes + self.fixed_bytes + self.row_bytes
    }
}

/// Plan the reading of the images of `header` within `budget` bytes; `extra_bytes` is
/// held beside them the whole run (a calibration sphere, a chrome sphere).
///
/// Errors: a capture that does not fit even with one row per band, saying how much it
/// needs and what to change.
pub fn plan(header: &StackHeader, extra_bytes: u64, budget: u64) -> Result<Plan> {
    let (w, h, k) = (header.width as u64, header.height as u64, header.k() as u64);
    let grid_bytes = w * h * GRID_BYTES_PER_PIXEL;
    let fixed_bytes = RUN_BYTES
        + header.whole_bytes()
        + header.row_reader_bytes()
        + k * CHUNK_ROWS * w * 4
        + extra_bytes;
    let row_bytes = w * (4 * k + BAND_BYTES_PER_PIXEL);
    let base = grid_bytes + fixed_bytes;
    let whole_images = header.layout.iter().filter(|(_, rows)| !rows).count();
    if base + row_bytes > budget {
        return Err(over_budget(header, base + row_bytes, budget, whole_images));
    }
    let band_rows = ((budget - base) / row_bytes).min(h).max(1) as usize;
    let bands = header.height.div_ceil(band_rows);
    Ok(Plan {
        budget,
        band_rows,
        bands,
        grid_bytes,
        fixed_bytes,
        row_bytes,
        peak_bytes: base + band_rows as u64 * row_bytes,
        whole_images,
    })
}

fn over_budget(header: &StackHeader, need: u64, budget: u64, whole: usize) -> Error {
    let mut fix = format!(
        "give the run a memory budget of at least {} (it has {}), or crop or downsample the \
         images, or use fewer of them",
        Size(need),
        Size(budget)
    );
    if whole > 0 {
        fix.push_str(&format!(
            "; {whole} of the images are not PNGs read row by row and are held whole \
             ({}): PNG files need less",
            Size(header.whole_bytes())
        ));
    }
    Error::setting(
        Setting::Memory,
        format!(
            "{} images of {}×{} need at least {} of memory, over the memory budget of {}",
            header.k(),
            header.width,
            header.height,
            Size(need),
            Size(budget)
        ),
        fix,
    )
}

impl fmt::Display for Plan {
    /// One line: the need, the budget and the bands.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "memory plan: about {} of {} budget ({} grid, {} fixed, {} per band row); ",
            Size(self.peak_bytes),
            Size(self.budget),
            Size(self.grid_bytes),
            Size(self.fixed_bytes),
            Size(self.row_bytes)
        )?;
        if self.bands == 1 {
            write!(f, "the images are read in one band")?;
        } else {
            write!(
                f,
                "the images are read in {} bands of {} rows",
                self.bands, self.band_rows
            )?;
        }
        if self.whole_images > 0 {
            write!(f, " ({} images decoded whole)", self.whole_images)?;
        }
        Ok(())
    }
}

/// A byte count in binary units (`1.5 GiB`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Size(pub u64);

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.0 as f64;
        let (v, unit) = if b >= (1u64 << 30) as f64 {
            (b / (1u64 << 30) as f64, "GiB")
        } else if b >= (1u64 << 20) as f64 {
            (b / (1u64 << 20) as f64, "MiB")
        } else if b >= 1024.0 {
            (b / 1024.0, "KiB")
        } else {
            return write!(f, "{} B", self.0);
        };
        write!(f, "{v:.1} {unit}")
    }
}

/// Parse a memory size: a number of bytes with an optional unit `K`, `M`, `G`, `T`
/// (binary multiples; `KiB`, `MB`, `GB`… are read the same), e.g. `1.5G`, `800M`.
pub fn parse_size(text: &str) -> Result<u64> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let mult: u64 = match unit
        .trim()
        .to_ascii_uppercase()
        .trim_end_matches(['B', 'I'])
    {
        "" => 1,
        "K" => 1 << 10,
        "M" => 1 << 20,
        "G" => 1 << 30,
        "T" => 1 << 40,
        _ => 0,
    };
    match num.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && mult > 0 => Ok((v * mult as f64) as u64),
        _ => Err(Error::invalid(
            format!("memory size '{text}'"),
            "write a positive number of bytes with an optional unit K, M, G or T, e.g. 1.5G",
        )),
    }
}

/// The default budget: half of the machine's memory (`total_bytes`), so that a run
/// leaves room for the system and another job; 4 GiB when the total is unknown.
pub fn default_budget(total_bytes: Option<u64>) -> u64 {
    total_bytes.map_or(4 << 30, |t| t / 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn header(w: usize, h: usize, k: usize, rows: bool) -> StackHeader {
        StackHeader {
            files: (0..k).map(|i| PathBuf::from(format!("{i}.png"))).collect(),
            width: w,
            height: h,
            bit_depth: 16,
            layout: vec![(1, rows); k],
        }
    }

    #[test]
    fn a_capture_that_fits_is_read_in_one_band() {
        let p = plan(&header(256, 256, 8, true), 0, 8 << 30).unwrap();
        assert_eq!((p.bands, p.band_rows), (1, 256));
        assert!(p.peak_bytes <= p.budget);
    }

    #[test]
    fn the_band_height_keeps_the_peak_within_the_budget() {
        let hd = header(4096, 4096, 32, true);
        // 1 GiB of grid and 2.6 GiB of band for one band: 3 GiB needs several
        let budget = 3 << 30;
        let p = plan(&hd, 0, budget).unwrap();
        assert!(p.bands > 1, "{p}");
        assert!(p.peak_bytes <= budget, "{p}");
        // one more row per band would be over
        assert!(p.peak_bytes + p.row_bytes > budget, "{p}");
        assert_eq!(p.bands, 4096usize.div_ceil(p.band_rows));
    }

    #[test]
    fn an_over_budget_capture_says_what_it_needs() {
        let hd = header(8192, 8192, 60, false);
        let err = plan(&hd, 0, 1 << 30).unwrap_err().to_string();
        assert!(err.contains("60 images of 8192×8192"), "{err}");
        assert!(err.contains("over the memory budget of 1.0 GiB"), "{err}");
        assert!(err.contains("held whole"), "{err}");
        // the amount said is the minimum: that budget is accepted
        let need = 8192 * 8192 * GRID_BYTES_PER_PIXEL
            + RUN_BYTES
            + hd.whole_bytes()
            + hd.row_reader_bytes()
            + 60 * CHUNK_ROWS * 8192 * 4
            + 8192 * (4 * 60 + BAND_BYTES_PER_PIXEL);
        let p = plan(&hd, 0, need).unwrap();
        assert_eq!((p.band_rows, p.minimum_bytes()), (1, need));
    }

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("1.5G").unwrap(), 3 << 29);
        assert_eq!(parse_size("800M").unwrap(), 800 << 20);
        assert_eq!(parse_size("2GiB").unwrap(), 2 << 30);
        assert_eq!(parse_size("4096").unwrap(), 4096);
        assert!(parse_size("-1G").is_err());
        assert!(parse_size("lots").is_err());
        assert_eq!(Size(1536 << 20).to_string(), "1.5 GiB");
    }
}
