//! Analytic test surfaces with exact gradients, and error measures, shared by the
//! integration tests.

use photostereo::image::{gradient_to_normal, pixel_to_xy};
use photostereo::integrate::{label_components, Method, Options};
use photostereo::{DepthMap, GrayImage, Image, Mask, NormalMap};

/// A surface sampled at pixel centres: exact depth and exact gradients (camera frame).
pub struct Surface {
    pub w: usize,
    pub h: usize,
    pub depth: Vec<f64>,
    pub p: GrayImage,
    pub q: GrayImage,
    pub mask: Mask,
}

impl Surface {
    /// Sample `f(x, y) -> (z, p, q)` at every pixel centre.
    pub fn sample(w: usize, h: usize, mask: Mask, f: impl Fn(f64, f64) -> (f64, f64, f64)) -> Self {
        let mut depth = vec![0.0; w * h];
        let mut p = GrayImage::filled(w, h, 0.0);
        let mut q = GrayImage::filled(w, h, 0.0);
        for r in 0..h {
            for c in 0..w {
                let (x, y) = pixel_to_xy(r, c, w, h);
                let (z, pp, qq) = f(x, y);
                let i = r * w + c;
                depth[i] = z;
                if mask.data[i] {
                    p.data[i] = pp as f32;
                    q.data[i] = qq as f32;
                }
            }
        }
        Surface {
            w,
            h,
            depth,
            p,
            q,
            mask,
        }
    }

    /// Unit normals n ∝ (−p, −q, 1) inside the mask, (0, 0, 0) outside.
    pub fn normals(&self) -> NormalMap {
        Image::from_fn(self.w, self.h, |r, c| {
            let i = r * self.w + c;
            if self.mask.data[i] {
                gradient_to_normal(self.p.data[i], self.q.data[i])
            } else {
                [0.0; 3]
            }
        })
    }

    /// Depth range over the mask.
    pub fn range(&self) -> f64 {
        let vals = self
            .depth
            .iter()
            .zip(&self.mask.data)
            .filter(|(_, &m)| m)
            .map(|(&v, _)| v);
        let (lo, hi) = vals.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
        hi - lo
    }

    /// RMSE over the mask after removing the best constant offset of every connected part.
    pub fn rmse(&self, depth: &DepthMap) -> f64 {
        let comps = label_components(&self.mask);
        let mut sum = vec![0.0; comps.count];
        let mut cnt = vec![0usize; comps.count];
        for i in 0..self.w * self.h {
            let l = comps.labels[i];
            if l != u32::MAX {
                assert!(
                    depth.data[i].is_finite(),
                    "NaN depth inside the mask at {i}"
                );
                sum[l as usize] += depth.data[i] as f64 - self.depth[i];
                cnt[l as usize] += 1;
            }
        }
        let (mut se, mut n) = (0.0, 0usize);
        for i in 0..self.w * self.h {
            let l = comps.labels[i];
            if l != u32::MAX {
                let off = sum[l as usize] / cnt[l as usize] as f64;
                se += (depth.data[i] as f64 - self.depth[i] - off).powi(2);
                n += 1;
            }
        }
        (se / n as f64).sqrt()
    }

    /// Add independent Gaussian noise of standard deviation `sigma` to p and q (mask only).
    pub fn add_noise(&mut self, sigma: f64, seed: u64) {
        let mut rng = Gauss::new(seed);
        for i in 0..self.w * self.h {
            if self.mask.data[i] {
                self.p.data[i] += (sigma * rng.next()) as f32;
                self.q.data[i] += (sigma * rng.next()) as f32;
            }
        }
    }
}

/// MATLAB's `peaks` and its exact partial derivatives (4th-order central differences
/// in f64, error ~1e-12).
pub fn peaks_fn(u: f64, v: f64) -> f64 {
    3.0 * (1.0 - u).powi(2) * (-u * u - (v + 1.0).powi(2)).exp()
        - 10.0 * (u / 5.0 - u.powi(3) - v.powi(5)) * (-u * u - v * v).exp()
        - 1.0 / 3.0 * (-(u + 1.0).powi(2) - v * v).exp()
}

fn d4(f: impl Fn(f64) -> f64, t: f64) -> f64 {
    let e = 1e-3;
    (-f(t + 2.0 * e) + 8.0 * f(t + e) - 8.0 * f(t - e) + f(t - 2.0 * e)) / (12.0 * e)
}

/// `peaks` over [−3, 3] across the width, depth amplitude W/24 pixels (slopes up to ~2).
pub fn peaks(w: usize, h: usize, mask: Mask) -> Surface {
    let s = 6.0 / w as f64;
    let a = w as f64 / 24.0;
    Surface::sample(w, h, mask, |x, y| {
        let (u, v) = (s * x, s * y);
        let z = a * peaks_fn(u, v);
        let p = a * s * d4(|t| peaks_fn(t, v), u);
        let q = a * s * d4(|t| peaks_fn(u, t), v);
        (z, p, q)
    })
}

/// A sphere cap z = sqrt(R² − (x−x0)² − (y−y0)²) (convex, highest at (x0, y0)).
pub fn sphere_cap(w: usize, h: usize, radius: f64, centre: (f64, f64), mask: Mask) -> Surface {
    Surface::sample(w, h, mask, |x, y| {
        let (dx, dy) = (x - centre.0, y - centre.1);
        let z = (radius * radius - dx * dx - dy * dy).max(1e-9).sqrt();
        (z, -dx / z, -dy / z)
    })
}

/// A disk mask of radius `rad` around the pixel-unit camera point (x0, y0).
pub fn disk(w: usize, h: usize, centre: (f64, f64), rad: f64) -> Mask {
    Mask::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        (x - centre.0).powi(2) + (y - centre.1).powi(2) < rad * rad
    })
}

/// Every method, with its command-line name.
pub fn all_methods() -> Vec<Method> {
    vec![
        Method::Path,
        Method::FrankotChellappa { reflect: false },
        Method::FrankotChellappa { reflect: true },
        Method::Dct,
        Method::Lsq,
    ]
}

pub fn opts(method: Method) -> Options {
    Options {
        method,
        ..Options::default()
    }
}

/// Standard normal deviates (xorshift64* + Box–Muller), deterministic: the draws the
/// integration tests' margins were measured on (`integrate_trust` depends on its draw:
/// with [`super::Rng`] BiNI's trust-weight gain vanishes, 0.272 → 0.287 px).
pub struct Gauss(u64);

impl Gauss {
    pub fn new(seed: u64) -> Self {
        Gauss(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        ((v >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    pub fn next(&mut self) -> f64 {
        let (a, b) = (self.uniform(), self.uniform());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    }
}
