//! The output images of [`super::solve`], written row by row by the workers (no
//! per-pixel intermediate buffer, no serial pass over the image afterwards).

use crate::image::{GrayImage, Image, NormalMap};

/// Result of [`super::solve`]; every image has the target's size, zeros outside the mask.
#[derive(Clone, Debug)]
pub struct Output {
    /// Unit normals inside the mask, [0, 0, 0] outside.
    pub normals: NormalMap,
    /// Confidence in [0, 1] (see the module docs); 0 outside the mask.
    pub confidence: GrayImage,
    /// RMS match residual per light used, in intensity units.
    pub residual: GrayImage,
    /// Albedo of the target relative to the sphere (normalised matching only).
    pub albedo: Option<GrayImage>,
    /// Mixture weights (a, b), one image per table (two tables only).
    pub weights: Option<Vec<GrayImage>>,
    /// Standard error of the mixture weights, max(σ_a, σ_b) (two tables only; see the
    /// module docs).
    pub weight_sigma: Option<GrayImage>,
    /// Number of lights dropped as cast-shadowed at each pixel.
    pub shadowed_lights: Image<u16>,
    /// Number of lights above the dark level at each pixel.
    pub lit_lights: Image<u16>,
    /// Summary figures.
    pub stats: Stats,
}

/// Summary of a [`super::solve`] run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// Pixels solved (inside the mask).
    pub pixels: usize,
    /// Pixels with at least one light dropped as cast-shadowed.
    pub shadowed_pixels: usize,
    /// Pixels with confidence below 0.5.
    pub low_confidence_pixels: usize,
    /// Mean RMS residual over the mask.
    pub mean_residual: f64,
    /// The check of the outline's coverage correction on the calibration sphere's own
    /// outline ([`super::Lookup::outline_check`]), where it ran.
    pub outline_check: Option<OutlineCheck>,
}

/// The outline's coverage correction ([`super::outline`]) tried on the calibration sphere's own
/// outline ([`super::OutlineSample`]), whose normals are known: the correction is applied to a
/// target's outline only where it brings the sphere's closer to the truth (strictly:
/// where it changes nothing, its search is skipped). On renders whose silhouette pixels
/// average the sphere and a dark background it does (Mitsuba's diffuse sphere 2.42° →
/// 0.05°, its rough plastic 1.96° → 1.07°, circle found); on DiLiGenT's ball, whose rim a
/// real lens blurs, it does not (1.02° → 1.05°: its tuples there are not c·I(n̄)), and a
/// mask drawn through that ball's rim keeps its plain matches.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutlineCheck {
    /// Outline pixels of the sphere checked.
    pub pixels: usize,
    /// Their mean angular error (degrees) with the plain match.
    pub plain_deg: f64,
    /// Their mean angular error (degrees) with the coverage correction.
    pub corrected_deg: f64,
}

impl OutlineCheck {
    /// Whether the correction brought the sphere's outline closer to the truth.
    pub fn helps(&self) -> bool {
        self.corrected_deg < self.plain_deg
    }

    /// The decision and its figures in words, as `normals` and `run`'s figures say them:
    /// "applied (on the sphere's own outline, 282 px: 2.42° plain, 0.05° corrected)".
    pub fn describe(&self) -> String {
        format!(
            "{} (on the sphere's own outline, {} px: {:.2}° plain, {:.2}° corrected)",
            if self.helps() {
                "applied"
            } else {
                "not applied"
            },
            self.pixels,
            self.plain_deg,
            self.corrected_deg
        )
    }
}

/// Result at one pixel.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PixelOut {
    pub normal: [f32; 3],
    pub confidence: f32,
    pub residual: f32,
    pub coef: [f32; 2],
    /// Standard error of the mixture weights (two tables only).
    pub weight_sigma: f32,
    pub shadowed: u16,
    pub lit: u16,
}

/// One plane per output image, row-major; all zero (outside the mask) until written.
pub(crate) struct Planes {
    width: usize,
    height: usize,
    normals: Vec<[f32; 3]>,
    confidence: Vec<f32>,
    residual: Vec<f32>,
    coef: [Vec<f32>; 2],
    sigma: Vec<f32>,
    shadowed: Vec<u16>,
    lit: Vec<u16>,
    /// Which optional planes are filled: coefficient 0 (albedo or weight a), and the
    /// mixture's weight b and standard error.
    with_coef: bool,
    with_mix: bool,
    /// Also return weight a as the albedo (diffuse/specular split).
    pub albedo_from_weight: bool,
}

/// Mutable views of one row of every plane.
pub(crate) struct Row<'a> {
    normals: &'a mut [[f32; 3]],
    confidence: &'a mut [f32],
    residual: &'a mut [f32],
    coef0: &'a mut [f32],
    coef1: &'a mut [f32],
    sigma: &'a mut [f32],
    shadowed: &'a mut [u16],
    lit: &'a mut [u16],
    with_coef: bool,
    with_mix: bool,
    /// Summary of the pixels written so far.
    pub stats: Stats,
}

impl Planes {
    /// Zeroed planes (the allocator hands out zero pages: planes never written cost
    /// nothing).
    pub fn new(width: usize, height: usize, n_tables: usize, normalize: bool) -> Self {
        let n = width * height;
        let with_mix = n_tables == 2;
        Planes {
            width,
            height,
            normals: vec![[0.0; 3]; n],
            confidence: vec![0.0; n],
            residual: vec![0.0; n],
            coef: [vec![0.0; n], vec![0.0; n]],
            sigma: vec![0.0; n],
            shadowed: vec![0; n],
            lit: vec![0; n],
            with_coef: with_mix || normalize,
            with_mix,
            albedo_from_weight: false,
        }
    }

    /// The rows, top to bottom.
    pub fn rows(&mut self) -> Vec<Row<'_>> {
        let w = self.width;
        let [c0, c1] = &mut self.coef;
        self.normals
            .chunks_mut(w)
            .zip(self.confidence.chunks_mut(w))
            .zip(self.residual.chunks_mut(w))
            .zip(c0.chunks_mut(w).zip(c1.chunks_mut(w)))
            .zip(self.sigma.chunks_mut(w))
            .zip(self.shadowed.chunks_mut(w).zip(self.lit.chunks_mut(w)))
            .map(
                |(
                    ((((normals, confidence), residual), (coef0, coef1)), sigma),
                    (shadowed, lit),
                )| {
                    Row {
                        normals,
                        confidence,
                        residual,
                        coef0,
                        coef1,
                        sigma,
                        shadowed,
                        lit,
                        with_coef: self.with_coef,
                        with_mix: self.with_mix,
                        stats: Stats::default(),
                    }
                },
            )
            .collect()
    }

    /// The output images, with `stats` summed over the rows (mean residual still a sum).
    pub fn into_output(self, mut stats: Stats) -> Output {
        stats.mean_residual /= stats.pixels.max(1) as f64;
        let (width, height) = (self.width, self.height);
        let img = |data: Vec<f32>| Image {
            width,
            height,
            data,
        };
        let [c0, c1] = self.coef;
        let (albedo, weights) = match (self.with_mix, self.with_coef) {
            (true, _) => (
                self.albedo_from_weight.then(|| img(c0.clone())),
                Some(vec![img(c0), img(c1)]),
            ),
            (false, true) => (Some(img(c0)), None),
            _ => (None, None),
        };
        Output {
            normals: Image {
                width,
                height,
                data: self.normals,
            },
            confidence: img(self.confidence),
            residual: img(self.residual),
            albedo,
            weights,
            weight_sigma: self.with_mix.then(|| img(self.sigma)),
            shadowed_lights: Image {
                width,
                height,
                data: self.shadowed,
            },
            lit_lights: Image {
                width,
                height,
                data: self.lit,
            },
            stats,
        }
    }
}

impl Row<'_> {
    /// Write the result of column `c` (a mask pixel).
    #[inline]
    pub fn set(&mut self, c: usize, px: &PixelOut) {
        self.normals[c] = px.normal;
        self.confidence[c] = px.confidence;
        self.residual[c] = px.residual;
        self.shadowed[c] = px.shadowed;
        self.lit[c] = px.lit;
        if self.with_coef {
            self.coef0[c] = px.coef[0];
        }
        if self.with_mix {
            self.coef1[c] = px.coef[1];
            self.sigma[c] = px.weight_sigma;
        }
        self.stats.pixels += 1;
        self.stats.shadowed_pixels += (px.shadowed > 0) as usize;
        self.stats.low_confidence_pixels += (px.confidence < 0.5) as usize;
        self.stats.mean_residual += px.residual as f64;
    }
}

/// Sum of two partial summaries (mean residual as a sum).
pub(crate) fn add_stats(a: Stats, b: Stats) -> Stats {
    Stats {
        pixels: a.pixels + b.pixels,
        shadowed_pixels: a.shadowed_pixels + b.shadowed_pixels,
        low_confidence_pixels: a.low_confidence_pixels + b.low_confidence_pixels,
        mean_residual: a.mean_residual + b.mean_residual,
        outline_check: a.outline_check.or(b.outline_check),
    }
}
