//! Raster files (PNG, TIFF) through the `image` crate: light images, masks, normal
//! maps and pictures for looking at.
//!
//! * Reading: 8/16-bit gray, gray+alpha, RGB, RGBA and float RGB(A); values are divided
//!   by the full scale of the bit depth and RGB is turned into luminance (see the
//!   [module docs](super)).
//! * Writing (always PNG, always atomic): normal maps as 16-bit RGB with
//!   c = (n + 1)/2, gray images as auto-scaled 16-bit, masks as 8-bit 0/255, and
//!   false-colour 8-bit RGB pictures (turbo colour map) of depth or error maps.

use super::response::Response;
use super::{limits, not_found_or_io, write_atomic};
use crate::error::{Error, Result};
use crate::image::{GrayImage, Image, Mask, NormalMap};
use crate::picture::{png_bytes, Deflate};
use image::{DynamicImage, ImageFormat, ImageReader, Luma, Rgb};
use std::path::{Path, PathBuf};

/// Rec. 709 luminance weights on linear R, G, B.
pub const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// A decoded light image: luminance in [0, 1], bit depth and saturated pixels.
pub(crate) struct Decoded {
    pub image: GrayImage,
    /// 8 or 16 for integer images, 32 for float images.
    pub bit_depth: u8,
    /// True where some colour channel sits at the full scale (255 or 65535).
    pub saturated: Vec<bool>,
}

/// Read one image as luminance in [0, 1] and return it with its bit depth (8, 16, or
/// 32 for float files). `channel_scale` divides R, G, B before the conversion to
/// luminance (a gray image is divided by the luminance of the triple); pass the light
/// intensity here.
pub fn read_gray_image(path: &Path, channel_scale: Option<[f32; 3]>) -> Result<(GrayImage, u8)> {
    let d = decode_gray(path, channel_scale)?;
    Ok((d.image, d.bit_depth))
}

/// An image reader for `path` with its format guessed and the [`limits`] set.
pub(crate) fn reader(path: &Path) -> Result<ImageReader<std::io::BufReader<std::fs::File>>> {
    let fix = "check the path; images must be PNG, TIFF or JPEG files";
    let mut reader = ImageReader::open(path)
        .map_err(|e| not_found_or_io(path, e, fix))?
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))?;
    reader.limits(limits::image_limits());
    Ok(reader)
}

/// Decode an image after checking the size its header claims against the [`limits`]
/// (the header alone is read first, so a lying header costs no allocation).
pub(crate) fn open_image(path: &Path) -> Result<DynamicImage> {
    open_image_format(path).map(|(img, _)| img)
}

/// [`open_image`], with the file's format (by its content).
fn open_image_format(path: &Path) -> Result<(DynamicImage, Option<ImageFormat>)> {
    let mut probe = reader(path)?;
    let format = probe.format();
    // No size limit on the probe, so that the size it reads is reported in our words.
    let mut lenient = limits::image_limits();
    (lenient.max_image_width, lenient.max_image_height) = (None, None);
    probe.limits(lenient);
    // An unreadable header is reported by `decode` below, with the decoder's words.
    if let Ok((w, h)) = probe.into_dimensions() {
        limits::check_dimensions(path, w as u64, h as u64)?;
    }
    let img = reader(path)?.decode().map_err(|e| Error::Decode {
        path: path.to_path_buf(),
        message: format!("{e} (expected an 8/16-bit gray or RGB PNG, TIFF or JPEG image)"),
    })?;
    Ok((img, format))
}

pub(crate) fn decode_gray(path: &Path, channel_scale: Option<[f32; 3]>) -> Result<Decoded> {
    decode_gray_response(path, channel_scale, Response::Linear)
}

/// [`decode_gray`] with the values linearised by `response` (resolved for the file's
/// format: [`Response::Auto`] is sRGB for a JPEG).
pub(crate) fn decode_gray_response(
    path: &Path,
    channel_scale: Option<[f32; 3]>,
    response: Response,
) -> Result<Decoded> {
    let scale = channel_scale.unwrap_or([1.0; 3]);
    if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(Error::invalid(
            format!("{}: light intensity {scale:?}", path.display()),
            "intensities must be finite and positive",
        ));
    }
    let (img, format) = open_image_format(path)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let response = response.resolve(format);
    if response != Response::Linear {
        return finish(path, (w, h), curved(path, &img, scale, response)?);
    }
    let converted = match &img {
        DynamicImage::ImageLuma8(b) => convert(b.as_raw(), 1, false, Some(u8::MAX), scale, 8),
        DynamicImage::ImageLumaA8(b) => convert(b.as_raw(), 2, false, Some(u8::MAX), scale, 8),
        DynamicImage::ImageRgb8(b) => convert(b.as_raw(), 3, true, Some(u8::MAX), scale, 8),
        DynamicImage::ImageRgba8(b) => convert(b.as_raw(), 4, true, Some(u8::MAX), scale, 8),
        DynamicImage::ImageLuma16(b) => convert(b.as_raw(), 1, false, Some(u16::MAX), scale, 16),
        DynamicImage::ImageLumaA16(b) => convert(b.as_raw(), 2, false, Some(u16::MAX), scale, 16),
        DynamicImage::ImageRgb16(b) => convert(b.as_raw(), 3, true, Some(u16::MAX), scale, 16),
        DynamicImage::ImageRgba16(b) => convert(b.as_raw(), 4, true, Some(u16::MAX), scale, 16),
        DynamicImage::ImageRgb32F(b) => convert(b.as_raw(), 3, true, None, scale, 32),
        DynamicImage::ImageRgba32F(b) => convert(b.as_raw(), 4, true, None, scale, 32),
        other => return Err(unsupported(path, other)),
    };
    finish(path, (w, h), converted)
}

/// Luminance, saturation flags and bit depth of a decoded image.
type Converted = (Vec<f32>, Vec<bool>, u8);

fn unsupported(path: &Path, img: &DynamicImage) -> Error {
    Error::Decode {
        path: path.to_path_buf(),
        message: format!("unsupported pixel type {:?}", img.color()),
    }
}

/// Luminance, saturation flags and bit depth as a [`Decoded`], checked finite.
fn finish(path: &Path, (w, h): (usize, usize), converted: Converted) -> Result<Decoded> {
    let (data, saturated, bit_depth) = converted;
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        return Err(Error::Decode {
            path: path.to_path_buf(),
            message: format!(
                "pixel (x {}, y {}) is {} (float images must hold finite values)",
                i % w.max(1),
                i / w.max(1),
                data[i]
            ),
        });
    }
    Ok(Decoded {
        image: Image::from_vec(w, h, data)?,
        bit_depth,
        saturated,
    })
}

/// A sample type of a decoded image, with its full scale.
pub(crate) trait Sample: Copy + PartialEq {
    const FULL: f32;
    fn value(self) -> f32;
}
impl Sample for u8 {
    const FULL: f32 = 255.0;
    fn value(self) -> f32 {
        self as f32
    }
}
impl Sample for u16 {
    const FULL: f32 = 65535.0;
    fn value(self) -> f32 {
        self as f32
    }
}
impl Sample for f32 {
    const FULL: f32 = 1.0;
    fn value(self) -> f32 {
        self
    }
}

/// Interleaved samples (`channels` per pixel, colour first, alpha ignored) → luminance
/// in [0, 1] and per-pixel saturation flags.
pub(crate) fn convert<T: Sample>(
    raw: &[T],
    channels: usize,
    color: bool,
    full: Option<T>,
    scale: [f32; 3],
    bit_depth: u8,
) -> (Vec<f32>, Vec<bool>, u8) {
    let n = raw.len() / channels;
    let mut out = Vec::with_capacity(n);
    let mut sat = Vec::with_capacity(n);
    let used = if color { 3 } else { 1 };
    // Divisors rather than reciprocal weights, so that an integer sample k comes back
    // as exactly k / full (the value the writers quantised).
    let divisors: [f32; 3] = if color {
        std::array::from_fn(|i| T::FULL * scale[i])
    } else if scale[0] == scale[1] && scale[1] == scale[2] {
        [T::FULL * scale[0], 1.0, 1.0]
    } else {
        let lum = LUMA[0] * scale[0] + LUMA[1] * scale[1] + LUMA[2] * scale[2];
        [T::FULL * lum, 1.0, 1.0]
    };
    let weights = if color { LUMA } else { [1.0, 0.0, 0.0] };
    for px in raw.chunks_exact(channels) {
        let mut y = 0.0;
        for i in 0..used {
            y += weights[i] * (px[i].value() / divisors[i]);
        }
        out.push(y);
        sat.push(full.is_some_and(|f| px[..used].contains(&f)));
    }
    (out, sat, bit_depth)
}

/// Luminance of `img` with every colour sample linearised by `response` first (a
/// table per integer code), then divided by `scale`; the saturation flags are those of
/// the stored values.
fn curved(
    path: &Path,
    img: &DynamicImage,
    scale: [f32; 3],
    response: Response,
) -> Result<Converted> {
    let lut8 = || response.table(255);
    let lut16 = || response.table(65535);
    Ok(match img {
        DynamicImage::ImageLuma8(b) => convert_curve(b.as_raw(), 1, false, &lut8(), scale, 8),
        DynamicImage::ImageLumaA8(b) => convert_curve(b.as_raw(), 2, false, &lut8(), scale, 8),
        DynamicImage::ImageRgb8(b) => convert_curve(b.as_raw(), 3, true, &lut8(), scale, 8),
        DynamicImage::ImageRgba8(b) => convert_curve(b.as_raw(), 4, true, &lut8(), scale, 8),
        DynamicImage::ImageLuma16(b) => convert_curve(b.as_raw(), 1, false, &lut16(), scale, 16),
        DynamicImage::ImageLumaA16(b) => convert_curve(b.as_raw(), 2, false, &lut16(), scale, 16),
        DynamicImage::ImageRgb16(b) => convert_curve(b.as_raw(), 3, true, &lut16(), scale, 16),
        DynamicImage::ImageRgba16(b) => convert_curve(b.as_raw(), 4, true, &lut16(), scale, 16),
        DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_) => {
            // float files hold linear values already; a curve is applied as asked
            let rgb = img.to_rgb32f();
            let raw: Vec<f32> = rgb
                .as_raw()
                .iter()
                .map(|&v| response.linearize(v))
                .collect();
            convert(&raw, 3, true, None, scale, 32)
        }
        other => return Err(unsupported(path, other)),
    })
}

/// Interleaved integer samples → luminance of the linearised (`lut`) colour channels,
/// each divided by its `scale`, and saturation flags (a channel at the top code).
fn convert_curve<T: Sample + Into<u32>>(
    raw: &[T],
    channels: usize,
    color: bool,
    lut: &[f32],
    scale: [f32; 3],
    bit_depth: u8,
) -> (Vec<f32>, Vec<bool>, u8) {
    let top = (lut.len() - 1) as u32;
    let gray_scale = LUMA[0] * scale[0] + LUMA[1] * scale[1] + LUMA[2] * scale[2];
    let (weights, used) = if color {
        (std::array::from_fn(|i| LUMA[i] / scale[i]), 3)
    } else {
        ([1.0 / gray_scale, 0.0, 0.0], 1)
    };
    let mut out = Vec::with_capacity(raw.len() / channels);
    let mut sat = Vec::with_capacity(raw.len() / channels);
    for px in raw.chunks_exact(channels) {
        let mut y = 0.0;
        let mut clipped = false;
        for i in 0..used {
            let code: u32 = px[i].into();
            y += weights[i] * lut[code as usize];
            clipped |= code == top;
        }
        out.push(y);
        sat.push(clipped);
    }
    (out, sat, bit_depth)
}

/// Read a mask image (PNG/TIFF, any pixel type): a pixel is inside when any colour
/// channel is non-zero.
pub fn read_mask(path: &Path) -> Result<Mask> {
    let d = decode_gray(path, None)?;
    Ok(d.image.map(|&v| v > 0.0))
}

/// Read a mask from a `.npy` file ([`read_mask_npy`](super::read_mask_npy)) or from
/// an image ([`read_mask`]), chosen by the extension.
pub fn read_mask_any(path: &Path) -> Result<Mask> {
    let is_npy = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"));
    if is_npy {
        super::read_mask_npy(path)
    } else {
        read_mask(path)
    }
}

/// Read a normal map from a float `.npy` of shape (H, W, 3)
/// ([`read_normals_npy`](super::read_normals_npy)) or from an 8/16-bit RGB image
/// encoding c = (n + 1)/2 ([`read_normals_png`]: DiLiGenT's and BiNI's `normal_map.png`,
/// our own `normals.png`), chosen by the extension.
pub fn read_normals_any(path: &Path) -> Result<NormalMap> {
    let is_npy = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"));
    if is_npy {
        super::read_normals_npy(path)
    } else {
        read_normals_png(path)
    }
}

/// Read a normal map written by [`write_normals_png`]: n = 2c − 1, normalised; black
/// pixels (all channels 0) are unknown and come back as `[0, 0, 0]`.
pub fn read_normals_png(path: &Path) -> Result<NormalMap> {
    let img = open_image(path)?;
    if img.color().channel_count() < 3 {
        return Err(Error::Decode {
            path: path.to_path_buf(),
            message: "a gray image is not a normal map (expected RGB with c = (n + 1)/2, or a \
                      float .npy of shape (H, W, 3))"
                .into(),
        });
    }
    let img = img.into_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let data = img
        .pixels()
        .map(|p| {
            if p.0 == [0.0; 3] {
                [0.0; 3]
            } else {
                crate::image::normalize(p.0.map(|c| 2.0 * c - 1.0))
            }
        })
        .collect();
    Image::from_vec(w, h, data)
}

/// Encode a PNG from raw subpixels and write it atomically.
pub(crate) fn save_png<P>(
    path: &Path,
    width: usize,
    height: usize,
    data: Vec<P::Subpixel>,
) -> Result<()>
where
    P: image::Pixel + image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    let bytes = png_bytes::<P>(width, height, data, Deflate::Fast).map_err(|e| {
        Error::invalid(
            format!("{}: image of {width}x{height} pixels", path.display()),
            e,
        )
    })?;
    write_atomic(path, |out| {
        out.write_all(&bytes).map_err(|e| Error::io(path, e))
    })
}

fn check_mask(mask: Option<&Mask>, width: usize, height: usize, what: &str) -> Result<()> {
    match mask {
        Some(m) => m.check_size(width, height, what),
        None => Ok(()),
    }
}

fn inside(mask: Option<&Mask>, i: usize) -> bool {
    mask.is_none_or(|m| m.data[i])
}

/// Write a normal map as a 16-bit RGB PNG with c = (n + 1)/2 per channel. Pixels
/// outside `mask`, NaN or zero normals are written black (0, 0, 0).
pub fn write_normals_png(path: &Path, normals: &NormalMap, mask: Option<&Mask>) -> Result<()> {
    check_mask(
        mask,
        normals.width,
        normals.height,
        "mask of the normal PNG",
    )?;
    let mut data = Vec::with_capacity(normals.len() * 3);
    for (i, n) in normals.data.iter().enumerate() {
        let valid = inside(mask, i) && n.iter().all(|v| v.is_finite()) && *n != [0.0; 3];
        for &v in n {
            let c = if valid { (v + 1.0) * 0.5 } else { 0.0 };
            data.push(quantize(c, 65535.0) as u16);
        }
    }
    save_png::<Rgb<u16>>(path, normals.width, normals.height, data)
}

/// Round `v` in [0, 1] to an integer of full scale `full`, clamping; NaN → 0.
fn quantize(v: f32, full: f32) -> u32 {
    if v.is_nan() {
        return 0;
    }
    (v.clamp(0.0, 1.0) * full).round() as u32
}

/// Write a gray image as 16-bit PNG, mapping `lo` → 0 and `hi` → 65535 (clamped;
/// NaN → 0). With `lo = 0, hi = 1` a [0, 1] image is stored exactly to 1/65535.
pub fn write_gray_png_range(path: &Path, img: &GrayImage, lo: f32, hi: f32) -> Result<()> {
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Err(Error::invalid(
            format!("{}: value range {lo}..{hi}", path.display()),
            "the range must be finite with hi > lo",
        ));
    }
    let data = img
        .data
        .iter()
        .map(|&v| quantize((v - lo) / (hi - lo), 65535.0) as u16)
        .collect();
    save_png::<Luma<u16>>(path, img.width, img.height, data)
}

/// Write a gray image (albedo, confidence, ...) as 16-bit PNG scaled automatically:
/// min(0, smallest finite value) → 0 and the largest finite value → 65535.
pub fn write_gray_png(path: &Path, img: &GrayImage) -> Result<()> {
    let (lo, hi) = finite_range(img.data.iter().copied()).unwrap_or((0.0, 1.0));
    let lo = lo.min(0.0);
    // A constant image (lo <= 0 here): widen the range by at least 1 and by |lo|,
    // so that the range stays non-empty for huge values too.
    let hi = if hi > lo { hi } else { lo + lo.abs().max(1.0) };
    write_gray_png_range(path, img, lo, hi)
}

/// Smallest and largest finite value, if any.
fn finite_range(values: impl Iterator<Item = f32>) -> Option<(f32, f32)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// Write a mask as an 8-bit gray PNG (255 inside, 0 outside).
pub fn write_mask_png(path: &Path, mask: &Mask) -> Result<()> {
    let data = mask
        .data
        .iter()
        .map(|&b| if b { 255u8 } else { 0 })
        .collect();
    save_png::<Luma<u8>>(path, mask.width, mask.height, data)
}

/// Turbo colour map (Mikhailov 2019, polynomial fit) of t in [0, 1] → 8-bit RGB.
pub fn turbo(t: f32) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0) as f64;
    let poly = |c: [f64; 6]| c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))));
    let r = poly([
        0.13572138,
        4.6153926,
        -42.66032258,
        132.13108234,
        -152.94239396,
        59.28637943,
    ]);
    let g = poly([
        0.09140261,
        2.19418839,
        4.84296658,
        -14.18503333,
        4.27729857,
        2.82956604,
    ]);
    let b = poly([
        0.1066733,
        12.64194608,
        -60.58204836,
        110.36276771,
        -89.90310912,
        27.34824973,
    ]);
    [r, g, b].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
}

/// Write a false-colour picture (turbo map, 8-bit RGB) of `img`: `range` (lo, hi) maps
/// to the ends of the colour map, by default the finite values inside the mask.
/// NaN and pixels outside `mask` are black.
pub fn write_colormap_png(
    path: &Path,
    img: &GrayImage,
    mask: Option<&Mask>,
    range: Option<(f32, f32)>,
) -> Result<()> {
    check_mask(mask, img.width, img.height, "mask of the colour picture")?;
    let inside_values = img
        .data
        .iter()
        .enumerate()
        .filter(|&(i, _)| inside(mask, i))
        .map(|(_, &v)| v);
    let (lo, hi) = range
        .or_else(|| finite_range(inside_values))
        .unwrap_or((0.0, 1.0));
    let span = if hi > lo { hi - lo } else { 1.0 };
    let data = colour_rows(img, mask, |v| turbo_table((v - lo) / span));
    save_png::<Rgb<u8>>(path, img.width, img.height, data)
}

/// RGB bytes of `img` by `colour`, rows in parallel; NaN and pixels outside `mask` black.
fn colour_rows(
    img: &GrayImage,
    mask: Option<&Mask>,
    colour: impl Fn(f32) -> [u8; 3] + Sync,
) -> Vec<u8> {
    use rayon::prelude::*;
    let row = img.width * 3;
    let mut data = vec![0u8; img.len() * 3];
    data.par_chunks_mut(row.max(1))
        .enumerate()
        .for_each(|(r, out)| {
            for (c, px) in out.chunks_exact_mut(3).enumerate() {
                let i = r * img.width + c;
                let v = img.data[i];
                if inside(mask, i) && v.is_finite() {
                    px.copy_from_slice(&colour(v));
                }
            }
        });
    data
}

/// Entries of [`turbo_table`]: 4096 steps of t, finer than the 256 levels of a colour.
const TURBO_STEPS: usize = 4096;

/// [`turbo`] read from a table of [`TURBO_STEPS`] entries (t rounded to the nearest
/// step: at most one level off the exact map), so that a large picture costs no
/// polynomial and no rounding call per pixel.
fn turbo_table(t: f32) -> [u8; 3] {
    static TABLE: std::sync::OnceLock<Vec<[u8; 3]>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        (0..TURBO_STEPS)
            .map(|i| turbo(i as f32 / (TURBO_STEPS - 1) as f32))
            .collect()
    });
    // t in [0, 1] after the clamp (NaN gives 0): `as` truncates, + 0.5 rounds
    let i = (t.clamp(0.0, 1.0) * (TURBO_STEPS - 1) as f32 + 0.5) as usize;
    table[i.min(TURBO_STEPS - 1)]
}

/// Write a false-colour picture of a depth map (far = blue, near = red), scaled to
/// the finite depths inside the mask; NaN and outside are black. For looking at only:
/// keep the `.npy` for numbers.
pub fn write_depth_png(path: &Path, depth: &GrayImage, mask: Option<&Mask>) -> Result<()> {
    write_colormap_png(path, depth, mask, None)
}

/// The format of an image file, by its first bytes (`None` when unreadable).
pub(crate) fn format_of(path: &Path) -> Option<image::ImageFormat> {
    image::ImageReader::open(path)
        .ok()?
        .with_guessed_format()
        .ok()?
        .format()
}

/// Luminance of an RGB triple (Rec. 709 weights [`LUMA`]).
pub(crate) fn luminance(t: [f32; 3]) -> f32 {
    LUMA[0] * t[0] + LUMA[1] * t[1] + LUMA[2] * t[2]
}

/// An image must share the size and bit depth of the first.
pub(crate) fn check_consistent(
    first: (&PathBuf, &Decoded),
    this: (&PathBuf, &Decoded),
) -> Result<()> {
    let ((f0, first), (f, d)) = (first, this);
    if !d.image.same_size(&first.image) {
        return Err(Error::SizeMismatch {
            what: format!("{} (first image {})", f.display(), f0.display()),
            expected_w: first.image.width,
            expected_h: first.image.height,
            found_w: d.image.width,
            found_h: d.image.height,
            fix: "all light images must have the same size".into(),
        });
    }
    if d.bit_depth != first.bit_depth {
        return Err(Error::invalid(
            format!(
                "{}: {}-bit image, but {} is {}-bit",
                f.display(),
                d.bit_depth,
                f0.display(),
                first.bit_depth
            ),
            "all light images must have the same bit depth",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_turbo_table_is_within_one_level_of_the_map() {
        for i in 0..=100_000 {
            let t = i as f32 / 100_000.0;
            let (a, b) = (turbo(t), turbo_table(t));
            for (x, y) in a.iter().zip(&b) {
                assert!(x.abs_diff(*y) <= 1, "t {t}: {a:?} vs {b:?}");
            }
        }
        assert_eq!(turbo_table(0.0), turbo(0.0));
        assert_eq!(turbo_table(1.0), turbo(1.0));
        assert_eq!(turbo_table(-3.0), turbo(0.0));
        assert_eq!(turbo_table(f32::NAN), turbo(0.0));
    }
}
