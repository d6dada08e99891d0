//! Cast shadows: exact tests on the analytic surface.
//!
//! A surface point P = (x₀, y₀, z₀) that faces the light l (n·l > 0) is in cast shadow
//! when the ray P + s·l (s > 0) passes below the surface somewhere.
//!
//! * **Sphere, blob** (z concave): never — the ray stays above the tangent plane at P,
//!   which lies above the whole surface.
//! * **Bowl** (sphere of radius R, centre C = (0, 0, R − d), cut by the plane z = 0):
//!   P lies on the sphere, so the ray leaves the ball again at s* = 2 (C − P)·l. If the
//!   exit point has z < 0 it hits the bowl wall (shadow); otherwise the ray crossed
//!   z = 0 inside the opening r < a and then stays above the rim plane (lit).
//! * **V-groove** (profile z(x) only): in the (u, z) plane with u = sign(l_x)·x the ray
//!   has slope m = l_z/|l_x|. It can only meet the wall on the far side, z = −d + u/t
//!   (t = tan(θ/2)), for u > 0: starting from height z_c above the crease at u = 0, it
//!   meets that wall at u* = (z_c + d)/(1/t − m) when m < 1/t, a shadow iff u* < d·t.
//! * **Vase**: ray marching. From (x₀, y₀) the ray advances horizontally along
//!   (l_x, l_y)/‖l_xy‖ in camera (x, y) — i.e. (+l_x, −l_y) in (column, row) since rows
//!   grow downward — rising by m = l_z/‖l_xy‖ per pixel; shadow when the exact height
//!   ([`Shape::height`]) exceeds the ray. Steps are [`STEP`] pixels, or longer when that
//!   is provably safe: write height − ray = g_body(t) + g_bumps(t), where g_body (the
//!   ellipsoidal body minus the ray) is concave in t, so its slope from t on is at most
//!   its secant slope c just before t, and the Gaussian bumps change by at most
//!   S = Σ|a_i|·e^(−1/2)/σ_i per pixel, or by at most b'(t)·Δ + K·Δ²/2 over Δ pixels with
//!   K = Σ|a_i|/σ_i² (the largest second derivative of a Gaussian along a line). With
//!   g(t) < 0 the ray therefore stays above the surface for the next −g/(c + S) pixels
//!   and for the next Δ* pixels, the positive root of g + (c + b')Δ + KΔ²/2; if c + S ≤ 0
//!   it stays above forever. The march
//!   also stops when the ray leaves the elliptical outline (convex, never re-entered),
//!   rises above the highest point of the shape, or has gone 2·(W + H) pixels. Features
//!   narrower than the half-pixel step can be stepped over.
//!
//! Heights come from the shape's closed form, not an interpolation of the sampled depth
//! map: no false self-shadowing from chords of the sampled surface at grazing angles,
//! and the flat rims of the bowl and the groove continue beyond the image border.

use super::shapes::{Bump, Shape};

/// Horizontal step of the march (pixels).
pub const STEP: f64 = 0.5;
/// Tolerance in height before a sample counts as an occluder (pixels).
pub const EPS: f64 = 1e-6;

/// Cast-shadow tests over a shape rendered on a `width` x `height` image.
pub struct Occluder<'a> {
    shape: &'a Shape,
    width: usize,
    height: usize,
    max_z: f64,
}

impl<'a> Occluder<'a> {
    /// Occlusion tests over `shape` for a `width` x `height` image.
    pub fn new(shape: &'a Shape, width: usize, height: usize) -> Self {
        Occluder {
            shape,
            width,
            height,
            max_z: shape.max_height(),
        }
    }

    /// True when the surface point of pixel (row, col) is hidden from the light `l`.
    /// Meaningful for points that face the light (n·l > 0).
    pub fn in_shadow(&self, row: usize, col: usize, l: [f32; 3]) -> bool {
        let (x0, y0) = crate::image::pixel_to_xy(row, col, self.width, self.height);
        let l = [l[0] as f64, l[1] as f64, l[2] as f64];
        match *self.shape {
            Shape::Sphere { .. } | Shape::Blob { .. } => false,
            Shape::Bowl { radius, depth } => bowl_shadow(x0, y0, l, radius, depth),
            Shape::VGroove { angle_deg, depth } => groove_shadow(x0, l, angle_deg, depth),
            Shape::Vase {
                rx,
                ry,
                height,
                ref bumps,
            } => self.march_vase(x0, y0, l, (rx, ry, height), bumps),
        }
    }

    /// The plain ray march (see the module docs) with horizontal step `step` pixels,
    /// for any shape: the exact height at every step.
    pub fn march(&self, x0: f64, y0: f64, l: [f64; 3], step: f64) -> bool {
        let z0 = self.shape.height(x0, y0);
        let horiz = (l[0] * l[0] + l[1] * l[1]).sqrt();
        if !z0.is_finite() || horiz < 1e-9 {
            return false;
        }
        let (ux, uy, m) = (l[0] / horiz, l[1] / horiz, l[2] / horiz);
        let max_steps = (2.0 * (self.width + self.height) as f64 / step) as usize + 2;
        for i in 1..=max_steps {
            let t = i as f64 * step;
            let z = z0 + t * m;
            if z > self.max_z + EPS {
                return false;
            }
            if self.shape.height(x0 + t * ux, y0 + t * uy) > z + EPS {
                return true;
            }
        }
        false
    }

    /// The vase march with safe jumps (see the module docs).
    fn march_vase(
        &self,
        x0: f64,
        y0: f64,
        l: [f64; 3],
        body: (f64, f64, f64),
        bumps: &[Bump],
    ) -> bool {
        let z0 = self.shape.height(x0, y0);
        let horiz = (l[0] * l[0] + l[1] * l[1]).sqrt();
        if !z0.is_finite() || horiz < 1e-9 {
            return false;
        }
        let ray = VaseRay::new(
            [x0, y0, z0],
            [l[0] / horiz, l[1] / horiz, l[2] / horiz],
            body,
            bumps,
        );
        let max_t = 2.0 * (self.width + self.height) as f64;
        let (mut t, mut g) = (0.0, 0.0);
        while t < max_t {
            let dt = if g < 0.0 {
                match ray.safe_step(t, g) {
                    Some(dt) => dt.max(STEP),
                    None => return false, // the ray only gets further above the surface
                }
            } else {
                STEP
            };
            t += dt;
            let z = z0 + t * ray.dir[2];
            if z > self.max_z + EPS {
                return false;
            }
            let h = self.shape.height(x0 + t * ray.dir[0], y0 + t * ray.dir[1]);
            if h == f64::NEG_INFINITY {
                return false; // left the convex outline: never re-entered
            }
            g = h - z;
            if g > EPS {
                return true;
            }
        }
        false
    }
}

/// A shadow ray over a vase: origin (x₀, y₀, z₀), direction (u_x, u_y, m) per pixel of
/// horizontal travel, and the bounds that make long steps safe.
struct VaseRay<'a> {
    origin: [f64; 3],
    dir: [f64; 3],
    body: (f64, f64, f64),
    bumps: &'a [Bump],
    /// S = Σ|a_i|·e^(−1/2)/σ_i: largest slope of the bump sum along a line.
    bump_slope: f64,
    /// K = Σ|a_i|/σ_i²: largest |second derivative| of the bump sum along a line.
    bump_curv: f64,
}

impl<'a> VaseRay<'a> {
    fn new(origin: [f64; 3], dir: [f64; 3], body: (f64, f64, f64), bumps: &'a [Bump]) -> Self {
        let bump_slope = bumps
            .iter()
            .map(|b| b.amplitude.abs() * (-0.5f64).exp() / b.sigma)
            .sum();
        let bump_curv = bumps
            .iter()
            .map(|b| b.amplitude.abs() / (b.sigma * b.sigma))
            .sum();
        VaseRay {
            origin,
            dir,
            body,
            bumps,
            bump_slope,
            bump_curv,
        }
    }

    fn point(&self, t: f64) -> (f64, f64) {
        (
            self.origin[0] + t * self.dir[0],
            self.origin[1] + t * self.dir[1],
        )
    }

    /// Ellipsoidal body minus the ray height at t (concave in t).
    fn body_minus_ray(&self, t: f64) -> f64 {
        let (x, y) = self.point(t);
        let (rx, ry, hb) = self.body;
        let u = 1.0 - (x / rx).powi(2) - (y / ry).powi(2);
        hb * u.max(0.0).sqrt() - (self.origin[2] + t * self.dir[2])
    }

    /// Exact slope of the bump sum along the ray at t.
    fn bumps_slope_at(&self, t: f64) -> f64 {
        let (x, y) = self.point(t);
        let slope = |b: &Bump| {
            let (dx, dy) = (x - b.x, y - b.y);
            let s2 = b.sigma * b.sigma;
            let g = b.amplitude * (-(dx * dx + dy * dy) / (2.0 * s2)).exp();
            -g * (dx * self.dir[0] + dy * self.dir[1]) / s2
        };
        self.bumps.iter().map(slope).sum()
    }

    /// How far the ray at t, g = height − ray < 0, surely stays above the surface;
    /// `None` when it stays above for good. From t on, body − ray falls at least as fast
    /// as its secant c just before t (concavity); the bumps rise at most S per pixel
    /// (linear bound) or b'(t)·Δ + K·Δ²/2 (Taylor bound).
    fn safe_step(&self, t: f64, g: f64) -> Option<f64> {
        let delta = 0.125;
        let secant = (self.body_minus_ray(t) - self.body_minus_ray(t - delta)) / delta;
        let rate = secant + self.bump_slope;
        if rate <= 0.0 {
            return None;
        }
        let linear = -g / rate;
        if self.bump_curv <= 0.0 {
            return Some(linear);
        }
        let a = secant + self.bumps_slope_at(t);
        let quad = (-a + (a * a - 2.0 * self.bump_curv * g).sqrt()) / self.bump_curv;
        Some(if quad.is_finite() {
            linear.max(quad)
        } else {
            linear
        })
    }
}

fn bowl_shadow(x0: f64, y0: f64, l: [f64; 3], a: f64, d: f64) -> bool {
    if x0 * x0 + y0 * y0 >= a * a {
        return false; // on the rim plane, the highest level of the shape
    }
    let big_r = (a * a + d * d) / (2.0 * d);
    let z0 = (big_r - d) - (big_r * big_r - x0 * x0 - y0 * y0).sqrt();
    let to_centre = [-x0, -y0, big_r - d - z0];
    let s = 2.0 * (to_centre[0] * l[0] + to_centre[1] * l[1] + to_centre[2] * l[2]);
    s > 0.0 && z0 + s * l[2] < -EPS
}

fn groove_shadow(x0: f64, l: [f64; 3], angle_deg: f64, d: f64) -> bool {
    let t = (0.5 * angle_deg).to_radians().tan();
    let half = d * t;
    if x0.abs() >= half || l[0].abs() < 1e-12 {
        return false;
    }
    let u0 = x0 * l[0].signum();
    if u0 > 0.0 {
        return false; // climbing its own wall: lit whenever it faces the light
    }
    let m = l[2] / l[0].abs();
    if m >= 1.0 / t {
        return false;
    }
    let z0 = -d + x0.abs() / t;
    let zc = z0 - u0 * m;
    let u_hit = (zc + d) / (1.0 / t - m);
    u_hit < half - EPS
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::normalize;

    /// The closed forms agree with the generic march on the exact heights.
    #[test]
    fn closed_forms_match_marching() {
        let shapes = [
            Shape::Bowl {
                radius: 30.0,
                depth: 12.0,
            },
            Shape::Bowl {
                radius: 25.0,
                depth: 25.0,
            },
            Shape::VGroove {
                angle_deg: 90.0,
                depth: 15.0,
            },
            Shape::VGroove {
                angle_deg: 40.0,
                depth: 20.0,
            },
        ];
        let lights = [
            [1.0, 0.2, 0.5],
            [-0.7, 0.4, 0.9],
            [0.1, -1.0, 0.3],
            [-0.6, -0.5, 0.2],
            [0.9, 0.0, 1.2],
        ];
        for shape in &shapes {
            let occ = Occluder::new(shape, 80, 70);
            let (mut shadowed, mut missed, mut extra, mut total) = (0, 0, 0, 0);
            for l in lights.map(normalize) {
                let l32 = l;
                let l64 = [l[0] as f64, l[1] as f64, l[2] as f64];
                for r in 0..70 {
                    for c in 0..80 {
                        let (x, y) = crate::image::pixel_to_xy(r, c, 80, 70);
                        let n = shape.eval(x, y).unwrap().1;
                        if n[0] * l64[0] + n[1] * l64[1] + n[2] * l64[2] <= 1e-3 {
                            continue;
                        }
                        let exact = occ.in_shadow(r, c, l32);
                        total += 1;
                        shadowed += exact as usize;
                        let marched = occ.march(x, y, l64, 0.02);
                        missed += (exact && !marched) as usize;
                        extra += (!exact && marched) as usize;
                    }
                }
            }
            // A fine march (0.02 px) may step over a sliver thinner than its step (near
            // a vertical wall or the crease) but never invents a shadow.
            eprintln!("{shape:?}: shadowed {shadowed}, missed {missed} of {total}");
            assert!(shadowed > 100, "{shape:?}: {shadowed} shadowed");
            assert_eq!(extra, 0, "{shape:?}: march shadows {extra} lit points");
            assert!(
                missed * 1000 <= total,
                "{shape:?}: missed {missed} of {total}"
            );
        }
    }

    /// The vase march with safe jumps finds the shadows of a fine plain march.
    #[test]
    fn vase_jumps_match_a_fine_march() {
        let tower = Shape::Vase {
            rx: 45.0,
            ry: 40.0,
            height: 10.0,
            bumps: vec![
                Bump {
                    x: 5.0,
                    y: 3.0,
                    amplitude: 30.0,
                    sigma: 4.0,
                },
                Bump {
                    x: -12.0,
                    y: -10.0,
                    amplitude: -8.0,
                    sigma: 5.0,
                },
            ],
        };
        let preset = Shape::preset(crate::synth::ShapeKind::Vase, 96, 96);
        for (shape, min_shadowed) in [(preset, 25), (tower, 500)] {
            let occ = Occluder::new(&shape, 96, 96);
            let mut lights = crate::synth::default_lights(8).directions;
            lights.extend([[0.95, 0.0, 0.312], [-0.3, 0.9, 0.316]]);
            let (mut shadowed, mut missed, mut extra, mut total) = (0, 0, 0, 0);
            for l in &lights {
                let l64 = [l[0] as f64, l[1] as f64, l[2] as f64];
                for r in 0..96 {
                    for c in 0..96 {
                        let (x, y) = crate::image::pixel_to_xy(r, c, 96, 96);
                        let Some((_, n)) = shape.eval(x, y).filter(|_| (r + c) % 2 == 0) else {
                            continue;
                        };
                        if n[0] * l64[0] + n[1] * l64[1] + n[2] * l64[2] <= 1e-3 {
                            continue;
                        }
                        let fast = occ.in_shadow(r, c, *l);
                        let fine = occ.march(x, y, l64, 0.05);
                        total += 1;
                        shadowed += fine as usize;
                        missed += (fine && !fast) as usize;
                        extra += (fast && !fine) as usize;
                    }
                }
            }
            eprintln!("vase: shadowed {shadowed}, missed {missed}, extra {extra} of {total}");
            assert!(shadowed > min_shadowed, "{shadowed} shadowed");
            assert_eq!(extra, 0);
            assert!(missed * 1000 <= total, "missed {missed} of {total}");
        }
    }
}
