//! The lookup table: the calibration sphere's images around its circle, and one entry
//! (intensity tuple, analytic normal, pixel) per sphere pixel inside the rim.
//!
//! Besides the discrete entries the table keeps the sphere images on a small window
//! around the circle, so that the intensity field I(x, y) can be evaluated *between*
//! sphere pixels by bilinear interpolation ([`Table::sample`]). Window pixels that are
//! not well inside the sphere are padded with the value of the nearest sphere pixel
//! along the radius, which keeps the interpolation defined (and free of background)
//! everywhere the solver may look.

use crate::error::{Error, Result, Setting};
use crate::image::ImageStack;
use crate::sphere::Circle;

pub mod denoise;
pub mod format;
mod outline_sample;
mod window;

use denoise::Denoise;
pub use outline_sample::{OutlineSample, MAX_OUTLINE_SAMPLE};
use window::{auto_smooth, blur, pad_window};
pub use window::{estimate_noise, Window};

/// Options of [`Table::build`].
#[derive(Clone, Debug)]
pub struct BuildOptions {
    /// Width in pixels of the band just inside the occluding circle that is left out of
    /// the table (grazing normals, pixels mixed with the background). At least 1.0
    /// and less than half the radius. Default 2.0.
    pub rim: f64,
    /// Free-text name of the sphere's material, stored in the table (e.g. "red plastic").
    pub material: String,
    /// Standard deviation (pixels) of a Gaussian blur of the sphere images against
    /// noise, or the base width of the normal-space fit ([`BuildOptions::denoise`]);
    /// `Some(0.0)` = none. A blur of σ biases the tuples by about σ²/2 · ΔI, so
    /// it pays only on noisy spheres. `None` (default) chooses it from the noise
    /// estimated on the sphere ([`estimate_noise`]): 150 × noise / typical sample ×
    /// min(1, √(16 / K)) pixels (typical = median of the samples above 3 × noise), at
    /// most 1.5 px, and none when that is below 0.3 px (1% noise on a sphere of albedo
    /// ~0.8 under 16 lights gives 1.5 px). The rule was set at K = 12–16; the noise that
    /// one table sample puts into a fitted normal falls as 1/√K, hence the factor for
    /// more lights
    /// (DiLiGenT's ball, K = 96: 1.35 → 0.55 px; its 0.75× lookup in `lut_shared`
    /// 0.258° → 0.07°, against 0.111 / 0.072 / 0.115 / 0.176 / 0.270° with fixed blurs
    /// of 0.3 / 0.5 / 0.7 / 1.0 / 1.4 px). The noise is never taken below the
    /// quantisation's Δ/√12 (issue 24): a clean 8-bit rough-metal sphere (r 100,
    /// 16 lights, exposed for its peak) measured almost no noise on its dark side and got
    /// no smoothing; with the floor it gets 1.5 px, and the lookup on the 8-bit blob
    /// goes from 1.161° to 0.907° (`tests/camera_images.rs`).
    pub smooth: Option<f64>,
    /// How the noise is removed, with the width above ([`Denoise`]): by a blur of the
    /// images, or by a local quadratic fit over the normal sphere of a width chosen by
    /// cross-validation (`lut::denoise`); default [`Denoise::Auto`]: the fit when the
    /// width is at least 1 px (noisy spheres under few lights), else the blur.
    pub denoise: Denoise,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            rim: 2.0,
            material: String::new(),
            smooth: None,
            denoise: Denoise::default(),
        }
    }
}

/// The discrete entries: one per sphere pixel inside the rim, in row-major order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Entries {
    /// N × K intensity tuples, entry-major (`tuples[e * k + light]`).
    pub tuples: Vec<f32>,
    /// Analytic unit normal of each entry (camera frame).
    pub normals: Vec<[f32; 3]>,
    /// (row, col) of each entry in the calibration images.
    pub pixels: Vec<[u32; 2]>,
}

impl Entries {
    /// Number of entries.
    pub fn len(&self) -> usize {
        self.normals.len()
    }

    /// True when the table has no entry.
    pub fn is_empty(&self) -> bool {
        self.normals.is_empty()
    }
}

/// A lookup table intensity tuple → normal built from images of a calibration sphere.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// Number of lights (images).
    pub k: usize,
    /// Image names in light order (may be empty for in-memory data).
    pub names: Vec<String>,
    /// The sphere's occluding circle in the calibration images.
    pub circle: Circle,
    /// Free-text material name.
    pub material: String,
    /// Rim width (pixels) left out of the entries.
    pub rim: f64,
    /// Gaussian blur (pixels) applied to the sphere images when the table was built.
    pub smooth: f64,
    /// The optical blur of the calibration images (pixels, Gaussian σ on top of each
    /// pixel's area) measured on the sphere's rim at `circle` when the table was built
    /// ([`crate::sphere::rim_blur`]); `None` when it could not be measured (or the table
    /// was read from a file written before it was kept). The spatial stage trusts a
    /// target's mask outline less when it is blurred (`spatial`, "Blurred outlines").
    pub rim_blur: Option<f64>,
    /// Sphere images around the circle.
    pub window: Window,
    /// Discrete entries (tuples, normals, pixels).
    pub entries: Entries,
    /// The sphere's own outline as photographed ([`OutlineSample`]); `None` when the
    /// table was read from a file written before it was kept.
    pub outline: Option<OutlineSample>,
}

/// Smallest number of lights a table accepts.
pub const MIN_LIGHTS: usize = 3;

/// Largest black level, as a fraction of the table's peak, that [`Table::floors`] takes
/// a light's darkest sample for (cameras' black levels are a few percent of full scale).
pub const MAX_FLOOR: f32 = 0.1;

impl Table {
    /// Build the table from the K calibration images and the sphere's circle.
    ///
    /// Errors: K < 3 ([`Error::LightCount`]); a circle that leaves the images
    /// ([`Error::Setting`] with [`Setting::Circle`]); a bad rim, or a sphere too small to
    /// hold a table ([`Error::InvalidInput`]).
    pub fn build(stack: &ImageStack, circle: &Circle, opts: &BuildOptions) -> Result<Table> {
        check_lights(stack.k, "calibration images")?;
        if let Some((what, fix)) = circle_outside(circle, stack.width, stack.height) {
            return Err(Error::setting(Setting::Circle, what, fix));
        }
        let col0 = (circle.cx - circle.radius).floor().max(0.0) as usize;
        let row0 = (circle.cy - circle.radius).floor().max(0.0) as usize;
        let col1 = ((circle.cx + circle.radius).ceil() as usize).min(stack.width);
        let row1 = ((circle.cy + circle.radius).ceil() as usize).min(stack.height);
        let mut win = ImageStack::zeros(col1 - col0, row1 - row0, stack.k);
        for r in 0..win.height {
            for c in 0..win.width {
                let src = stack.pixel(row0 + r, col0 + c);
                win.pixel_flat_mut(r * win.width + c).copy_from_slice(src);
            }
        }
        let mut window = Window {
            col0,
            row0,
            stack: win,
        };
        let smooth = match opts.smooth {
            Some(s) => s,
            None => auto_smooth(&window, circle, opts.rim),
        };
        if smooth > 0.0 {
            if smooth.is_nan() || smooth > 10.0 {
                return Err(Error::invalid(
                    format!("smoothing of {smooth} px"),
                    "use a blur between 0 and 10 px (about 1 px for noisy spheres)",
                ));
            }
            match opts.denoise.resolve(smooth) {
                Denoise::ImageBlur | Denoise::Auto => {
                    pad_window(&mut window, circle, opts.rim);
                    blur(&mut window.stack, smooth);
                }
                Denoise::NormalSpace { width } => {
                    let w = match width {
                        Some(f) => f * smooth,
                        None => {
                            let f = &denoise::WIDTH_FACTORS;
                            denoise::choose_width(&window, circle, opts.rim, smooth, f).0
                        }
                    };
                    denoise::fit_in_normal_space(&mut window, circle, opts.rim, w)
                }
            }
        }
        let mut table = Table::from_parts(
            stack.names.clone(),
            *circle,
            opts.material.clone(),
            opts.rim,
            window,
        )?;
        table.smooth = smooth;
        table.rim_blur = crate::sphere::rim_blur(stack, circle);
        table.outline = OutlineSample::of(stack, circle);
        Ok(table)
    }

    /// Assemble a table from its window (pads it and derives the entries). Used by
    /// [`Table::build`] and when reading a table file.
    pub(crate) fn from_parts(
        names: Vec<String>,
        circle: Circle,
        material: String,
        rim: f64,
        mut window: Window,
    ) -> Result<Table> {
        let k = window.stack.k;
        let shifted = Circle {
            cx: circle.cx - window.col0 as f64,
            cy: circle.cy - window.row0 as f64,
            radius: circle.radius,
        };
        if let Some((what, fix)) = circle_outside(&shifted, window.stack.width, window.stack.height)
        {
            return Err(Error::invalid(what, fix));
        }
        if !(rim >= 1.0 && rim < circle.radius / 2.0) {
            return Err(Error::invalid(
                format!(
                    "rim of {rim} px on a sphere of radius {:.1} px",
                    circle.radius
                ),
                "use a rim of at least 1 px and less than half the radius (default 2)",
            ));
        }
        pad_window(&mut window, &circle, rim);
        let mut entries = Entries::default();
        let ws = &window.stack;
        for r in 0..ws.height {
            for c in 0..ws.width {
                let (row, col) = (window.row0 + r, window.col0 + c);
                if let Some(n) = circle.normal_at(row, col, rim) {
                    entries.tuples.extend_from_slice(ws.pixel(r, c));
                    entries.normals.push(n);
                    entries.pixels.push([row as u32, col as u32]);
                }
            }
        }
        if entries.len() < 20 {
            return Err(Error::invalid(
                format!(
                    "sphere of radius {:.1} px with a rim of {rim} px ({} table entries)",
                    circle.radius,
                    entries.len()
                ),
                "use a larger sphere (radius of 20 px or more) or a smaller rim",
            ));
        }
        Ok(Table {
            k,
            names,
            circle,
            material,
            rim,
            smooth: 0.0,
            rim_blur: None,
            window,
            entries,
            outline: None,
        })
    }

    /// Largest distance (pixels) from the circle centre the solver may move to.
    pub fn search_radius(&self) -> f64 {
        self.circle.radius - self.rim
    }

    /// Each light's floor: the darkest sample of its entries, the camera's black level
    /// where part of the sphere is unlit (0 on a capture without one). A minimum above
    /// [`MAX_FLOOR`] of the peak is light, not a black level (a light near the view axis
    /// lights the whole table), and gives 0. The cast-shadow test measures "dark" above
    /// this floor: with a 3% black level every unlit sample sat at the dark level itself
    /// and no cast shadow was found.
    pub fn floors(&self) -> Vec<f32> {
        let k = self.k;
        let mut low = vec![f32::INFINITY; k];
        for tuple in self.entries.tuples.chunks_exact(k.max(1)) {
            for (m, &v) in low.iter_mut().zip(tuple) {
                *m = m.min(v);
            }
        }
        let cap = MAX_FLOOR * self.peak();
        low.iter()
            .map(|&m| {
                if m.is_finite() && m > 0.0 && m <= cap {
                    m
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// The camera's black level: the smallest of the lights' [`Table::floors`], one level
    /// for all lights as a camera has (a light near the view axis lights the whole
    /// table, and its floor is its dimmest lit sample, not the black level); 0 without
    /// one.
    pub fn black_level(&self) -> f32 {
        let level = self.floors().into_iter().fold(f32::INFINITY, f32::min);
        if level.is_finite() {
            level
        } else {
            0.0
        }
    }

    /// The table with `floors` (one per light, e.g. [`Table::floors`]) taken off every
    /// sample of its window and entries: the light above a camera's black level, which
    /// is what scales with a target's albedo (a fit with a free brightness matches
    /// t − f = c·(I − f), not t = c·I).
    pub fn above(&self, floors: &[f32]) -> Table {
        let mut out = self.clone();
        let k = self.k.max(1);
        for tuple in out.entries.tuples.chunks_exact_mut(k) {
            tuple.iter_mut().zip(floors).for_each(|(v, f)| *v -= f);
        }
        for tuple in out.window.stack.data.chunks_exact_mut(k) {
            tuple.iter_mut().zip(floors).for_each(|(v, f)| *v -= f);
        }
        out
    }

    /// Largest sample of any entry (the table's brightness scale).
    pub fn peak(&self) -> f32 {
        // 8 independent chains (a single fold is one long dependency chain)
        let mut lanes = [0.0f32; 8];
        let chunks = self.entries.tuples.chunks_exact(8);
        let tail = chunks.remainder().iter().copied().fold(0.0, f32::max);
        for c in chunks {
            for (m, &v) in lanes.iter_mut().zip(c) {
                *m = m.max(v);
            }
        }
        lanes.iter().copied().fold(tail, f32::max)
    }

    /// Window-grid coordinates (gx, gy) of continuous image point (x, y): the grid has
    /// window pixel (r, c)'s centre at (c, r).
    #[inline]
    pub fn to_grid(&self, x: f64, y: f64) -> (f64, f64) {
        (
            x - 0.5 - self.window.col0 as f64,
            y - 0.5 - self.window.row0 as f64,
        )
    }

    /// Unit normal of the sphere at window-grid point (gx, gy), clamped to the sphere.
    #[inline]
    pub fn grid_normal(&self, gx: f64, gy: f64) -> [f32; 3] {
        let c = &self.circle;
        let nx = (gx + 0.5 + self.window.col0 as f64 - c.cx) / c.radius;
        let ny = -(gy + 0.5 + self.window.row0 as f64 - c.cy) / c.radius;
        let rho2 = (nx * nx + ny * ny).min(1.0);
        [nx as f32, ny as f32, (1.0 - rho2).sqrt() as f32]
    }

    /// Window-grid point of unit normal n (inverse of [`Table::grid_normal`]).
    #[inline]
    pub fn normal_to_grid(&self, n: [f32; 3]) -> (f64, f64) {
        let c = &self.circle;
        self.to_grid(c.cx + c.radius * n[0] as f64, c.cy - c.radius * n[1] as f64)
    }

    /// Move grid point (gx, gy) back inside the search disc if it left it.
    #[inline]
    pub fn clamp_grid(&self, gx: f64, gy: f64) -> (f64, f64) {
        let (cgx, cgy) = self.to_grid(self.circle.cx, self.circle.cy);
        let (dx, dy) = (gx - cgx, gy - cgy);
        let d = (dx * dx + dy * dy).sqrt();
        let rmax = self.search_radius();
        if d > rmax {
            (cgx + dx * rmax / d, cgy + dy * rmax / d)
        } else {
            (gx, gy)
        }
    }

    /// Bilinear interpolation of the K sphere images at window-grid point (gx, gy):
    /// writes I into `value` and, when given, ∂I/∂gx into `grad[..k]` and ∂I/∂gy into
    /// `grad[k..2k]`.
    #[inline]
    pub fn sample(&self, gx: f64, gy: f64, value: &mut [f32], grad: Option<&mut [f32]>) {
        let ws = &self.window.stack;
        let k = self.k;
        let c0 = (gx.floor().max(0.0) as usize).min(ws.width - 2);
        let r0 = (gy.floor().max(0.0) as usize).min(ws.height - 2);
        let a = (gx - c0 as f64) as f32;
        let b = (gy - r0 as f64) as f32;
        let top = &ws.data[(r0 * ws.width + c0) * k..(r0 * ws.width + c0 + 2) * k];
        let bot = &ws.data[((r0 + 1) * ws.width + c0) * k..((r0 + 1) * ws.width + c0 + 2) * k];
        let (p00, p01) = top.split_at(k);
        let (p10, p11) = bot.split_at(k);
        let value = &mut value[..k];
        match grad {
            None => {
                let (w00, w01, w10, w11) =
                    ((1.0 - a) * (1.0 - b), a * (1.0 - b), (1.0 - a) * b, a * b);
                for ((((v, x00), x01), x10), x11) in
                    value.iter_mut().zip(p00).zip(p01).zip(p10).zip(p11)
                {
                    *v = w00 * x00 + w01 * x01 + w10 * x10 + w11 * x11;
                }
            }
            Some(g) => {
                let (gxs, gys) = g[..2 * k].split_at_mut(k);
                let iter = value
                    .iter_mut()
                    .zip(gxs)
                    .zip(gys)
                    .zip(p00)
                    .zip(p01)
                    .zip(p10)
                    .zip(p11);
                for ((((((v, dx), dy), x00), x01), x10), x11) in iter {
                    let up = x00 + a * (x01 - x00);
                    let down = x10 + a * (x11 - x10);
                    *v = up + b * (down - up);
                    *dx = (x01 - x00) + b * ((x11 - x10) - (x01 - x00));
                    *dy = down - up;
                }
            }
        }
    }

    /// Check that this table fits a target of `k` lights named `names` (names are compared
    /// only when both sides have them).
    pub fn check_target(&self, k: usize, names: &[String], what: &str) -> Result<()> {
        if self.k != k {
            return Err(Error::TableMismatch {
                what: what.to_string(),
                reason: format!(
                    "the table has {} lights, the target {k}; use a table calibrated under the same lights",
                    self.k
                ),
            });
        }
        if !self.names.is_empty() && !names.is_empty() && self.names != names {
            let first = self
                .names
                .iter()
                .zip(names)
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            return Err(Error::TableMismatch {
                what: what.to_string(),
                reason: format!(
                    "image {} is '{}' in the table but '{}' in the target; the images must be the same lights in the same order",
                    first + 1,
                    self.names.get(first).map_or("", |s| s.as_str()),
                    names.get(first).map_or("", |s| s.as_str()),
                ),
            });
        }
        Ok(())
    }
}

/// Error unless K ≥ 3.
pub(crate) fn check_lights(k: usize, what: &str) -> Result<()> {
    if k < MIN_LIGHTS {
        return Err(Error::LightCount {
            what: what.to_string(),
            expected: MIN_LIGHTS,
            found: k,
            fix: "photometric stereo needs at least 3 images under different lights".into(),
        });
    }
    Ok(())
}

/// Error unless the circle lies inside a `width` x `height` image.
fn circle_outside(c: &Circle, width: usize, height: usize) -> Option<(String, &'static str)> {
    let finite = c.cx.is_finite() && c.cy.is_finite() && c.radius.is_finite();
    let inside = c.cx - c.radius >= 0.0
        && c.cy - c.radius >= 0.0
        && c.cx + c.radius <= width as f64
        && c.cy + c.radius <= height as f64;
    (!finite || c.radius <= 0.0 || !inside).then(|| {
        (
            format!(
                "sphere circle (cx {:.2}, cy {:.2}, r {:.2}) in {width}x{height} images",
                c.cx, c.cy, c.radius
            ),
            "the whole circle must lie inside the images; check the circle or the region the \
             sphere was searched in",
        )
    })
}

/// A table of a synthetic sphere for unit tests: `circle` in `size`² images under `k`
/// lights, sample `shade(n, i)` for light `i` at every pixel whose centre lies on the
/// sphere (normal `n`), no smoothing.
#[cfg(test)]
pub(crate) fn test_sphere_table(
    size: usize,
    circle: Circle,
    k: usize,
    shade: impl Fn([f32; 3], usize) -> f32,
) -> Table {
    let mut stack = ImageStack::zeros(size, size, k);
    for r in 0..size {
        for c in 0..size {
            let Some(n) = circle.normal_at(r, c, 0.0) else {
                continue;
            };
            for (i, v) in stack.pixel_flat_mut(r * size + c).iter_mut().enumerate() {
                *v = shade(n, i);
            }
        }
    }
    let opts = BuildOptions {
        smooth: Some(0.0),
        ..BuildOptions::default()
    };
    Table::build(&stack, &circle, &opts).unwrap()
}
