//! Pictures for people: maps turned into 8-bit RGB, and the crate's one PNG encoder
//! (`png_bytes`: the report's pictures, the sphere overlay, the plots and the PNG
//! files of [`crate::io`]).
//!
//! * normals: c = (n + 1)/2 per channel (the README's convention), unknown pixels grey;
//! * scalar maps (albedo, confidence, errors): linear grey or a colour map between two
//!   stated limits, pixels outside the mask (or NaN) in the background colour;
//! * depth: false colour (viridis) from the 1st to the 99th percentile of the finite values.
//!
//! Large maps are shrunk by box averaging so that a report stays a few megabytes.

use crate::error::{Error, Result};
use crate::image::{GrayImage, Image, ImageStack, Mask, NormalMap};

/// Colour of pixels outside the mask / without a value.
pub const BACKGROUND: [u8; 3] = [40, 44, 52];

/// An 8-bit RGB raster, row-major.
pub type Rgb = Image<[u8; 3]>;

/// Colour maps for scalar images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorMap {
    /// Black → white.
    Gray,
    /// Perceptually uniform dark blue → green → yellow (matplotlib's viridis).
    Viridis,
    /// Black → red → yellow → white (matplotlib's inferno), for errors.
    Inferno,
    /// Blue → light grey → red (Moreland's diverging cool–warm), for signed maps with 0
    /// in the middle (curvature).
    CoolWarm,
}

const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 81, 139],
    [44, 113, 142],
    [33, 144, 141],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];

const INFERNO: [[u8; 3]; 9] = [
    [0, 0, 4],
    [31, 12, 72],
    [85, 15, 109],
    [136, 34, 106],
    [186, 54, 85],
    [227, 89, 51],
    [249, 140, 10],
    [249, 201, 50],
    [252, 255, 164],
];

const COOL_WARM: [[u8; 3]; 9] = [
    [59, 76, 192],
    [85, 114, 226],
    [124, 159, 249],
    [170, 199, 253],
    [221, 221, 221],
    [246, 183, 156],
    [241, 134, 104],
    [213, 79, 64],
    [180, 4, 38],
];

impl ColorMap {
    /// Colour of `t` in [0, 1] (clamped).
    pub fn color(self, t: f32) -> [u8; 3] {
        let t = if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let stops = match self {
            ColorMap::Gray => {
                let g = (t * 255.0).round() as u8;
                return [g, g, g];
            }
            ColorMap::Viridis => &VIRIDIS,
            ColorMap::Inferno => &INFERNO,
            ColorMap::CoolWarm => &COOL_WARM,
        };
        let x = t * (stops.len() - 1) as f32;
        let i = (x.floor() as usize).min(stops.len() - 2);
        let f = x - i as f32;
        let mut out = [0u8; 3];
        for (ch, o) in out.iter_mut().enumerate() {
            let a = f32::from(stops[i][ch]);
            let b = f32::from(stops[i + 1][ch]);
            *o = (a + (b - a) * f).round() as u8;
        }
        out
    }
}

/// How hard [`png_bytes`] compresses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Deflate {
    /// The encoder's default level: pictures embedded in a report, overlays, plots.
    Default,
    /// Fast deflate: image files written by [`crate::io`] (previews of 2048² depth maps
    /// were dominated by zlib's default level: files ~10-20% larger, written several
    /// times faster).
    Fast,
}

/// Encode `data`, row-major subpixels of pixel type `P`, as a `width` × `height` PNG
/// (adaptive filtering). Errors: the reason, for the caller to name the picture.
pub(crate) fn png_bytes<P>(
    width: usize,
    height: usize,
    data: Vec<P::Subpixel>,
    deflate: Deflate,
) -> std::result::Result<Vec<u8>, String>
where
    P: image::Pixel + image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err("PNG images must be smaller than 2^32 pixels on each side".into());
    };
    if w == 0 || h == 0 {
        return Err("a PNG needs at least one pixel; nothing to write".into());
    }
    let buf = image::ImageBuffer::<P, Vec<P::Subpixel>>::from_raw(w, h, data)
        .ok_or_else(|| format!("{width}x{height} pixels need more data than given"))?;
    let mut out = Vec::new();
    let encoder = match deflate {
        Deflate::Default => PngEncoder::new(&mut out),
        Deflate::Fast => {
            PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
        }
    };
    buf.write_with_encoder(encoder)
        .map_err(|e| format!("PNG encoding failed: {e}"))?;
    Ok(out)
}

/// Encode an RGB raster as PNG bytes.
pub fn encode_png(img: &Rgb) -> Result<Vec<u8>> {
    if img.width == 0 || img.height == 0 {
        return Err(Error::invalid(
            "report picture of size 0",
            "give the report images with at least one pixel",
        ));
    }
    let flat: Vec<u8> = img.data.iter().flatten().copied().collect();
    png_bytes::<image::Rgb<u8>>(img.width, img.height, flat, Deflate::Default)
        .map_err(|e| Error::invalid("report picture", e))
}

/// The `q`-quantile (0..1) of the finite values, or `None` when there is none.
pub fn quantile(values: impl Iterator<Item = f32>, q: f32) -> Option<f32> {
    let mut v: Vec<f32> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    let k = ((v.len() - 1) as f32 * q.clamp(0.0, 1.0)).round() as usize;
    let (_, x, _) = v.select_nth_unstable_by(k, f32::total_cmp);
    Some(*x)
}

fn inside(mask: Option<&Mask>, i: usize) -> bool {
    mask.is_none_or(|m| m.data.get(i).copied().unwrap_or(false))
}

/// Normal map as colours c = (n + 1)/2; pixels outside the mask or without a unit normal grey.
pub fn normals_rgb(n: &NormalMap, mask: Option<&Mask>) -> Rgb {
    let data = n
        .data
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let len2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            if !inside(mask, i) || !len2.is_finite() || len2 < 0.25 {
                return BACKGROUND;
            }
            v.map(|x| (((x + 1.0) * 0.5).clamp(0.0, 1.0) * 255.0).round() as u8)
        })
        .collect();
    Image {
        width: n.width,
        height: n.height,
        data,
    }
}

/// A scalar map through `cmap` with `lo` → 0 and `hi` → 1; NaN and outside-mask pixels get
/// the background colour.
pub fn scalar_rgb(img: &GrayImage, mask: Option<&Mask>, lo: f32, hi: f32, cmap: ColorMap) -> Rgb {
    let span = if hi > lo { hi - lo } else { 1.0 };
    let data = img
        .data
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            if !inside(mask, i) || !v.is_finite() {
                BACKGROUND
            } else {
                cmap.color((v - lo) / span)
            }
        })
        .collect();
    Image {
        width: img.width,
        height: img.height,
        data,
    }
}

/// Robust display range of a scalar map: 1st and 99th percentile of its finite values
/// inside the mask (`(0, 1)` when there are none).
pub fn robust_range(img: &GrayImage, mask: Option<&Mask>) -> (f32, f32) {
    let vals = || {
        img.data
            .iter()
            .enumerate()
            .filter(|(i, _)| inside(mask, *i))
            .map(|(_, v)| *v)
    };
    let lo = quantile(vals(), 0.01);
    let hi = quantile(vals(), 0.99);
    match (lo, hi) {
        (Some(lo), Some(hi)) if hi > lo => (lo, hi),
        (Some(lo), Some(_)) => (lo, lo + 1.0),
        _ => (0.0, 1.0),
    }
}

/// Shrink by an integer factor (box average) so that neither side exceeds `max_side`.
pub fn shrink(img: &Rgb, max_side: usize) -> Rgb {
    let f = img.width.max(img.height).div_ceil(max_side.max(1)).max(1);
    if f == 1 {
        return img.clone();
    }
    let (w, h) = (img.width.div_ceil(f), img.height.div_ceil(f));
    Image::from_fn(w, h, |r, c| {
        let mut acc = [0u32; 3];
        let mut n = 0u32;
        for rr in r * f..((r + 1) * f).min(img.height) {
            for cc in c * f..((c + 1) * f).min(img.width) {
                let p = img.get(rr, cc);
                for k in 0..3 {
                    acc[k] += u32::from(p[k]);
                }
                n += 1;
            }
        }
        acc.map(|a| (a / n.max(1)) as u8)
    })
}

/// The K input images as grey thumbnails of height at most `max_side`, all on one scale
/// (0 → black, the 99.5th percentile of the whole stack → white, with a display gamma 1/2.2).
pub fn stack_thumbnails(stack: &ImageStack, max_side: usize) -> Vec<Rgb> {
    let white = quantile(stack.data.iter().step_by(7).copied(), 0.995)
        .filter(|w| *w > 0.0)
        .unwrap_or(1.0);
    (0..stack.k)
        .map(|i| {
            let img = stack.image(i);
            let rgb = img.map(|&v| {
                let t = (v / white).clamp(0.0, 1.0).powf(1.0 / 2.2);
                ColorMap::Gray.color(if t.is_finite() { t } else { 0.0 })
            });
            shrink(&rgb, max_side)
        })
        .collect()
}

/// A horizontal colour bar (for legends), `width` × `height` pixels.
pub fn colorbar(cmap: ColorMap, width: usize, height: usize) -> Rgb {
    let w = width.max(2);
    Image::from_fn(w, height.max(1), |_, c| {
        cmap.color(c as f32 / (w - 1) as f32)
    })
}

/// White level of an albedo picture: its 99th percentile inside the mask (highlights
/// above it saturate), at least 1e-6.
pub fn albedo_white(albedo: &GrayImage, mask: Option<&Mask>) -> f32 {
    robust_range(albedo, mask).1.max(1e-6)
}

/// The albedo picture of the report and of `albedo.png`: grey, black = 0, white =
/// [`albedo_white`]; outside the mask [`BACKGROUND`]. Returns the raster and the white level.
pub fn albedo_picture(albedo: &GrayImage, mask: Option<&Mask>) -> (Rgb, f32) {
    let hi = albedo_white(albedo, mask);
    (scalar_rgb(albedo, mask, 0.0, hi, ColorMap::Gray), hi)
}

/// The depth picture of the report and of `depth.png`: viridis from the 1st (far, dark
/// purple) to the 99th percentile (near, yellow) of the finite depths inside the mask;
/// outside and NaN [`BACKGROUND`]. Returns the raster and the depth range (lo, hi) in pixels.
pub fn depth_picture(depth: &GrayImage, mask: Option<&Mask>) -> (Rgb, (f32, f32)) {
    let (lo, hi) = robust_range(depth, mask);
    (scalar_rgb(depth, mask, lo, hi, ColorMap::Viridis), (lo, hi))
}

/// A signed map (curvature) in cool–warm, symmetric about 0: −`limit` blue, 0 grey,
/// +`limit` red, beyond saturated; outside and NaN [`BACKGROUND`].
pub fn signed_picture(img: &GrayImage, mask: Option<&Mask>, limit: f32) -> Rgb {
    let limit = if limit > 0.0 && limit.is_finite() {
        limit
    } else {
        1.0
    };
    scalar_rgb(img, mask, -limit, limit, ColorMap::CoolWarm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colormap_ends_are_the_published_colours() {
        assert_eq!(ColorMap::Viridis.color(0.0), [68, 1, 84]);
        assert_eq!(ColorMap::Viridis.color(1.0), [253, 231, 37]);
        assert_eq!(ColorMap::Inferno.color(2.0), [252, 255, 164]);
        assert_eq!(ColorMap::Gray.color(0.5), [128, 128, 128]);
        assert_eq!(ColorMap::CoolWarm.color(0.5), [221, 221, 221]);
    }

    #[test]
    fn normal_colours_follow_the_readme_encoding() {
        let n = Image::from_vec(2, 1, vec![[0.0, 0.0, 1.0], [f32::NAN; 3]]).unwrap();
        let rgb = normals_rgb(&n, None);
        assert_eq!(rgb.data[0], [128, 128, 255]);
        assert_eq!(rgb.data[1], BACKGROUND);
    }

    #[test]
    fn shrink_averages_boxes() {
        let img = Image::from_fn(4, 2, |_, c| {
            if c % 2 == 0 {
                [0, 0, 0]
            } else {
                [200, 100, 50]
            }
        });
        let s = shrink(&img, 2);
        assert_eq!((s.width, s.height), (2, 1));
        assert_eq!(s.data[0], [100, 50, 25]);
    }

    #[test]
    fn png_round_trips() {
        let img = Image::from_fn(3, 2, |r, c| [r as u8 * 50, c as u8 * 70, 9]);
        let bytes = encode_png(&img).unwrap();
        let back = image::load_from_memory(&bytes).unwrap().to_rgb8();
        assert_eq!(back.get_pixel(2, 1).0, [50, 140, 9]);
    }
}
