//! Small analytic height fields shared by the interreflection tests.

use photostereo::image::{dot3, gradient_to_normal, pixel_to_xy, DepthMap, GrayImage, ImageStack};
use photostereo::NormalMap;

/// A height field z(x, y) with its gradient, sampled at pixel centres.
pub fn sample(
    w: usize,
    h: usize,
    f: impl Fn(f64, f64) -> (f64, f64, f64),
) -> (DepthMap, NormalMap) {
    let z = DepthMap::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        f(x, y).0 as f32
    });
    let n = NormalMap::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        let (_, p, q) = f(x, y);
        gradient_to_normal(p as f32, q as f32)
    });
    (z, n)
}

/// Spherical-cap bowl of opening radius `radius` and depth `depth` (rim at z = 0, flat rim
/// outside): returns (z, p, q).
pub fn bowl(radius: f64, depth: f64) -> impl Fn(f64, f64) -> (f64, f64, f64) {
    let rs = (radius * radius + depth * depth) / (2.0 * depth);
    move |x, y| {
        let r2 = x * x + y * y;
        if r2 >= radius * radius {
            return (0.0, 0.0, 0.0);
        }
        let s = (rs * rs - r2).sqrt();
        (-depth + (rs - s), x / s, y / s)
    }
}

/// A ring-shaped trough around a central hill: Gaussian ring of depth `amp` at radius `r0`,
/// width `sigma`. Points across the hill do not see each other.
pub fn trough(r0: f64, sigma: f64, amp: f64) -> impl Fn(f64, f64) -> (f64, f64, f64) {
    move |x, y| {
        let rho = (x * x + y * y).sqrt().max(1e-9);
        let e = (-(rho - r0).powi(2) / (2.0 * sigma * sigma)).exp();
        let z = -amp * e;
        let dz = amp * e * (rho - r0) / (sigma * sigma);
        (z, dz * x / rho, dz * y / rho)
    }
}

/// Direct Lambertian images ρ·max(0, n·l) (no cast shadows) for the given lights.
pub fn direct(normals: &NormalMap, albedo: f32, lights: &[[f32; 3]]) -> ImageStack {
    let (w, h, k) = (normals.width, normals.height, lights.len());
    let mut s = ImageStack::zeros(w, h, k);
    for (p, n) in normals.data.iter().enumerate() {
        for (i, l) in lights.iter().enumerate() {
            s.data[p * k + i] = albedo * dot3(*n, *l).max(0.0);
        }
    }
    s
}

/// Uniform albedo map.
pub fn albedo(w: usize, h: usize, rho: f32) -> GrayImage {
    GrayImage::filled(w, h, rho)
}
