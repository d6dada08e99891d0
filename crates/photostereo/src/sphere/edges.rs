//! From the maximum image to sub-pixel edge points of the sphere's silhouette.
//!
//! * Otsu's threshold (Otsu 1979): the grey level maximising the between-class
//!   variance of a 256-bin histogram.
//! * The largest 8-connected bright component, with its holes filled (dark spots
//!   inside the sphere must not create inner edges).
//! * For every boundary pixel: a 1-D intensity profile along the image gradient
//!   (Sobel; the direction to the component's centroid where the gradient vanishes),
//!   sampled bilinearly from −3.5 to +3.5 pixels. Straight lines are fitted to the
//!   samples at least 2 px outside and inside; the edge is where the profile crosses
//!   the line halfway between them (linear interpolation). On an area-sampled step
//!   edge this is the true edge to sub-pixel accuracy, and the extrapolated lines
//!   keep the shading ramp inside a lit sphere from pulling the edge inward.

use std::collections::VecDeque;

/// A float raster seen through a crop window (all coordinates are crop-relative).
pub(crate) struct View<'a> {
    pub width: usize,
    pub height: usize,
    pub data: &'a [f32],
}

impl View<'_> {
    #[inline]
    fn at(&self, r: usize, c: usize) -> f32 {
        self.data[r * self.width + c]
    }

    /// Bilinear value at continuous coordinates (x along columns, y along rows),
    /// pixel (r, c) centred at (c + 0.5, r + 0.5); clamped at the border.
    pub fn bilinear(&self, x: f64, y: f64) -> f64 {
        let fx = (x - 0.5).clamp(0.0, (self.width - 1) as f64);
        let fy = (y - 0.5).clamp(0.0, (self.height - 1) as f64);
        let (c0, r0) = (fx.floor() as usize, fy.floor() as usize);
        let (c1, r1) = ((c0 + 1).min(self.width - 1), (r0 + 1).min(self.height - 1));
        let (tx, ty) = (fx - c0 as f64, fy - r0 as f64);
        let top = self.at(r0, c0) as f64 * (1.0 - tx) + self.at(r0, c1) as f64 * tx;
        let bottom = self.at(r1, c0) as f64 * (1.0 - tx) + self.at(r1, c1) as f64 * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// Sobel gradient (d/dx along columns, d/dy along rows) at an interior pixel.
    pub(crate) fn sobel(&self, r: usize, c: usize) -> (f64, f64) {
        if r == 0 || c == 0 || r + 1 >= self.height || c + 1 >= self.width {
            return (0.0, 0.0);
        }
        let v = |dr: isize, dc: isize| {
            self.at((r as isize + dr) as usize, (c as isize + dc) as usize) as f64
        };
        let gx = (v(-1, 1) + 2.0 * v(0, 1) + v(1, 1)) - (v(-1, -1) + 2.0 * v(0, -1) + v(1, -1));
        let gy = (v(1, -1) + 2.0 * v(1, 0) + v(1, 1)) - (v(-1, -1) + 2.0 * v(-1, 0) + v(-1, 1));
        (gx / 8.0, gy / 8.0)
    }
}

/// Otsu's threshold of the values with `keep[i]` true, on 256 bins over [lo, hi].
pub(crate) fn otsu(values: &[f32], keep: &[bool], lo: f32, hi: f32) -> f32 {
    const BINS: usize = 256;
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    let mut hist = [0u64; BINS];
    for (v, _) in values.iter().zip(keep).filter(|(_, &k)| k) {
        let b = (((v - lo) / span) * BINS as f32) as usize;
        hist[b.min(BINS - 1)] += 1;
    }
    let total: u64 = hist.iter().sum();
    let sum_all: f64 = hist
        .iter()
        .enumerate()
        .map(|(i, &h)| i as f64 * h as f64)
        .sum();
    let (mut w0, mut sum0) = (0u64, 0.0f64);
    let (mut best, mut best_bin) = (-1.0f64, 0usize);
    for (i, &h) in hist.iter().enumerate() {
        w0 += h;
        sum0 += i as f64 * h as f64;
        let w1 = total - w0;
        if w0 == 0 || w1 == 0 {
            continue;
        }
        let m0 = sum0 / w0 as f64;
        let m1 = (sum_all - sum0) / w1 as f64;
        let between = w0 as f64 * w1 as f64 * (m0 - m1).powi(2);
        if between > best {
            best = between;
            best_bin = i;
        }
    }
    lo + span * (best_bin as f32 + 1.0) / BINS as f32
}

/// The largest 8-connected component of `fg`, with its holes filled.
pub(crate) fn largest_component(fg: &[bool], width: usize, height: usize) -> Vec<bool> {
    let mut label = vec![0u32; fg.len()];
    let (mut best_label, mut best_size, mut next) = (0u32, 0usize, 0u32);
    for start in 0..fg.len() {
        if !fg[start] || label[start] != 0 {
            continue;
        }
        next += 1;
        let size = flood(&mut label, start, next, width, height, true, |i| fg[i]);
        if size > best_size {
            best_size = size;
            best_label = next;
        }
    }
    let comp: Vec<bool> = label.iter().map(|&l| l == best_label && l != 0).collect();
    fill_holes(&comp, width, height)
}

/// Pixels not reachable from the border through background (4-connected) are holes.
fn fill_holes(comp: &[bool], width: usize, height: usize) -> Vec<bool> {
    let mut outside = vec![0u32; comp.len()];
    for r in 0..height {
        for c in 0..width {
            let on_border = r == 0 || c == 0 || r + 1 == height || c + 1 == width;
            let i = r * width + c;
            if on_border && !comp[i] && outside[i] == 0 {
                flood(&mut outside, i, 1, width, height, false, |j| !comp[j]);
            }
        }
    }
    outside.iter().map(|&o| o == 0).collect()
}

/// Breadth-first flood fill from `start` over pixels where `inside` holds; returns its size.
fn flood(
    label: &mut [u32],
    start: usize,
    value: u32,
    width: usize,
    height: usize,
    eight: bool,
    inside: impl Fn(usize) -> bool,
) -> usize {
    let mut queue = VecDeque::from([start]);
    label[start] = value;
    let mut size = 0;
    while let Some(i) = queue.pop_front() {
        size += 1;
        let (r, c) = ((i / width) as isize, (i % width) as isize);
        for dr in -1isize..=1 {
            for dc in -1isize..=1 {
                if (dr == 0 && dc == 0) || (!eight && dr != 0 && dc != 0) {
                    continue;
                }
                let (nr, nc) = (r + dr, c + dc);
                if nr < 0 || nc < 0 || nr >= height as isize || nc >= width as isize {
                    continue;
                }
                let j = nr as usize * width + nc as usize;
                if label[j] == 0 && inside(j) {
                    label[j] = value;
                    queue.push_back(j);
                }
            }
        }
    }
    size
}

/// Component pixels with a 4-neighbour outside it, excluding the crop border (where
/// the silhouette is cut by the window, not by the sphere).
pub(crate) fn boundary_pixels(comp: &[bool], width: usize, height: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for r in 1..height.saturating_sub(1) {
        for c in 1..width.saturating_sub(1) {
            let i = r * width + c;
            if comp[i] && (!comp[i - 1] || !comp[i + 1] || !comp[i - width] || !comp[i + width]) {
                out.push((r, c));
            }
        }
    }
    out
}

/// Sub-pixel edge point near boundary pixel (r, c): the mid-level crossing of the
/// profile along the gradient. `toward` is a point inside the blob (its centroid);
/// `min_step` the smallest plateau difference accepted as an edge.
pub(crate) fn subpixel_edge(
    img: &View,
    r: usize,
    c: usize,
    toward: (f64, f64),
    min_step: f64,
) -> Option<[f64; 2]> {
    const HALF: f64 = 3.5;
    const CLEAR: f64 = 2.0;
    const STEP: f64 = 0.25;
    let (x0, y0) = (c as f64 + 0.5, r as f64 + 0.5);
    let (gx, gy) = img.sobel(r, c);
    let g = (gx * gx + gy * gy).sqrt();
    let (mut dx, mut dy) = if g > 1e-12 {
        (gx / g, gy / g)
    } else {
        (toward.0 - x0, toward.1 - y0)
    };
    let norm = (dx * dx + dy * dy).sqrt();
    if norm.is_nan() || norm <= 0.0 {
        return None;
    }
    dx /= norm;
    dy /= norm;
    let n = (2.0 * HALF / STEP) as usize + 1;
    let at = |i: usize| -HALF + i as f64 * STEP;
    let prof: Vec<f64> = (0..n)
        .map(|i| img.bilinear(x0 + at(i) * dx, y0 + at(i) * dy))
        .collect();
    // straight lines through the samples at |s| >= CLEAR on either side
    let plateau = ((HALF - CLEAR) / STEP) as usize + 1;
    let outer = line_fit(&prof[..plateau], at(0), STEP);
    let inner = line_fit(&prof[n - plateau..], at(n - plateau), STEP);
    if inner.0 - outer.0 < min_step {
        return None;
    }
    // crossing of the profile with the midline between the two extrapolated plateaus
    let mid = |i: usize| 0.5 * (outer.0 + outer.1 * at(i) + inner.0 + inner.1 * at(i));
    let mut best: Option<f64> = None;
    for i in 0..n - 1 {
        let (a, b) = (prof[i] - mid(i), prof[i + 1] - mid(i + 1));
        if a < 0.0 && b >= 0.0 {
            let s = at(i) + a / (a - b) * STEP;
            if best.is_none_or(|bs| s.abs() < bs.abs()) {
                best = Some(s);
            }
        }
    }
    best.map(|s| [x0 + s * dx, y0 + s * dy])
}

/// Least-squares line through equally spaced samples starting at `s0`: returns
/// (value at s = 0, slope).
fn line_fit(values: &[f64], s0: f64, step: f64) -> (f64, f64) {
    let n = values.len() as f64;
    let ms = s0 + step * (n - 1.0) / 2.0;
    let mv = values.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, v) in values.iter().enumerate() {
        let ds = s0 + i as f64 * step - ms;
        sxy += ds * (v - mv);
        sxx += ds * ds;
    }
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (mv - slope * ms, slope)
}
