//! Reading a stack of light images by row bands, for captures too large to hold as
//! one float stack.
//!
//! [`probe_images`] reads the headers only (size, bit depth, channels: nothing is
//! decoded), so the memory a run needs is known before any pixel is read
//! ([`crate::plan`]). A [`BandReader`] then yields the images' rows `r0..r1` as a
//! pixel-major [`ImageStack`] of `r1 − r0` rows, band after band from the top:
//!
//! * non-interlaced 8/16-bit gray or RGB(A) PNGs are decoded row by row with the `png`
//!   crate's row reader (one open decoder per image: its inflate window and two rows);
//! * any other file (TIFF, palette or interlaced PNG) cannot be read by rows through its
//!   decoder, so it is decoded once and kept at its own bit depth (a 16-bit image stays
//!   2 bytes a sample, not 4); its bands are converted from that.
//!
//! Each row goes through the same conversion as [`super::load_dataset`] (division by
//! the full scale and the light intensity, luminance), so a band holds exactly the
//! values of the same rows of the whole stack.

use super::raster::{convert, open_image, reader, Sample};
use super::{limits, not_found_or_io};
use crate::error::{Error, Result};
use crate::image::ImageStack;
use image::DynamicImage;
use rayon::prelude::*;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// What the headers of a stack's images say (nothing decoded).
#[derive(Clone, Debug, PartialEq)]
pub struct StackHeader {
    /// The image files, in light order.
    pub files: Vec<PathBuf>,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Bits per sample: 8, 16, or 32 (float).
    pub bit_depth: u8,
    /// For each image: its samples per pixel (1 gray … 4 RGBA) and whether it can be
    /// read row by row (else it is decoded whole and kept at its bit depth).
    pub layout: Vec<(u8, bool)>,
}

impl StackHeader {
    /// Number of images.
    pub fn k(&self) -> usize {
        self.files.len()
    }

    /// Bytes held for the images that are decoded whole (kept at their own bit depth).
    pub fn whole_bytes(&self) -> u64 {
        let px = (self.width * self.height) as u64;
        let bytes = u64::from(self.bit_depth / 8);
        self.layout
            .iter()
            .filter(|(_, rows)| !rows)
            .map(|&(ch, _)| px * u64::from(ch) * bytes)
            .sum()
    }

    /// Bytes of decoder state for the images read by rows (window, two raw rows, file
    /// buffer).
    pub fn row_reader_bytes(&self) -> u64 {
        let row = (self.width * usize::from(self.bit_depth / 8)) as u64;
        self.layout
            .iter()
            .filter(|(_, rows)| *rows)
            .map(|&(ch, _)| 2 * row * u64::from(ch) + (96 << 10))
            .sum()
    }
}

/// Read the headers of `files`: sizes, bit depths and channels, checked to agree (the
/// same errors as [`super::load_dataset`]) and against [`limits`].
pub fn probe_images(files: &[PathBuf]) -> Result<StackHeader> {
    let Some(first) = files.first() else {
        return Err(Error::invalid(
            "image stack",
            "at least one image is needed",
        ));
    };
    let heads: Vec<Head> = files.par_iter().map(|f| probe(f)).collect::<Result<_>>()?;
    let h0 = &heads[0];
    for (f, h) in files.iter().zip(&heads).skip(1) {
        if (h.width, h.height) != (h0.width, h0.height) {
            return Err(Error::SizeMismatch {
                what: format!("{} (first image {})", f.display(), first.display()),
                expected_w: h0.width,
                expected_h: h0.height,
                found_w: h.width,
                found_h: h.height,
                fix: "all light images must have the same size".into(),
            });
        }
        if h.bit_depth != h0.bit_depth {
            return Err(Error::invalid(
                format!(
                    "{}: {}-bit image, but {} is {}-bit",
                    f.display(),
                    h.bit_depth,
                    first.display(),
                    h0.bit_depth
                ),
                "all light images must have the same bit depth",
            ));
        }
    }
    Ok(StackHeader {
        files: files.to_vec(),
        width: h0.width,
        height: h0.height,
        bit_depth: h0.bit_depth,
        layout: heads.iter().map(|h| (h.channels, h.rows)).collect(),
    })
}

/// One image's header.
struct Head {
    width: usize,
    height: usize,
    bit_depth: u8,
    channels: u8,
    rows: bool,
}

fn decode_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Decode {
        path: path.to_path_buf(),
        message: format!("{e} (expected an 8/16-bit gray or RGB PNG or TIFF image)"),
    }
}

/// The header of one image: a PNG through the `png` crate, anything else through the
/// `image` crate's decoder (which reads the header only until asked for pixels).
fn probe(path: &Path) -> Result<Head> {
    if let Some(head) = probe_png(path)? {
        return Ok(head);
    }
    let decoder = reader(path)?
        .into_decoder()
        .map_err(|e| decode_error(path, e))?;
    use image::ImageDecoder;
    let (w, h) = decoder.dimensions();
    limits::check_dimensions(path, u64::from(w), u64::from(h))?;
    let color = decoder.color_type();
    let channels = color.channel_count();
    let bit_depth = (color.bytes_per_pixel() / channels * 8) as u8;
    Ok(Head {
        width: w as usize,
        height: h as usize,
        bit_depth,
        channels,
        rows: false,
    })
}

/// The header of a PNG file (`None` when the file is not a PNG).
fn probe_png(path: &Path) -> Result<Option<Head>> {
    let fix = "check the path; images must be PNG or TIFF files";
    let mut file = File::open(path).map_err(|e| not_found_or_io(path, e, fix))?;
    let mut magic = [0u8; 8];
    use std::io::Read;
    if file.read_exact(&mut magic).is_err() || magic != *b"\x89PNG\r\n\x1a\n" {
        return Ok(None);
    }
    let mut dec = png::Decoder::new(BufReader::new(
        File::open(path).map_err(|e| Error::io(path, e))?,
    ));
    let info = dec.read_header_info().map_err(|e| decode_error(path, e))?;
    let (w, h) = (info.width, info.height);
    limits::check_dimensions(path, u64::from(w), u64::from(h))?;
    use png::{BitDepth, ColorType};
    let channels = match info.color_type {
        ColorType::Grayscale => 1,
        ColorType::GrayscaleAlpha => 2,
        ColorType::Rgb => 3,
        ColorType::Rgba => 4,
        // palette images come out of the image crate as 8-bit RGB(A)
        ColorType::Indexed => 3 + u8::from(info.trns.is_some()),
    };
    let deep = matches!(info.bit_depth, BitDepth::Eight | BitDepth::Sixteen);
    let rows = deep
        && info.color_type != ColorType::Indexed
        && !info.interlaced
        && info.animation_control.is_none();
    let bit_depth = if info.bit_depth == BitDepth::Sixteen {
        16
    } else {
        8
    };
    Ok(Some(Head {
        width: w as usize,
        height: h as usize,
        bit_depth,
        channels,
        rows,
    }))
}

/// Where one image's rows come from.
enum Source {
    /// A PNG decoded row by row.
    Png(Box<png::Reader<BufReader<File>>>),
    /// An image decoded whole, kept at its own bit depth.
    Whole(DynamicImage),
}

/// Reads the rows of a stack's images band after band, from the top ([module docs](self)).
pub struct BandReader {
    header: StackHeader,
    sources: Vec<Source>,
    scales: Vec<[f32; 3]>,
    next_row: usize,
}

impl BandReader {
    /// Open the images of `header` (`scales`: one light intensity per image, dividing
    /// R, G, B, as in [`super::LoadOptions::apply_intensities`]; `None` = 1). Images
    /// that cannot be read by rows are decoded here, in parallel.
    pub fn open(header: StackHeader, scales: &[Option<[f32; 3]>]) -> Result<Self> {
        let k = header.k();
        let scales: Vec<[f32; 3]> = (0..k)
            .map(|i| scales.get(i).copied().flatten().unwrap_or([1.0; 3]))
            .collect();
        for (f, s) in header.files.iter().zip(&scales) {
            if s.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                return Err(Error::invalid(
                    format!("{}: light intensity {s:?}", f.display()),
                    "intensities must be finite and positive",
                ));
            }
        }
        let sources = header
            .files
            .par_iter()
            .zip(&header.layout)
            .map(|(f, &(_, rows))| open_source(f, rows))
            .collect::<Result<_>>()?;
        Ok(BandReader {
            header,
            sources,
            scales,
            next_row: 0,
        })
    }

    /// The headers the reader was opened with.
    pub fn header(&self) -> &StackHeader {
        &self.header
    }

    /// The first row of the next band (rows above it have been read).
    pub fn next_row(&self) -> usize {
        self.next_row
    }

    /// The next `rows` rows of every image (fewer at the bottom) as a pixel-major stack
    /// of that many rows, with the image names.
    ///
    /// Errors: a file that is damaged past its header ([`Error::Decode`], naming it);
    /// no rows left.
    pub fn next_band(&mut self, rows: usize) -> Result<ImageStack> {
        let (w, h, k) = (self.header.width, self.header.height, self.header.k());
        let r0 = self.next_row;
        let rows = rows.min(h - r0.min(h));
        if rows == 0 {
            return Err(Error::invalid(
                "band past the last row of the images",
                "read at most the images' height in rows",
            ));
        }
        let mut stack = ImageStack::zeros(w, rows, k);
        // a few rows of every image at a time, converted in parallel over the images,
        // then interleaved: the buffers stay K × CHUNK rows, not a second band
        const CHUNK: usize = 16;
        for c0 in (0..rows).step_by(CHUNK) {
            let n = CHUNK.min(rows - c0);
            let first = r0 + c0;
            let planes: Vec<Vec<f32>> = self
                .sources
                .par_iter_mut()
                .zip(&self.header.files)
                .zip(&self.scales)
                .zip(&self.header.layout)
                .map(|(((src, f), s), &(ch, _))| src.rows(f, first, n, w, ch, *s))
                .collect::<Result<_>>()?;
            stack.data[c0 * w * k..(c0 + n) * w * k]
                .par_chunks_mut(w * k)
                .enumerate()
                .for_each(|(r, out)| {
                    for (i, plane) in planes.iter().enumerate() {
                        for (px, v) in out.chunks_exact_mut(k).zip(&plane[r * w..(r + 1) * w]) {
                            px[i] = *v;
                        }
                    }
                });
        }
        self.next_row = r0 + rows;
        stack.names = self
            .header
            .files
            .iter()
            .map(|f| {
                f.file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        Ok(stack)
    }
}

fn open_source(path: &Path, rows: bool) -> Result<Source> {
    if !rows {
        return Ok(Source::Whole(open_image(path)?));
    }
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let mut dec = png::Decoder::new(BufReader::new(file));
    // the samples as stored (no expansion, no gamma): the image crate's values
    dec.set_transformations(png::Transformations::IDENTITY);
    let reader = dec.read_info().map_err(|e| decode_error(path, e))?;
    Ok(Source::Png(Box::new(reader)))
}

impl Source {
    /// Rows `first..first + n` as luminance (`w` per row), `ch` samples per pixel.
    fn rows(
        &mut self,
        path: &Path,
        first: usize,
        n: usize,
        w: usize,
        ch: u8,
        scale: [f32; 3],
    ) -> Result<Vec<f32>> {
        let ch = usize::from(ch);
        let mut out = Vec::with_capacity(n * w);
        match self {
            Source::Png(reader) => {
                let sixteen = reader.info().bit_depth == png::BitDepth::Sixteen;
                for _ in 0..n {
                    let row = reader
                        .next_row()
                        .map_err(|e| decode_error(path, e))?
                        .ok_or_else(|| decode_error(path, "fewer rows than its header says"))?;
                    let raw = row.data();
                    if sixteen {
                        let v: Vec<u16> = raw
                            .chunks_exact(2)
                            .map(|b| u16::from_be_bytes([b[0], b[1]]))
                            .collect();
                        out.extend(luminance(&v[..w * ch], ch, Some(u16::MAX), scale));
                    } else {
                        out.extend(luminance(&raw[..w * ch], ch, Some(u8::MAX), scale));
                    }
                }
            }
            Source::Whole(img) => {
                // the decoded pixel type, which may add alpha to what the header said
                let ch = usize::from(img.color().channel_count());
                let span = first * w * ch..(first + n) * w * ch;
                let lum = whole_rows(img, span, scale).ok_or_else(|| Error::Decode {
                    path: path.to_path_buf(),
                    message: format!("unsupported pixel type {:?}", img.color()),
                })?;
                if let Some(i) = lum.iter().position(|v| !v.is_finite()) {
                    return Err(Error::Decode {
                        path: path.to_path_buf(),
                        message: format!(
                            "pixel (x {}, y {}) is {} (float images must hold finite values)",
                            i % w.max(1),
                            first + i / w.max(1),
                            lum[i]
                        ),
                    });
                }
                out = lum;
            }
        }
        Ok(out)
    }
}

/// Luminance of interleaved samples (`ch` per pixel: 1 gray, 2 gray + alpha, 3 RGB,
/// 4 RGBA), as the whole-image decoding computes it.
fn luminance<T: Sample>(raw: &[T], ch: usize, full: Option<T>, scale: [f32; 3]) -> Vec<f32> {
    convert(raw, ch, ch >= 3, full, scale, 0).0
}

/// The samples `span` (whole rows) of a decoded image as luminance; `None` for a pixel
/// type the loader does not take.
fn whole_rows(img: &DynamicImage, span: std::ops::Range<usize>, s: [f32; 3]) -> Option<Vec<f32>> {
    use DynamicImage as D;
    let (m8, m16) = (Some(u8::MAX), Some(u16::MAX));
    Some(match img {
        D::ImageLuma8(b) => luminance(&b.as_raw()[span], 1, m8, s),
        D::ImageLumaA8(b) => luminance(&b.as_raw()[span], 2, m8, s),
        D::ImageRgb8(b) => luminance(&b.as_raw()[span], 3, m8, s),
        D::ImageRgba8(b) => luminance(&b.as_raw()[span], 4, m8, s),
        D::ImageLuma16(b) => luminance(&b.as_raw()[span], 1, m16, s),
        D::ImageLumaA16(b) => luminance(&b.as_raw()[span], 2, m16, s),
        D::ImageRgb16(b) => luminance(&b.as_raw()[span], 3, m16, s),
        D::ImageRgba16(b) => luminance(&b.as_raw()[span], 4, m16, s),
        D::ImageRgb32F(b) => luminance(&b.as_raw()[span], 3, None, s),
        D::ImageRgba32F(b) => luminance(&b.as_raw()[span], 4, None, s),
        _ => return None,
    })
}
