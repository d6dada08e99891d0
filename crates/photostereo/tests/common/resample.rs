//! Resampling a sphere's photographs to another scale (area averaging) and the analytic
//! truth of the resampled sphere: the "same sphere at another size" cases of
//! `lut_shared.rs` and `lut_camera_ball.rs`.

use photostereo::image::{ImageStack, Mask, NormalMap};
use photostereo::sphere::Circle;

/// Resample `stack` by `s` about the circle centre into a `width` × `height` image whose
/// pixel (r, c) covers the source box of side 1/s around (cx + (c + ½ − cx)/s, …),
/// averaged exactly over the source pixels it overlaps (area averaging).
pub fn rescale(stack: &ImageStack, c: &Circle, s: f64, width: usize, height: usize) -> ImageStack {
    let k = stack.k;
    let mut out = ImageStack::zeros(width, height, k);
    out.names = stack.names.clone();
    let half = 0.5 / s;
    let mut acc = vec![0.0f64; k];
    for r in 0..height {
        for col in 0..width {
            let x = c.cx + (col as f64 + 0.5 - c.cx) / s;
            let y = c.cy + (r as f64 + 0.5 - c.cy) / s;
            acc.fill(0.0);
            let mut area = 0.0;
            let (x0, x1, y0, y1) = (x - half, x + half, y - half, y + half);
            for sr in (y0.floor().max(0.0) as usize)..(y1.ceil() as usize).min(stack.height) {
                let wy = (y1.min(sr as f64 + 1.0) - y0.max(sr as f64)).max(0.0);
                for sc in (x0.floor().max(0.0) as usize)..(x1.ceil() as usize).min(stack.width) {
                    let wx = (x1.min(sc as f64 + 1.0) - x0.max(sc as f64)).max(0.0);
                    for (a, v) in acc.iter_mut().zip(stack.pixel(sr, sc)) {
                        *a += wx * wy * *v as f64;
                    }
                    area += wx * wy;
                }
            }
            for (d, a) in out.pixel_flat_mut(r * width + col).iter_mut().zip(&acc) {
                *d = (a / area.max(1e-12)) as f32;
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
    (width, height): (usize, usize),
    support: f64,
) -> ImageStack {
    let k = stack.k;
    let mut out = ImageStack::zeros(width, height, k);
    out.names = stack.names.clone();
    let tent = |d: f64| (1.0 - d.abs() / support).max(0.0);
    // the source pixels (index i, centre i + ½) within `support` of x
    let span = |x: f64, n: usize| {
        let lo = (x - support - 0.5).ceil().max(0.0) as usize;
        let hi = ((x + support - 0.5).floor().max(-1.0) + 1.0) as usize;
        lo..hi.min(n)
    };
    let mut acc = vec![0.0f64; k];
    for r in 0..height {
        for col in 0..width {
            let x = c.cx + (col as f64 + 0.5 - c.cx) / s;
            let y = c.cy + (r as f64 + 0.5 - c.cy) / s;
            acc.fill(0.0);
            let mut total = 0.0;
            for sr in span(y, stack.height) {
                let wy = tent(sr as f64 + 0.5 - y);
                for sc in span(x, stack.width) {
                    let wt = wy * tent(sc as f64 + 0.5 - x);
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
