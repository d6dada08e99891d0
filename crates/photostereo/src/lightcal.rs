//! Light calibration from a sphere of known circle: directions (and relative
//! intensities) of the K lights, from a matte sphere or from a chrome sphere.
//!
//! **Matte sphere** ([`from_matte_sphere`]). A Lambertian sphere pixel with the
//! analytic normal n (see [`crate::sphere`]) reads I = ρ e max(0, n·l) under light l of
//! intensity e. Over the lit pixels of image k this is linear in sₖ = ρ eₖ lₖ:
//! I = n·sₖ, solved by least squares (3×3 normal equations). Pixels are first selected
//! by their brightness (I > `shadow_fraction` × the image's brightest sphere pixel),
//! then — to avoid the noise bias of thresholding measured values — by the predicted
//! brightness n·sₖ of the current fit, and refitted. lₖ = sₖ/‖sₖ‖, and the relative
//! intensity is ‖sₖ‖ / maxⱼ ‖sⱼ‖ (the sphere's albedo is unknown). A camera's black
//! level (or ambient light) lifts every sample: the refits take off the level of the
//! sphere's attached shadow (the median of the pixels the fit puts well into it), one
//! level for all images (the median over the lights that shadow enough of the sphere).
//! On quantised images that reading is the level rounded to a step; the lit pixels
//! correct it by up to half a step (variable projection, `level_on_lit_pixels`).
//!
//! **Chrome sphere** ([`from_chrome_sphere`]). A mirror sphere shows each light as a
//! small highlight where its normal bisects the view v = (0, 0, 1) and the light.
//! The highlight position is the intensity-weighted centroid (weights I − t) of the
//! brightest connected blob of pixels above t = `blob_fraction` × the image's peak
//! inside the sphere; its normal n follows from the circle, and the light is the
//! mirror reflection of the view direction: l = 2(n·v)n − v. Intensities are set to 1.
//! An error of δ pixels in the centroid moves l by about 2δ/(R n_z) radians.
//!
//! References: R. J. Woodham 1980 (matte calibration is photometric stereo with the
//! roles of normals and lights swapped); W. Zhou and C. Kambhamettu, "Estimation of
//! illuminant direction and intensity of multiple light sources", ECCV 2002 (specular
//! sphere); A. Hertzmann and S. M. Seitz, "Example-based photometric stereo", PAMI 2005.

use crate::error::{Error, Result};
use crate::image::{normalize, ImageStack, Lights};
use crate::sphere::fit::{accumulate, solve3};
use crate::sphere::Circle;
use crate::stats::{median, median_smallest_gap};

/// Settings of [`from_matte_sphere`].
#[derive(Clone, Debug)]
pub struct MatteOptions {
    /// Pixels within this distance of the rim are skipped (grazing normals, mixed pixels).
    pub rim_px: f64,
    /// A pixel is lit when above this fraction of the image's brightest sphere pixel
    /// (first pass) or of the fit's peak (later passes).
    pub shadow_fraction: f32,
    /// Samples at or above this value are saturated and skipped (∞ = none).
    pub saturation: f32,
    /// Refits with the selection by predicted brightness.
    pub iterations: usize,
}

impl MatteOptions {
    /// A sample the fit may use: finite and below saturation.
    fn usable(&self, v: f32) -> bool {
        v.is_finite() && v < self.saturation
    }
}

impl Default for MatteOptions {
    fn default() -> Self {
        MatteOptions {
            rim_px: 3.0,
            shadow_fraction: 0.1,
            saturation: f32::INFINITY,
            iterations: 3,
        }
    }
}

/// Settings of [`from_chrome_sphere`].
#[derive(Clone, Debug)]
pub struct ChromeOptions {
    /// Pixels within this distance of the rim are skipped (reflections of the background).
    pub rim_px: f64,
    /// The highlight blob is made of pixels above this fraction (0..1) of the peak.
    pub blob_fraction: f32,
}

impl Default for ChromeOptions {
    fn default() -> Self {
        ChromeOptions {
            rim_px: 2.0,
            blob_fraction: 0.5,
        }
    }
}

/// Where the highlight of one light was found on the chrome sphere.
#[derive(Clone, Debug, PartialEq)]
pub struct Highlight {
    /// Sub-pixel centroid, image coordinates (x along columns, y along rows, pixels).
    pub x: f64,
    /// See `x`.
    pub y: f64,
    /// Pixels in the blob.
    pub pixels: usize,
    /// Brightest sample of the blob.
    pub peak: f32,
    /// Sphere normal at the centroid.
    pub normal: [f32; 3],
}

/// Light directions and relative intensities from a matte (Lambertian) sphere.
///
/// Errors: [`Error::InvalidInput`] for an empty stack, a circle outside the images or an
/// image with too few lit sphere pixels (names the image and the fix).
pub fn from_matte_sphere(
    stack: &ImageStack,
    circle: &Circle,
    opts: &MatteOptions,
) -> Result<Lights> {
    let pixels = sphere_pixels(stack, circle, opts.rim_px)?;
    // the camera's black level is common to all images: the median of the shadow
    // levels of the lights that leave enough of the sphere in shadow, then every light
    // fitted above it (a light near the view axis shadows too little to measure it)
    let mut levels = Vec::with_capacity(stack.k);
    for k in 0..stack.k {
        levels.extend(fit_matte_light(stack, &pixels, k, opts, None)?.1);
    }
    let measured = !levels.is_empty();
    let mut black = median(&mut levels).unwrap_or(0.0);
    if measured {
        black = level_on_lit_pixels(stack, &pixels, opts, black)?;
    }
    let mut directions = Vec::with_capacity(stack.k);
    let mut strengths = Vec::with_capacity(stack.k);
    for k in 0..stack.k {
        let (s, _) = fit_matte_light(stack, &pixels, k, opts, Some(black))?;
        let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        directions.push([
            (s[0] / len) as f32,
            (s[1] / len) as f32,
            (s[2] / len) as f32,
        ]);
        strengths.push(len);
    }
    let top = strengths.iter().copied().fold(0.0, f64::max);
    Ok(Lights {
        directions,
        intensities: strengths.iter().map(|s| (s / top) as f32).collect(),
    })
}

/// Light directions from the highlights on a chrome (mirror) sphere, with where each
/// highlight was found.
///
/// Errors: [`Error::InvalidInput`] for an empty stack, a circle outside the images, or
/// an image without a highlight on the sphere (names the image).
pub fn from_chrome_sphere(
    stack: &ImageStack,
    circle: &Circle,
    opts: &ChromeOptions,
) -> Result<(Lights, Vec<Highlight>)> {
    let pixels = sphere_pixels(stack, circle, opts.rim_px)?;
    let mut directions = Vec::with_capacity(stack.k);
    let mut highlights = Vec::with_capacity(stack.k);
    for k in 0..stack.k {
        let h = find_highlight(stack, circle, &pixels, k, opts)?;
        let n = h.normal;
        let l = [
            2.0 * n[2] * n[0],
            2.0 * n[2] * n[1],
            2.0 * n[2] * n[2] - 1.0,
        ];
        directions.push(normalize(l));
        highlights.push(h);
    }
    Ok((Lights::from_directions(directions), highlights))
}

/// A sphere pixel: flat index and analytic normal.
struct SpherePixel {
    index: usize,
    normal: [f64; 3],
}

fn sphere_pixels(stack: &ImageStack, circle: &Circle, rim: f64) -> Result<Vec<SpherePixel>> {
    if stack.k == 0 || stack.pixels() == 0 {
        return Err(Error::invalid(
            "sphere images",
            "the stack is empty: give the sphere's images",
        ));
    }
    circle.check_inside(stack.width, stack.height, "sphere circle")?;
    let mut out = Vec::new();
    for r in 0..stack.height {
        for c in 0..stack.width {
            if let Some(n) = circle.normal_at(r, c, rim) {
                out.push(SpherePixel {
                    index: r * stack.width + c,
                    normal: [n[0] as f64, n[1] as f64, n[2] as f64],
                });
            }
        }
    }
    if out.len() < 20 {
        return Err(Error::invalid(
            format!("sphere circle r = {:.1} px", circle.radius),
            "the sphere covers too few pixels for calibration: use a larger sphere or a smaller rim",
        ));
    }
    Ok(out)
}

fn image_name(stack: &ImageStack, k: usize) -> String {
    stack
        .names
        .get(k)
        .cloned()
        .unwrap_or_else(|| format!("image {k}"))
}

/// The light s of image `k` (module docs) fitted above the black level `black`, or above
/// the level of this image's own attached shadow when `None`; with the shadow's level
/// found (`None` when it could not be measured, or when `black` was given).
fn fit_matte_light(
    stack: &ImageStack,
    pixels: &[SpherePixel],
    k: usize,
    opts: &MatteOptions,
    black: Option<f32>,
) -> Result<([f64; 3], Option<f32>)> {
    let value = |p: &SpherePixel| stack.data[p.index * stack.k + k];
    let peak = pixels
        .iter()
        .map(value)
        .filter(|&v| opts.usable(v))
        .fold(0.0f32, f32::max);
    let first = opts.shadow_fraction * peak;
    let mut s = lsq_light(
        pixels
            .iter()
            .filter(|p| opts.usable(value(p)) && value(p) > first),
        value,
    );
    let mut found = None;
    for _ in 0..opts.iterations {
        let Some(cur) = s else { break };
        let (top, lit) = lit_by(pixels, &value, cur, opts);
        if black.is_none() {
            found = shadow_level(pixels, &value, &|p| dot(p.normal, cur), top);
        }
        let level = black.or(found).unwrap_or(0.0);
        s = lsq_light(lit, |p| value(p) - level);
    }
    match s {
        Some(v) if dot(v, v) > 0.0 => Ok((v, found)),
        _ => Err(Error::invalid(
            format!("matte sphere, {}", image_name(stack, k)),
            "too few lit sphere pixels to fit the light: check the exposure, the circle and that the light faces the sphere",
        )),
    }
}

/// The level of the sphere's attached shadow in one image: the median of the pixels
/// that the current fit `pred` puts well into it (below −[`SHADOW_DEPTH`] × its peak
/// `top`), where there are at least [`MIN_SHADOW_PIXELS`]; else `None`. A camera's black level
/// (or ambient light) lifts every sample by it, and a fit through the origin would
/// tilt the light to explain it (a 3% black level on a 128² matte sphere: 0.003° →
/// 1.34° per light).
fn shadow_level(
    pixels: &[SpherePixel],
    value: &impl Fn(&SpherePixel) -> f32,
    pred: &impl Fn(&SpherePixel) -> f64,
    top: f64,
) -> Option<f32> {
    let mut dark: Vec<f32> = (pixels.iter())
        .filter(|p| pred(p) < -SHADOW_DEPTH * top)
        .map(value)
        .filter(|v| v.is_finite())
        .collect();
    if dark.len() < MIN_SHADOW_PIXELS {
        return None;
    }
    median(&mut dark).map(|m| m.max(0.0))
}

/// The shadow's level `black` corrected on the lit pixels, within half the images'
/// quantisation step. Quantised, the shadow reads the level rounded to a step (a 3% level
/// in 8 bits is 7.65 steps and the shadow reads 8), while the lit pixels read it on
/// average: the lights fitted above the rounded level tilted by 0.059° on a 256² matte
/// sphere, 0.0014° when the level is a whole number of steps. Every image k reads
/// I = β + n·sₖ on its lit pixels; with each sₖ projected out (variable projection, as
/// [`crate::lambertian::estimate_black_level`]: u = P⊥1 over the image's lit pixels),
/// β − `black` = Σ⟨I − black, u⟩ / Σ⟨1, u⟩. The correction is kept within half a step
/// of the shadow's level, which it can only be off by: on a sphere that is not quite
/// Lambertian the lit pixels' model is not exact, and the shadow's reading stays the
/// measurement. Images that are not quantised (no step found) keep the shadow's level.
///
/// Errors: as [`fit_matte_light`].
fn level_on_lit_pixels(
    stack: &ImageStack,
    pixels: &[SpherePixel],
    opts: &MatteOptions,
    black: f32,
) -> Result<f32> {
    let step = quantisation_step(stack, pixels);
    if step <= 0.0 {
        return Ok(black);
    }
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for k in 0..stack.k {
        let (s, _) = fit_matte_light(stack, pixels, k, opts, Some(black))?;
        let value = |p: &SpherePixel| stack.data[p.index * stack.k + k];
        let lit: Vec<&SpherePixel> = lit_by(pixels, &value, s, opts).1.collect();
        // the normals play the lights' part of the Lambertian solve's terms
        let normals: Vec<[f64; 3]> = lit.iter().map(|p| p.normal).collect();
        let all: Vec<usize> = (0..lit.len()).collect();
        let above = |i: usize| (value(lit[i]) - black) as f64;
        let [n, d, _, _] = crate::lambertian::black_terms(&normals, &all, above, 0.0);
        (num, den) = (num + n, den + d);
    }
    let shift = if den > 0.0 { (num / den) as f32 } else { 0.0 };
    let half = 0.5 * step;
    Ok((black + shift.clamp(-half, half)).max(0.0))
}

/// The pixels of one image (samples `value`) that the light `s` lights above
/// `shadow_fraction` of its peak over the sphere, with a sample that is finite and below
/// saturation; and that peak.
fn lit_by<'a>(
    pixels: &'a [SpherePixel],
    value: &'a impl Fn(&SpherePixel) -> f32,
    s: [f64; 3],
    opts: &'a MatteOptions,
) -> (f64, impl Iterator<Item = &'a SpherePixel>) {
    let pred = move |p: &SpherePixel| dot(p.normal, s);
    let top = pixels.iter().map(pred).fold(0.0, f64::max);
    let cut = opts.shadow_fraction as f64 * top;
    let lit = (pixels.iter()).filter(move |p| opts.usable(value(p)) && pred(p) > cut);
    (top, lit)
}

/// The images' quantisation step over the sphere's pixels (the median over the images
/// of the smallest gap between two distinct values); 0 when they are not quantised.
fn quantisation_step(stack: &ImageStack, pixels: &[SpherePixel]) -> f32 {
    let mut per_image: Vec<Vec<f32>> = (0..stack.k)
        .map(|k| {
            (pixels.iter())
                .map(|p| stack.data[p.index * stack.k + k])
                .filter(|v| v.is_finite())
                .collect()
        })
        .collect();
    let step = median_smallest_gap(per_image.iter_mut(), MIN_STEPS);
    // floats: the smallest gap of a continuum is a rounding error, not a step
    let top = (per_image.iter().flatten()).fold(0.0f32, |m, &v| m.max(v.abs()));
    if step > top * 1e-6 {
        step
    } else {
        0.0
    }
}

/// Fewest distinct values of an image for its smallest gap to count as its step.
const MIN_STEPS: usize = 8;

/// Depth into the attached shadow (fraction of the fit's peak) of the pixels whose
/// median is the shadow's level: away from the terminator, where blur and the fit's
/// error mix in lit pixels.
const SHADOW_DEPTH: f64 = 0.1;

/// Fewest shadowed pixels whose median is taken for the shadow's level.
const MIN_SHADOW_PIXELS: usize = 50;

fn lsq_light<'a>(
    sel: impl Iterator<Item = &'a SpherePixel>,
    value: impl Fn(&SpherePixel) -> f32,
) -> Option<[f64; 3]> {
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    let mut n = 0usize;
    for p in sel {
        accumulate(&mut a, &mut b, p.normal, value(p) as f64);
        n += 1;
    }
    if n < 10 {
        return None;
    }
    solve3(a, b)
}

fn find_highlight(
    stack: &ImageStack,
    circle: &Circle,
    pixels: &[SpherePixel],
    k: usize,
    opts: &ChromeOptions,
) -> Result<Highlight> {
    let w = stack.width;
    let value = |i: usize| stack.data[i * stack.k + k];
    let peak = pixels
        .iter()
        .map(|p| value(p.index))
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max);
    if peak <= 0.0 {
        return Err(Error::invalid(
            format!("chrome sphere, {}", image_name(stack, k)),
            "no highlight on the sphere (it is black): check the circle and that the light is visible in the sphere",
        ));
    }
    let t = opts.blob_fraction.clamp(0.0, 0.999) * peak;
    let mut on = vec![false; stack.pixels()];
    for p in pixels {
        on[p.index] = value(p.index) >= t;
    }
    let blob = brightest_blob(&on, w, stack.height, |i| (value(i) - t) as f64);
    let (mut sw, mut sx, mut sy, mut top) = (0.0f64, 0.0f64, 0.0f64, 0.0f32);
    for &i in &blob {
        let wgt = (value(i) - t) as f64 + 1e-9;
        sw += wgt;
        sx += wgt * ((i % w) as f64 + 0.5);
        sy += wgt * ((i / w) as f64 + 0.5);
        top = top.max(value(i));
    }
    let (x, y) = (sx / sw, sy / sw);
    let nx = (x - circle.cx) / circle.radius;
    let ny = -(y - circle.cy) / circle.radius;
    let nz = (1.0 - nx * nx - ny * ny).max(0.0).sqrt();
    Ok(Highlight {
        x,
        y,
        pixels: blob.len(),
        peak: top,
        normal: [nx as f32, ny as f32, nz as f32],
    })
}

/// The 8-connected component of `on` with the largest total `weight`.
fn brightest_blob(on: &[bool], w: usize, h: usize, weight: impl Fn(usize) -> f64) -> Vec<usize> {
    let mut seen = vec![false; on.len()];
    let (mut best, mut best_weight) = (Vec::new(), -1.0f64);
    for start in 0..on.len() {
        if !on[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        let mut comp = vec![start];
        let mut head = 0;
        while head < comp.len() {
            let i = comp[head];
            head += 1;
            let (r, c) = (i / w, i % w);
            for nr in r.saturating_sub(1)..=(r + 1).min(h - 1) {
                for nc in c.saturating_sub(1)..=(c + 1).min(w - 1) {
                    let j = nr * w + nc;
                    if on[j] && !seen[j] {
                        seen[j] = true;
                        comp.push(j);
                    }
                }
            }
        }
        let total: f64 = comp.iter().map(|&i| weight(i)).sum();
        if total > best_weight {
            best_weight = total;
            best = comp;
        }
    }
    best
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
