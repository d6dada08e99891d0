//! Analytic scenes for the lookup-table tests (no dependence on the renderer):
//! a calibration sphere and a smooth target shaded by the same closed-form BRDF.

use super::{angle_deg, Rng};
use photostereo::image::{dot3, normalize, ImageStack, Mask, NormalMap};
use photostereo::sphere::Circle;

/// A closed-form reflectance: diffuse albedo `kd` + Blinn–Phong lobe `ks`·(n·h)^`shininess`.
#[derive(Clone, Copy, Debug)]
pub struct Brdf {
    pub kd: f32,
    pub ks: f32,
    pub shininess: f32,
}

/// `k` lights on two rings around the view direction.
pub fn lights(k: usize) -> Vec<[f32; 3]> {
    (0..k)
        .map(|i| {
            let ring = i % 2;
            let elev = if ring == 0 { 50f32 } else { 70f32 }.to_radians();
            let az = (i as f32 / k as f32) * std::f32::consts::TAU + 0.3;
            normalize([elev.cos() * az.cos(), elev.cos() * az.sin(), elev.sin()])
        })
        .collect()
}

/// The K intensities of a surface with normal `n`.
pub fn shade(n: [f32; 3], lights: &[[f32; 3]], brdf: Brdf, albedo: f32, out: &mut [f32]) {
    for (o, l) in out.iter_mut().zip(lights) {
        let nl = dot3(n, *l);
        if nl <= 0.0 {
            *o = 0.0;
            continue;
        }
        let h = normalize([l[0], l[1], l[2] + 1.0]);
        let nh = dot3(n, h).max(0.0);
        *o = albedo * brdf.kd * nl + brdf.ks * nh.powf(brdf.shininess) * nl;
    }
}

/// A `size`² image of a sphere of `radius` centred in it, shaded at pixel centres.
pub fn sphere(size: usize, radius: f64, lights: &[[f32; 3]], brdf: Brdf) -> (ImageStack, Circle) {
    let k = lights.len();
    let circle = Circle {
        cx: size as f64 / 2.0 + 0.3,
        cy: size as f64 / 2.0 - 0.2,
        radius,
    };
    let mut stack = ImageStack::zeros(size, size, k);
    for r in 0..size {
        for c in 0..size {
            if let Some(n) = circle.normal_at(r, c, 0.0) {
                shade(n, lights, brdf, 1.0, stack.pixel_flat_mut(r * size + c));
            }
        }
    }
    (stack, circle)
}

/// A `size`² target: a sum of Gaussian bumps on a plane, with its exact normals.
pub fn bumps(
    size: usize,
    lights: &[[f32; 3]],
    brdf: Brdf,
    albedo: &dyn Fn(usize, usize) -> f32,
) -> (ImageStack, Mask, NormalMap) {
    let k = lights.len();
    let mut stack = ImageStack::zeros(size, size, k);
    let mut normals = NormalMap::filled(size, size, [0.0; 3]);
    let s = size as f32;
    let bumps = [
        (0.3f32, 0.35f32, 0.45f32, 0.16f32),
        (0.7, 0.6, -0.3, 0.12),
        (0.45, 0.75, 0.35, 0.1),
    ];
    for r in 0..size {
        for c in 0..size {
            let (x, y) = (c as f32 + 0.5, r as f32 + 0.5);
            let (mut dzdx, mut dzdy) = (0.0f32, 0.0f32);
            for (bx, by, amp, sig) in bumps {
                let (dx, dy) = (x - bx * s, y - by * s);
                let sg = sig * s;
                let g = amp * s * (-(dx * dx + dy * dy) / (2.0 * sg * sg)).exp();
                dzdx += -g * dx / (sg * sg);
                dzdy += -g * dy / (sg * sg);
            }
            // dzdy is along rows (down); camera y is up
            let n = normalize([-dzdx, dzdy, 1.0]);
            *normals.get_mut(r, c) = n;
            shade(
                n,
                lights,
                brdf,
                albedo(r, c),
                stack.pixel_flat_mut(r * size + c),
            );
        }
    }
    (stack, Mask::full(size, size), normals)
}

/// Mean and median angular error over the mask.
pub fn errors(est: &NormalMap, truth: &NormalMap, mask: &Mask) -> (f64, f64) {
    let mut e: Vec<f64> = (0..mask.data.len())
        .filter(|&i| mask.data[i])
        .map(|i| angle_deg(est.data[i], truth.data[i]))
        .collect();
    e.sort_by(|a, b| a.total_cmp(b));
    let mean = e.iter().sum::<f64>() / e.len() as f64;
    (mean, e[e.len() / 2])
}

/// Deterministic Gaussian noise of standard deviation `sigma` added to every sample.
pub fn add_noise(stack: &mut ImageStack, sigma: f32, seed: u64) {
    let mut rng = Rng(seed);
    for v in stack.data.iter_mut() {
        *v += sigma * rng.gauss();
    }
}
