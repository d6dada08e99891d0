//! Test-only sphere raster shared by the sphere, Lambertian and light-calibration
//! tests: an area-sampled (supersampled) sphere under distant lights, optionally with
//! a Blinn–Phong specular lobe, a grey background and Gaussian noise.

use super::Rng;
use photostereo::image::{GrayImage, Image, ImageStack};
use photostereo::sphere::Circle;

#[derive(Clone)]
pub struct Scene {
    pub width: usize,
    pub height: usize,
    pub circle: Circle,
    pub lights: Vec<[f32; 3]>,
    pub albedo: f32,
    pub background: f32,
    /// Blinn–Phong (k_s, exponent); k_s = 0 for pure Lambertian.
    pub specular: (f32, f32),
    /// Mirror sphere: a light of this angular radius (radians) seen in reflection; 0 = off.
    pub mirror_light_radius: f32,
    pub noise_sigma: f32,
    pub supersample: usize,
    pub seed: u64,
}

impl Default for Scene {
    fn default() -> Self {
        Scene {
            width: 160,
            height: 140,
            circle: Circle {
                cx: 81.37,
                cy: 68.81,
                radius: 50.23,
            },
            lights: ring_lights(8, 40.0),
            albedo: 0.8,
            background: 0.0,
            specular: (0.0, 1.0),
            mirror_light_radius: 0.0,
            noise_sigma: 0.0,
            supersample: 4,
            seed: 7,
        }
    }
}

/// `k` unit lights at `polar_deg` from the view axis, evenly spread in azimuth.
pub fn ring_lights(k: usize, polar_deg: f32) -> Vec<[f32; 3]> {
    let t = polar_deg.to_radians();
    (0..k)
        .map(|i| {
            let a = i as f32 / k as f32 * std::f32::consts::TAU + 0.3;
            [t.sin() * a.cos(), t.sin() * a.sin(), t.cos()]
        })
        .collect()
}

/// `k` lights spread over the cap within `max_polar_deg` of the view axis (golden spiral).
pub fn spiral_lights(k: usize, max_polar_deg: f32) -> Vec<[f32; 3]> {
    let cos_max = max_polar_deg.to_radians().cos();
    (0..k)
        .map(|i| {
            let z = 1.0 - (1.0 - cos_max) * (i as f32 + 0.5) / k as f32;
            let s = (1.0 - z * z).sqrt();
            let a = i as f32 * 2.399_963;
            [s * a.cos(), s * a.sin(), z]
        })
        .collect()
}

/// Shading of the sphere point with normal `n` under light `l`.
fn shade(scene: &Scene, n: [f32; 3], l: [f32; 3]) -> f32 {
    let ndl = n[0] * l[0] + n[1] * l[1] + n[2] * l[2];
    if scene.mirror_light_radius > 0.0 {
        // reflected view ray r = 2 (n·v) n − v, v = (0,0,1)
        let r = [
            2.0 * n[2] * n[0],
            2.0 * n[2] * n[1],
            2.0 * n[2] * n[2] - 1.0,
        ];
        let c = r[0] * l[0] + r[1] * l[1] + r[2] * l[2];
        return if c >= scene.mirror_light_radius.cos() {
            1.0
        } else {
            0.02
        };
    }
    let mut v = scene.albedo * ndl.max(0.0);
    let (ks, e) = scene.specular;
    if ks > 0.0 && ndl > 0.0 {
        let h = photostereo::image::normalize([l[0], l[1], l[2] + 1.0]);
        let ndh = (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]).max(0.0);
        v += ks * ndh.powf(e);
    }
    v
}

/// Unit normal of the sphere at continuous image point (x, y), or None outside.
pub fn sphere_normal(c: &Circle, x: f64, y: f64) -> Option<[f32; 3]> {
    let nx = (x - c.cx) / c.radius;
    let ny = -(y - c.cy) / c.radius;
    let r2 = nx * nx + ny * ny;
    (r2 < 1.0).then(|| [nx as f32, ny as f32, (1.0 - r2).sqrt() as f32])
}

/// Render one image per light.
pub fn render(scene: &Scene) -> ImageStack {
    let mut rng = Rng(scene.seed);
    let ss = scene.supersample.max(1);
    let images: Vec<GrayImage> = scene
        .lights
        .iter()
        .map(|&l| {
            Image::from_fn(scene.width, scene.height, |r, c| {
                let mut acc = 0.0;
                for i in 0..ss {
                    for j in 0..ss {
                        let x = c as f64 + (j as f64 + 0.5) / ss as f64;
                        let y = r as f64 + (i as f64 + 0.5) / ss as f64;
                        acc += match sphere_normal(&scene.circle, x, y) {
                            Some(n) => shade(scene, n, l),
                            None => scene.background,
                        };
                    }
                }
                acc / (ss * ss) as f32 + scene.noise_sigma * rng.gauss()
            })
        })
        .collect();
    ImageStack::from_images(&images).unwrap()
}

/// Paint bright disks (value `v`, radius `rad`) at the given centres in every image.
pub fn add_blobs(stack: &mut ImageStack, centres: &[(f64, f64)], rad: f64, v: f32) {
    let (w, h, k) = (stack.width, stack.height, stack.k);
    for r in 0..h {
        for c in 0..w {
            let (x, y) = (c as f64 + 0.5, r as f64 + 0.5);
            if centres
                .iter()
                .any(|&(bx, by)| (x - bx).powi(2) + (y - by).powi(2) < rad * rad)
            {
                for i in 0..k {
                    stack.data[(r * w + c) * k + i] = v;
                }
            }
        }
    }
}

/// Load a directory of 8/16-bit PNGs listed in `filenames.txt` as a grey stack in [0, 1].
pub fn load_png_dir(dir: &std::path::Path) -> ImageStack {
    let names = std::fs::read_to_string(dir.join("filenames.txt")).unwrap();
    let images: Vec<GrayImage> = names
        .split_whitespace()
        .map(|n| {
            let img = image::open(dir.join(n)).unwrap().to_luma32f();
            Image::from_vec(img.width() as usize, img.height() as usize, img.into_raw()).unwrap()
        })
        .collect();
    ImageStack::from_images(&images).unwrap()
}
