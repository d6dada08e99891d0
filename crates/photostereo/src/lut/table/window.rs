//! The sphere images on a window around the circle, and what is done to them before
//! the entries are read: padding outside the sphere, the Gaussian blur, and the noise
//! estimate that chooses the blur.

use crate::image::ImageStack;
use crate::sphere::Circle;
use crate::stats::{median, median_smallest_gap};

/// The sphere images on the window around the circle, pixel-major, padded outside the
/// sphere (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    /// Column of the window's left edge in the calibration images.
    pub col0: usize,
    /// Row of the window's top edge in the calibration images.
    pub row0: usize,
    /// The K images on the window; `stack.names` is empty.
    pub stack: ImageStack,
}

/// Replace window pixels that are not well inside the sphere (centre farther than
/// R − rim + 1 from the centre) by the nearest such pixel along the radius.
pub(super) fn pad_window(window: &mut Window, circle: &Circle, rim: f64) {
    let ws = &mut window.stack;
    let k = ws.k;
    let support = circle.radius - rim + 1.0;
    let target = support - 1.5;
    let (gcx, gcy) = (
        circle.cx - 0.5 - window.col0 as f64,
        circle.cy - 0.5 - window.row0 as f64,
    );
    for r in 0..ws.height {
        for c in 0..ws.width {
            let (dx, dy) = (c as f64 - gcx, r as f64 - gcy);
            let d = (dx * dx + dy * dy).sqrt();
            if d < support {
                continue;
            }
            let sc = ((gcx + dx * target / d).round().max(0.0) as usize).min(ws.width - 1);
            let sr = ((gcy + dy * target / d).round().max(0.0) as usize).min(ws.height - 1);
            let src = (sr * ws.width + sc) * k;
            let dst = (r * ws.width + c) * k;
            ws.data.copy_within(src..src + k, dst);
        }
    }
}

/// The image blur as [`super::Table::build`] applies it (padding, then blur), for comparisons.
#[cfg(test)]
pub(crate) fn blur_for_tests(window: &mut Window, circle: &Circle, rim: f64, sigma: f64) {
    pad_window(window, circle, rim);
    blur(&mut window.stack, sigma);
}

/// Separable Gaussian blur of standard deviation `sigma` pixels (edges clamped).
pub(super) fn blur(stack: &mut ImageStack, sigma: f64) {
    let radius = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f32> = (-radius..=radius)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32)
        .collect();
    let total: f32 = kernel.iter().sum();
    let kernel: Vec<f32> = kernel.iter().map(|v| v / total).collect();
    let (w, h, k) = (stack.width as isize, stack.height as isize, stack.k);
    for horizontal in [true, false] {
        let src = stack.data.clone();
        for r in 0..h {
            for c in 0..w {
                let dst =
                    &mut stack.data[((r * w + c) as usize) * k..((r * w + c) as usize + 1) * k];
                dst.fill(0.0);
                for (j, kv) in kernel.iter().enumerate() {
                    let o = j as isize - radius;
                    let (rr, cc) = if horizontal {
                        (r, (c + o).clamp(0, w - 1))
                    } else {
                        ((r + o).clamp(0, h - 1), c)
                    };
                    let s = &src[((rr * w + cc) as usize) * k..((rr * w + cc) as usize + 1) * k];
                    dst.iter_mut().zip(s).for_each(|(d, v)| *d += kv * v);
                }
            }
        }
    }
}

/// Blur (pixels) chosen from the sphere's noise (see [`super::BuildOptions::smooth`]).
pub(super) fn auto_smooth(window: &Window, circle: &Circle, rim: f64) -> f64 {
    let (noise, typical) = estimate_noise(window, circle, rim);
    if typical.is_nan() || typical <= 0.0 {
        return 0.0;
    }
    let lights = (16.0 / window.stack.k.max(1) as f64).sqrt().min(1.0);
    let blur = (150.0 * (noise / typical) as f64 * lights).min(1.5);
    if blur < 0.3 {
        0.0
    } else {
        blur
    }
}

/// Noise of the sphere images, estimated from the residual of each pixel against the
/// mean of its 4 neighbours (σ ≈ 1.4826 · median |residual| / √1.25) over pixels well
/// inside the rim, and never below the quantisation's Δ/√12 (Δ the smallest step
/// between distinct sample values of a light, median over the lights; as
/// `spatial::levels`): on an 8-bit sphere the residuals measure nothing where whole
/// regions sit at one level (a metal's dark side), although every sample carries ±Δ/2.
/// Returns (σ, typical sample) in intensity units, the typical sample being the median
/// of the samples above 3σ.
pub fn estimate_noise(window: &Window, circle: &Circle, rim: f64) -> (f32, f32) {
    let ws = &window.stack;
    let k = ws.k;
    let inner = circle.radius - rim - 2.0;
    let (gcx, gcy) = (
        circle.cx - 0.5 - window.col0 as f64,
        circle.cy - 0.5 - window.row0 as f64,
    );
    let mut res = Vec::new();
    let mut values = Vec::new();
    for r in 1..ws.height.saturating_sub(1) {
        for c in 1..ws.width.saturating_sub(1) {
            if ((c as f64 - gcx).powi(2) + (r as f64 - gcy).powi(2)).sqrt() >= inner {
                continue;
            }
            let (p, u, d) = (ws.pixel(r, c), ws.pixel(r - 1, c), ws.pixel(r + 1, c));
            let (lf, rt) = (ws.pixel(r, c - 1), ws.pixel(r, c + 1));
            for i in 0..k {
                values.push(p[i]);
                res.push((p[i] - 0.25 * (u[i] + d[i] + lf[i] + rt[i])).abs());
            }
        }
    }
    if res.is_empty() {
        return (0.0, 0.0);
    }
    let quantisation = quantisation_step(&values, k) / 12f32.sqrt();
    let sigma = (1.4826 * median(&mut res).unwrap_or(0.0) / 1.25f32.sqrt()).max(quantisation);
    let mut lit: Vec<f32> = values.into_iter().filter(|&v| v > 3.0 * sigma).collect();
    (sigma, median(&mut lit).unwrap_or(0.0))
}

/// Median over the `k` lights of `values` (pixel-major, K per pixel) of the smallest
/// positive difference between two distinct values of the light; 0 when no light has
/// two distinct values.
fn quantisation_step(values: &[f32], k: usize) -> f32 {
    let mut per_light: Vec<Vec<f32>> = (0..k)
        .map(|l| {
            (values.iter().skip(l).step_by(k))
                .copied()
                .filter(|v| v.is_finite())
                .collect()
        })
        .collect();
    median_smallest_gap(per_light.iter_mut(), 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere r 30 with a sharp lobe per light (most samples dark), 8-bit or float.
    fn lobed_sphere(bits8: bool) -> (Window, Circle) {
        let (w, k) = (64usize, 4usize);
        let circle = Circle {
            cx: 32.0,
            cy: 32.0,
            radius: 30.0,
        };
        let mut stack = ImageStack::zeros(w, w, k);
        for r in 0..w {
            for c in 0..w {
                let (x, y) = (
                    (c as f64 + 0.5 - 32.0) / 30.0,
                    (32.0 - r as f64 - 0.5) / 30.0,
                );
                let z = (1.0 - x * x - y * y).max(0.0).sqrt();
                for (l, v) in stack.pixel_flat_mut(r * w + c).iter_mut().enumerate() {
                    let a = l as f64 * 1.5;
                    let d = (0.5 * a.cos() * x + 0.5 * a.sin() * y + 0.87 * z).max(0.0);
                    let i = d.powi(40) as f32;
                    *v = if bits8 {
                        (i * 255.0).round() / 255.0
                    } else {
                        i
                    };
                }
            }
        }
        let window = Window {
            col0: 0,
            row0: 0,
            stack,
        };
        (window, circle)
    }

    #[test]
    fn quantised_sphere_noise_is_at_least_the_quantisation() {
        let floor = 1.0 / 255.0 / 12f32.sqrt();
        let (window, circle) = lobed_sphere(true);
        let (sigma, _) = estimate_noise(&window, &circle, 2.0);
        assert!(sigma >= 0.999 * floor, "{sigma} against {floor}");
        // the same sphere in floats: smooth, no step to floor it
        let (window, circle) = lobed_sphere(false);
        let (sigma, _) = estimate_noise(&window, &circle, 2.0);
        assert!(sigma < 0.1 * floor, "{sigma}");
    }
}
