//! Test-only helpers shared by the tests of the sphere's circle on `../shared` data
//! (`sphere_shared`, `sphere_truth`): the circle of a dataset's true normals, circle
//! errors, a Gaussian blur and 8-bit quantisation of image stacks.

use super::solve3;
use photostereo::image::{GrayImage, Image, ImageStack};
use photostereo::io;
use photostereo::sphere::Circle;
use std::path::Path;

/// Least-squares circle u = cx + R n_x, v = cy − R n_y (pixel (r, c) centred at
/// (c + 0.5, r + 0.5)) over the pixels of `dir/normal_gt.npy` whose unit normal has
/// n_z ≥ `min_nz`; its RMS residual (px) and the pixel count.
pub fn normals_circle(dir: &Path, min_nz: f64) -> (Circle, f64, usize) {
    let n = io::read_normals_npy(&dir.join("normal_gt.npy")).unwrap();
    let mut pts = Vec::new();
    let (mut a, mut b) = ([[0.0f64; 3]; 3], [0.0f64; 3]);
    for r in 0..n.height {
        for c in 0..n.width {
            let v = n.get(r, c).map(f64::from);
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if !(0.5..1.5).contains(&len) || v[2] / len < min_nz {
                continue;
            }
            let (nx, ny) = (v[0] / len, v[1] / len);
            let (u, w) = (c as f64 + 0.5, r as f64 + 0.5);
            for (row, rhs) in [([1.0, 0.0, nx], u), ([0.0, 1.0, -ny], w)] {
                for i in 0..3 {
                    for j in 0..3 {
                        a[i][j] += row[i] * row[j];
                    }
                    b[i] += row[i] * rhs;
                }
            }
            pts.push((nx, ny, u, w));
        }
    }
    let x = solve3(a, b);
    let c = Circle {
        cx: x[0],
        cy: x[1],
        radius: x[2],
    };
    let ss: f64 = pts
        .iter()
        .map(|&(nx, ny, u, w)| {
            (u - c.cx - c.radius * nx).powi(2) + (w - c.cy + c.radius * ny).powi(2)
        })
        .sum();
    (c, (ss / (2 * pts.len()) as f64).sqrt(), pts.len())
}

/// Centre distance and (signed) radius difference of `c` from `t` (px).
pub fn errors(c: &Circle, t: &Circle) -> (f64, f64) {
    ((c.cx - t.cx).hypot(c.cy - t.cy), c.radius - t.radius)
}

/// Separable Gaussian blur of σ `sigma` px (edges clamped).
pub fn gaussian_blur(img: &GrayImage, sigma: f64) -> GrayImage {
    if sigma <= 0.0 {
        return img.clone();
    }
    let half = (4.0 * sigma).ceil() as isize;
    let k: Vec<f64> = (-half..=half)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let norm: f64 = k.iter().sum();
    let (w, h) = (img.width as isize, img.height as isize);
    let pass = |src: &GrayImage, horizontal: bool| {
        Image::from_fn(img.width, img.height, |r, c| {
            let mut acc = 0.0;
            for (j, kv) in k.iter().enumerate() {
                let o = j as isize - half;
                let (rr, cc) = if horizontal {
                    (r as isize, (c as isize + o).clamp(0, w - 1))
                } else {
                    ((r as isize + o).clamp(0, h - 1), c as isize)
                };
                acc += kv * *src.get(rr as usize, cc as usize) as f64;
            }
            (acc / norm) as f32
        })
    };
    pass(&pass(img, true), false)
}

/// Each image blurred by σ `sigma` px, then (when `bits8`) scaled so that the stack's
/// maximum is 255 and rounded to integers (values kept in that scale / 255).
pub fn degrade(stack: &ImageStack, sigma: f64, bits8: bool) -> ImageStack {
    let peak = stack.data.iter().cloned().fold(0.0f32, f32::max).max(1e-12);
    let images: Vec<GrayImage> = (0..stack.k)
        .map(|k| {
            let mut img = gaussian_blur(&stack.image(k), sigma);
            if bits8 {
                for v in img.data.iter_mut() {
                    *v = (*v / peak * 255.0).round().clamp(0.0, 255.0) / 255.0 * peak;
                }
            }
            img
        })
        .collect();
    ImageStack::from_images(&images).unwrap()
}
