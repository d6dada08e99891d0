//! Resampling a sphere's photographs to another scale (area averaging) and the analytic
//! truth of the resampled sphere: the "same sphere at another size" cases of
//! `lut_shared.rs` and `lut_camera_ball.rs`.

use photostereo::image::{ImageStack, Mask, NormalMap};
use photostereo::sphere::Circle;
use std::ops::Range;

/// Resample `stack` by `s` about the circle centre into a `width` × `height` image whose
/// pixel (r, c) covers the source box of side 1/s around (cx + (c + ½ − cx)/s, …),
/// averaged exactly over the source pixels it overlaps (area averaging).
pub fn rescale(stack: &ImageStack, c: &Circle, s: f64, width: usize, height: usize) -> ImageStack {
    let half = 0.5 / s;
    // the source pixels [i, i + 1) the box [x − half, x + half] overlaps, and by how much
    let span = |x: f64, n: usize| {
        ((x - half).floor().max(0.0) as usize)..((x + half).ceil() as usize).min(n)
    };
    let overlap =
        |x: f64, i: usize| ((x + half).min(i as f64 + 1.0) - (x - half).max(i as f64)).max(0.0);
    resample(stack, c, s, (width, height), span, overlap)
}

/// Resample `stack` by `s` about the circle centre with a separable filter: target pixel
/// (r, c) sits at (x, y) = (cx + (c + ½ − cx)/s, cy + (r + ½ − cy)/s) in the source, and
/// is the mean of the source pixels in `span(x, width)` × `span(y, height)` weighted by
/// `weight(x, column) · weight(y, row)`.
fn resample(
    stack: &ImageStack,
    c: &Circle,
    s: f64,
    (width, height): (usize, usize),
    span: impl Fn(f64, usize) -> Range<usize>,
    weight: impl Fn(f64, usize) -> f64,
) -> ImageStack {
    let k = stack.k;
    let mut out = ImageStack::zeros(width, height, k);
    out.names = stack.names.clone();
    let mut acc = vec![0.0f64; k];
    for r in 0..height {
        for col in 0..width {
            let x = c.cx + (col as f64 + 0.5 - c.cx) / s;
            let y = c.cy + (r as f64 + 0.5 - c.cy) / s;
            acc.fill(0.0);
            let mut total = 0.0;
            for sr in span(y, stack.height) {
                let wy = weight(y, sr);
                for sc in span(x, stack.width) {
                    let wt = weight(x, sc) * wy;
                    for (a, v) in acc.iter_mut().zip(stack.pixel(sr, sc)) {
                        *a += wt * *v as f64;
                    }
                    total += wt;
                }
            }
            for (d, a) in out.pixel_flat_mut(r * width + col).iter_mut().zip(&acc) {
                *d = (a / total.max(1e-12)) as f32;
            }
        }
    }
    out
}

/// The sphere's analytic normals and the mask of pixels whose centre lies at least
/// `inset` px inside the circle.
pub fn sphere_truth(c: &Circle, width: usize, height: usize, inset: f64) -> (Mask, NormalMap) {
    let mut mask = Mask::filled(width, height, false);
    let mut normals = NormalMap::filled(width, height, [0.0; 3]);
    for r in 0..height {
        for col in 0..width {
            let nx = (col as f64 + 0.5 - c.cx) / c.radius;
            let ny = -(r as f64 + 0.5 - c.cy) / c.radius;
            let rho = (nx * nx + ny * ny).sqrt();
            if rho * c.radius <= c.radius - inset {
                *mask.get_mut(r, col) = true;
                let nz = (1.0 - rho * rho).max(0.0).sqrt();
                *normals.get_mut(r, col) = [nx as f32, ny as f32, nz as f32];
            }
        }
    }
    (mask, normals)
}

/// Resample `stack` by `s` about the circle centre as [`rescale`] does, but with a tent
/// filter of half-width `support` source pixels: each target pixel is the weighted
/// mean of the source pixels whose centres lie within `support` of its centre's
/// position in the source, weighted by 1 − distance/support along each axis. With
/// `support` = 1 this is plain bilinear interpolation at that position; with
/// `support` = 1/s it is the antialiased bilinear of common image libraries (Pillow's
/// `resize(..., BILINEAR)` when shrinking).
pub fn rescale_tent(
    stack: &ImageStack,
    c: &Circle,
    s: f64,
    size: (usize, usize),
    support: f64,
) -> ImageStack {
    // the source pixels (index i, centre i + ½) within `support` of x
    let span = |x: f64, n: usize| {
        let lo = (x - support - 0.5).ceil().max(0.0) as usize;
        let hi = ((x + support - 0.5).floor().max(-1.0) + 1.0) as usize;
        lo..hi.min(n)
    };
    let tent = |x: f64, i: usize| (1.0 - (i as f64 + 0.5 - x).abs() / support).max(0.0);
    resample(stack, c, s, size, span, tent)
}
