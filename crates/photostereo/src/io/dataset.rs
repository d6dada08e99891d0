//! Loading and writing whole datasets in the DiLiGenT layout (see the
//! [module docs](super) for the files and the rules).

use super::bands::{probe_images, BandReader, StackHeader};
use super::hdr;
use super::lights_file::{self, LightFile};
use super::raster::{
    check_consistent, decode_gray_response, format_of, luminance, read_mask_any, save_png,
    write_mask_png, Decoded,
};
use super::response::Response;
use super::text_files::{
    natural_cmp, read_filenames, read_intensities, read_lights, write_intensities,
    write_light_directions,
};
use super::write_text;
use crate::error::{Error, Result};
use crate::image::{ImageStack, Lights, Mask};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Options of [`load_dataset`].
#[derive(Clone, Debug)]
pub struct LoadOptions {
    /// Fail when `light_directions.txt` is missing (default `false`: `lights` is `None`).
    pub require_lights: bool,
    /// Fail when there is no mask (default `false`: `mask` is `None`).
    pub require_mask: bool,
    /// Divide each image by its `light_intensities.txt` entry (default `true`). When
    /// `false` the images are left as they are and the luminance of each intensity goes
    /// to [`Lights::intensities`] instead.
    pub apply_intensities: bool,
    /// Read the mask from this file (PNG/TIFF or `.npy`) instead of `dir/mask.png`.
    pub mask_path: Option<PathBuf>,
    /// The response curve of the light images (default [`Response::Auto`]: sRGB for
    /// JPEG files, linear for PNG/TIFF); values are linearised on reading.
    pub response: Response,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            require_lights: false,
            require_mask: false,
            apply_intensities: true,
            mask_path: None,
            response: Response::Auto,
        }
    }
}

/// A loaded dataset.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// The K images as luminance in [0, 1] (already divided by the light intensities
    /// when [`LoadOptions::apply_intensities`]); `names` holds the file names.
    pub stack: ImageStack,
    /// Light directions (unit) from `light_directions.txt`, if present. Intensities are
    /// 1 when they were applied to the images, else the luminance of each entry of
    /// `light_intensities.txt` (1 without the file).
    pub lights: Option<Lights>,
    /// The raw `light_intensities.txt` entries as RGB triples, if present.
    pub raw_intensities: Option<Vec<[f32; 3]>>,
    /// Object mask, if present (checked: same size as the images, not empty).
    pub mask: Option<Mask>,
    /// Number of (pixel, image) samples inside the mask (everywhere without a mask)
    /// where some channel sits at full scale (255 or 65535): clipped highlights.
    pub saturated: usize,
    /// The dataset directory.
    pub dir: PathBuf,
    /// Bit depth of the images: 8, 16 (or 32 for float TIFF).
    pub bit_depth: u8,
    /// The response curve the images were linearised with ([`LoadOptions::response`]
    /// resolved for the first image's format: never [`Response::Auto`]).
    pub response: Response,
}

/// Load a dataset directory (DiLiGenT layout, see the [module docs](super)).
///
/// Errors name the file and the problem: missing directory, no light image, an
/// unreadable or non-image file, images of different sizes or bit depths, a count of
/// light directions or intensities different from the number of images, a bad line in a
/// text file, a mask of the wrong size or an empty mask.
pub fn load_dataset(dir: &Path, opts: &LoadOptions) -> Result<Dataset> {
    if !dir.is_dir() {
        return Err(Error::NotFound {
            path: dir.to_path_buf(),
            fix: "give the directory that holds the light images".into(),
        });
    }
    let response = opts.response.check()?;
    let other = other_light_file(dir)?;
    let files = list_images(dir, other.as_ref())?;
    // several exposures per light: each line of filenames.txt names them
    let brackets = hdr::brackets(dir, &files)?;
    let files: Vec<PathBuf> = match &brackets {
        Some(b) => b.iter().map(|(f, _)| f[0].clone()).collect(),
        None => files,
    };
    let k = files.len();
    let (lights, raw_intensities) = read_light_files(dir, &files, other.as_ref(), opts)?;
    let scales: Vec<Option<[f32; 3]>> = (0..k)
        .map(|i| match &raw_intensities {
            Some(v) if opts.apply_intensities => Some(v[i]),
            _ => None,
        })
        .collect();
    // several exposures per light are merged into one image (io::hdr)
    let decode = |i: usize| match &brackets {
        Some(b) => hdr::decode_bracket(&b[i].0, &b[i].1, scales[i], response),
        None => decode_gray_response(&files[i], scales[i], response),
    };
    let (mut stack, mask, saturated, bit_depth) = decode_stack(dir, &files, opts, &decode)?;
    stack.names = file_names(&files);
    Ok(Dataset {
        stack,
        lights,
        raw_intensities,
        mask,
        saturated,
        dir: dir.to_path_buf(),
        bit_depth,
        response: response.resolve(format_of(&files[0])),
    })
}

/// A dataset opened for reading by row bands ([`open_dataset_bands`]): everything but
/// the pixels of the light images, which [`DatasetBands::reader`] reads.
#[derive(Clone, Debug)]
pub struct DatasetBands {
    /// The light images' headers.
    pub header: StackHeader,
    /// The intensity that divides each image's R, G, B (`None` = 1).
    pub scales: Vec<Option<[f32; 3]>>,
    /// As [`Dataset::lights`].
    pub lights: Option<Lights>,
    /// As [`Dataset::raw_intensities`].
    pub raw_intensities: Option<Vec<[f32; 3]>>,
    /// As [`Dataset::mask`].
    pub mask: Option<Mask>,
    /// The dataset directory.
    pub dir: PathBuf,
}

/// Open a dataset directory (DiLiGenT layout) for reading by row bands: the image
/// headers, the text files and the mask are read and checked as [`load_dataset`] checks
/// them; the light images' pixels are left for [`DatasetBands::reader`].
pub fn open_dataset_bands(dir: &Path, opts: &LoadOptions) -> Result<DatasetBands> {
    if !dir.is_dir() {
        return Err(Error::NotFound {
            path: dir.to_path_buf(),
            fix: "give the directory that holds the light images".into(),
        });
    }
    let other = other_light_file(dir)?;
    let files = list_images(dir, other.as_ref())?;
    let k = files.len();
    let (lights, raw_intensities) = read_light_files(dir, &files, other.as_ref(), opts)?;
    check_banded(dir, &files[0], opts.response)?;
    let header = probe_images(&files)?;
    let mask = load_mask(dir, opts, header.width, header.height)?;
    let scales: Vec<Option<[f32; 3]>> = (0..k)
        .map(|i| match &raw_intensities {
            Some(v) if opts.apply_intensities => Some(v[i]),
            _ => None,
        })
        .collect();
    Ok(DatasetBands {
        header,
        scales,
        lights,
        raw_intensities,
        mask,
        dir: dir.to_path_buf(),
    })
}

/// Whether [`open_dataset_bands`] reads `dir` (one linear image per light, listable).
pub fn readable_by_bands(dir: &Path, response: Response) -> bool {
    let files = other_light_file(dir).and_then(|o| list_images(dir, o.as_ref()));
    matches!(files, Ok(f) if f.first().is_some_and(|p| check_banded(dir, p, response).is_ok()))
}

/// Band-wise reading takes linear single-exposure images: refuse a bracketed dataset
/// ([`hdr`]) or images with a non-linear response (a JPEG read as sRGB).
fn check_banded(dir: &Path, first: &Path, response: Response) -> Result<()> {
    if dir.join("exposure_times.txt").exists() {
        return Err(Error::invalid(
            format!(
                "{}: several exposures per light (exposure_times.txt)",
                dir.display()
            ),
            "read by row bands needs one linear image per light: load the whole dataset \
             (the exposures are merged on loading) or merge them beforehand",
        ));
    }
    let curve = response.check()?.resolve(format_of(first));
    if curve != Response::Linear {
        return Err(Error::invalid(
            format!("{}: images with a {curve} response", first.display()),
            "read by row bands needs linear images (PNG/TIFF): load the whole dataset, \
             which linearises them, or convert them to 16-bit linear PNG",
        ));
    }
    Ok(())
}

impl DatasetBands {
    /// A reader of the light images' rows from the top (already divided by the light
    /// intensities when [`LoadOptions::apply_intensities`]); each pass over the images
    /// opens one.
    pub fn reader(&self) -> Result<BandReader> {
        BandReader::open(self.header.clone(), &self.scales)
    }
}

/// A decoded stack: the stack, its mask, the saturated samples and the bit depth.
type DecodedStack = (ImageStack, Option<Mask>, usize, u8);

/// Decode `files` into one pixel-major stack. The images are decoded in parallel a few
/// at a time; each batch is checked against the first image, interleaved into the
/// stack and dropped at once, so the peak is the stack plus one batch of decoded images
/// (decoding all of them before interleaving held the stack more than twice over).
/// Errors come in the order they always did: decoding, then consistency, then the mask.
fn decode_stack(
    dir: &Path,
    files: &[PathBuf],
    opts: &LoadOptions,
    decode: &(dyn Fn(usize) -> Result<Decoded> + Sync),
) -> Result<DecodedStack> {
    let first = decode(0)?;
    let (w, h, k) = (first.image.width, first.image.height, files.len());
    let bit_depth = first.bit_depth;
    // a bad mask is reported after the images, as when the images were decoded first
    let mask = load_mask(dir, opts, w, h);
    let in_mask = mask.as_ref().ok().and_then(|m| m.as_ref());
    let mut stack = ImageStack::zeros(w, h, k);
    let mut saturated = count_saturated(&first, in_mask);
    interleave(&mut stack, 0, &first.image);
    let batch = rayon::current_num_threads().clamp(1, 8);
    for start in (1..k).step_by(batch) {
        let end = (start + batch).min(k);
        let decoded: Vec<Decoded> = (start..end)
            .into_par_iter()
            .map(decode)
            .collect::<Result<_>>()?;
        for (d, i) in decoded.iter().zip(start..end) {
            check_consistent((&files[0], &first), (&files[i], d))?;
            saturated += count_saturated(d, in_mask);
            interleave(&mut stack, i, &d.image);
        }
    }
    Ok((stack, mask?, saturated, bit_depth))
}

/// Write `image` as image `i` of the pixel-major `stack`.
fn interleave(stack: &mut ImageStack, i: usize, image: &crate::image::GrayImage) {
    let k = stack.k;
    for (px, v) in stack.data.chunks_exact_mut(k).zip(&image.data) {
        px[i] = *v;
    }
}

/// The lights and the raw intensity triples of a dataset, each if present.
type LightFiles = (Option<Lights>, Option<Vec<[f32; 3]>>);

/// The file names (last components) of `files`.
fn file_names(files: &[PathBuf]) -> Vec<String> {
    files
        .iter()
        .map(|f| {
            f.file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect()
}

/// The light file of another tool (`.lp`, `lights.json`) of `dir`, read, when the
/// dataset has no `light_directions.txt` ([`lights_file::find_light_file`]).
fn other_light_file(dir: &Path) -> Result<Option<(PathBuf, LightFile)>> {
    if dir.join("light_directions.txt").exists() {
        return Ok(None);
    }
    match lights_file::find_light_file(dir)? {
        Some(p) => Ok(Some((p.clone(), lights_file::read_light_file(&p)?))),
        None => Ok(None),
    }
}

/// `light_directions.txt` (else the light file of another tool, `other`) and
/// `light_intensities.txt` (else the intensities of `other`) of `dir`, checked against
/// the images `files`. The lights' intensities are 1 when the intensities are applied
/// to the images, else the luminance of each entry.
fn read_light_files(
    dir: &Path,
    files: &[PathBuf],
    other: Option<&(PathBuf, LightFile)>,
    opts: &LoadOptions,
) -> Result<LightFiles> {
    let k = files.len();
    let mut raw = optional(dir.join("light_intensities.txt"), |p| {
        let v = read_intensities(p)?;
        check_count(p, k, v.len(), "one intensity line per image")?;
        Ok(v)
    })?;
    let mut lights = optional(dir.join("light_directions.txt"), |p| {
        let l = read_lights(p)?;
        check_count(p, k, l.len(), "one direction line per image")?;
        Ok(l)
    })?;
    if let Some((path, file)) = other {
        let names = file_names(files);
        // an .lp is matched by file name (it may list more images than filenames.txt)
        let l = match &file.names {
            Some(lp) => lights_file::reorder(path, &file.lights, lp, &names)?,
            None => file.lights.clone(),
        };
        check_count(path, k, l.len(), "one light per image, in image order")?;
        lights = Some(l);
        if raw.is_none() {
            raw = file.intensities.clone();
        }
    }
    if let (Some(l), Some(v), false) = (lights.as_mut(), &raw, opts.apply_intensities) {
        l.intensities = v.iter().map(|t| luminance(*t)).collect();
    }
    if opts.require_lights && lights.is_none() {
        return Err(Error::NotFound {
            path: dir.join("light_directions.txt"),
            fix: "this method needs the light directions: calibrate them first".into(),
        });
    }
    Ok((lights, raw))
}

/// Run `read` on `path` when the file exists.
fn optional<T>(path: PathBuf, read: impl FnOnce(&Path) -> Result<T>) -> Result<Option<T>> {
    if path.exists() {
        read(&path).map(Some)
    } else {
        Ok(None)
    }
}

fn check_count(path: &Path, expected: usize, found: usize, fix: &str) -> Result<()> {
    if expected != found {
        return Err(Error::LightCount {
            what: path.display().to_string(),
            expected,
            found,
            fix: format!("{fix} ({expected} images)"),
        });
    }
    Ok(())
}

fn load_mask(dir: &Path, opts: &LoadOptions, w: usize, h: usize) -> Result<Option<Mask>> {
    let path = opts
        .mask_path
        .clone()
        .unwrap_or_else(|| dir.join("mask.png"));
    if !path.exists() {
        if opts.require_mask || opts.mask_path.is_some() {
            return Err(Error::NotFound {
                path,
                fix: "give a mask image (non-zero = object) of the size of the images".into(),
            });
        }
        return Ok(None);
    }
    let mask = read_mask_any(&path)?;
    let what = path.display().to_string();
    mask.check_size(w, h, &what)?;
    mask.check_not_empty(&what)?;
    Ok(Some(mask))
}

fn count_saturated(d: &Decoded, mask: Option<&Mask>) -> usize {
    d.saturated
        .iter()
        .enumerate()
        .filter(|&(i, &s)| s && mask.is_none_or(|m| m.data[i]))
        .count()
}

/// True when a file name may be a light image: a PNG/TIFF/JPEG extension, and a stem
/// (lower case) that neither contains `mask`, nor ends in `_gt`, nor starts with
/// `normal`, `depth`, `albedo`, `error`, `overlay` or `preview`.
pub fn is_light_image_name(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    let Some((stem, ext)) = lower.rsplit_once('.') else {
        return false;
    };
    let image_ext = matches!(ext, "png" | "tif" | "tiff" | "jpg" | "jpeg");
    let excluded = stem.contains("mask")
        || stem.ends_with("_gt")
        || ["normal", "depth", "albedo", "error", "overlay", "preview"]
            .iter()
            .any(|p| stem.starts_with(p));
    image_ext && !excluded && !stem.is_empty()
}

/// The light images of `dir`: from `filenames.txt` if present, else those an `.lp`
/// light file names (`other`), else by name.
fn list_images(dir: &Path, other: Option<&(PathBuf, LightFile)>) -> Result<Vec<PathBuf>> {
    let list = dir.join("filenames.txt");
    let lp_names = other.and_then(|(p, f)| f.names.as_ref().map(|n| (p, n)));
    let files: Vec<PathBuf> = if list.exists() {
        read_filenames(&list)?
            .into_iter()
            .map(|n| dir.join(n))
            .collect()
    } else if let Some((lp, names)) = lp_names {
        lp_images(dir, lp, names)?
    } else {
        let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
        let mut names = Vec::new();
        for entry in entries {
            let entry = entry.map_err(|e| Error::io(dir, e))?;
            let name = entry.file_name().to_string_lossy().into_owned();
            if is_light_image_name(&name) && entry.path().is_file() {
                names.push(name);
            }
        }
        names.sort_by(|a, b| natural_cmp(a, b));
        names.into_iter().map(|n| dir.join(n)).collect()
    };
    if files.is_empty() {
        return Err(Error::invalid(
            format!("{}: no light images", dir.display()),
            "put the images (PNG/TIFF/JPEG, e.g. 001.png ...) there or list them in filenames.txt",
        ));
    }
    Ok(files)
}

/// The images an `.lp` file `lp` names, in `dir` (matched by file name): each must exist.
fn lp_images(dir: &Path, lp: &Path, names: &[String]) -> Result<Vec<PathBuf>> {
    names
        .iter()
        .map(|n| {
            let p = dir.join(n);
            if p.is_file() {
                Ok(p)
            } else {
                Err(Error::NotFound {
                    path: p,
                    fix: format!(
                        "{} names this image: put it in {} (images are matched by file name)",
                        lp.display(),
                        dir.display()
                    ),
                })
            }
        })
        .collect()
}

/// Write a dataset directory that [`load_dataset`] reads back: `001.png` ... (gray,
/// `bit_depth` 8 or 16, values in [0, 1] clamped and rounded to the bit depth),
/// `filenames.txt`, `light_directions.txt`, `light_intensities.txt` and, with a mask,
/// `mask.png`. Every file is written atomically.
pub fn write_dataset(
    dir: &Path,
    stack: &ImageStack,
    lights: &Lights,
    mask: Option<&Mask>,
    bit_depth: u8,
) -> Result<()> {
    if bit_depth != 8 && bit_depth != 16 {
        return Err(Error::invalid(
            format!("bit depth {bit_depth}"),
            "write 8- or 16-bit images",
        ));
    }
    check_count(
        Path::new("light directions"),
        stack.k,
        lights.len(),
        "one per image",
    )?;
    check_count(
        Path::new("light intensities"),
        stack.k,
        lights.intensities.len(),
        "one per image",
    )?;
    if let Some(m) = mask {
        m.check_size(stack.width, stack.height, "mask of the dataset")?;
    }
    super::create_dir_all(dir)?;
    let digits = stack.k.to_string().len().max(3);
    let names: Vec<String> = (1..=stack.k).map(|i| format!("{i:0digits$}.png")).collect();
    (0..stack.k)
        .into_par_iter()
        .try_for_each(|i| write_light_image(&dir.join(&names[i]), &stack.image(i), bit_depth))?;
    write_text(&dir.join("filenames.txt"), &(names.join("\n") + "\n"))?;
    write_light_directions(&dir.join("light_directions.txt"), lights)?;
    write_intensities(&dir.join("light_intensities.txt"), lights)?;
    if let Some(m) = mask {
        write_mask_png(&dir.join("mask.png"), m)?;
    }
    Ok(())
}

fn write_light_image(path: &Path, img: &crate::image::GrayImage, bit_depth: u8) -> Result<()> {
    if bit_depth == 16 {
        return super::write_gray_png_range(path, img, 0.0, 1.0);
    }
    let data: Vec<u8> = img
        .data
        .iter()
        .map(|&v| {
            if v.is_nan() {
                0
            } else {
                (v.clamp(0.0, 1.0) * 255.0).round() as u8
            }
        })
        .collect();
    save_png::<image::Luma<u8>>(path, img.width, img.height, data)
}
