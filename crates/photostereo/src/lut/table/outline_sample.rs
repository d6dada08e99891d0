//! The calibration sphere's own outline as photographed ([`OutlineSample`]), kept with
//! the table so that a lookup can check its outline correction on pixels whose normals
//! are known.

use crate::image::ImageStack;
use crate::sphere::Circle;

/// The sphere's own outline: the pixels a mask drawn through its rim holds on the
/// silhouette (centre inside the circle, a 4-neighbour's centre outside it), with their
/// tuples as photographed (before any denoising) and the analytic normal at their
/// centres; at most [`MAX_OUTLINE_SAMPLE`] of them, evenly spread in row-major order.
/// [`crate::lut::Lookup`] checks on them whether the outline's coverage correction
/// ([`crate::lut::outline`]) helps on this camera and material before it corrects a
/// target's outline with it.
#[derive(Clone, Debug, PartialEq)]
pub struct OutlineSample {
    /// n × K tuples, pixel-major.
    pub tuples: Vec<f32>,
    /// The analytic unit normal at each pixel's centre (camera frame).
    pub normals: Vec<[f32; 3]>,
}

/// Most outline pixels a table keeps ([`OutlineSample`]).
pub const MAX_OUTLINE_SAMPLE: usize = 512;

impl OutlineSample {
    /// The outline pixels of the sphere `circle` in `stack` (see [`OutlineSample`]);
    /// `None` when there are none with finite samples.
    pub fn of(stack: &ImageStack, circle: &Circle) -> Option<OutlineSample> {
        let inside = |r: i64, c: i64| {
            let (x, y) = (c as f64 + 0.5 - circle.cx, r as f64 + 0.5 - circle.cy);
            x * x + y * y < circle.radius * circle.radius
        };
        let (w, h) = (stack.width as i64, stack.height as i64);
        let in_image = |r: i64, c: i64| r >= 0 && c >= 0 && r < h && c < w;
        let (r0, r1) = (
            circle.cy - circle.radius - 1.0,
            circle.cy + circle.radius + 1.0,
        );
        let (c0, c1) = (
            circle.cx - circle.radius - 1.0,
            circle.cx + circle.radius + 1.0,
        );
        let mut pixels = Vec::new();
        for r in (r0.floor().max(0.0) as i64)..(r1.ceil() as i64).min(h) {
            for c in (c0.floor().max(0.0) as i64)..(c1.ceil() as i64).min(w) {
                let next = [(r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)];
                let on_silhouette = inside(r, c)
                    && next.iter().all(|&(rr, cc)| in_image(rr, cc))
                    && next.iter().any(|&(rr, cc)| !inside(rr, cc));
                let finite = |px: &[f32]| px.iter().all(|v| v.is_finite());
                if on_silhouette && finite(stack.pixel(r as usize, c as usize)) {
                    pixels.push((r as usize, c as usize));
                }
            }
        }
        let step = pixels.len().div_ceil(MAX_OUTLINE_SAMPLE).max(1);
        let mut out = OutlineSample {
            tuples: Vec::new(),
            normals: Vec::new(),
        };
        for &(r, c) in pixels.iter().step_by(step) {
            out.tuples.extend_from_slice(stack.pixel(r, c));
            out.normals.push(covered_mean_normal(circle, r, c));
        }
        (!out.normals.is_empty()).then_some(out)
    }
}

/// The mean of the sphere's normals over the part of pixel (r, c) inside `circle`
/// (16 × 16 samples), normalised: the normal that a silhouette pixel's tuple c·I(n̄)
/// belongs to, and the one a renderer's or a scanner's true normal map gives it.
fn covered_mean_normal(circle: &Circle, r: usize, c: usize) -> [f32; 3] {
    const SUB: usize = 16;
    let mut sum = [0.0f64; 3];
    for i in 0..SUB * SUB {
        let x = c as f64 + ((i % SUB) as f64 + 0.5) / SUB as f64 - circle.cx;
        let y = circle.cy - r as f64 - ((i / SUB) as f64 + 0.5) / SUB as f64;
        let (nx, ny) = (x / circle.radius, y / circle.radius);
        let rho2 = nx * nx + ny * ny;
        if rho2 < 1.0 {
            let n = [nx, ny, (1.0 - rho2).sqrt()];
            sum.iter_mut().zip(n).for_each(|(s, v)| *s += v);
        }
    }
    let len = sum.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-12);
    sum.map(|v| (v / len) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A disc of radius 10.3 at (16.2, 15.7) in 32² images, value 1 inside (pixel centre).
    fn disc(k: usize) -> (ImageStack, Circle) {
        let circle = Circle {
            cx: 16.2,
            cy: 15.7,
            radius: 10.3,
        };
        let mut stack = ImageStack::zeros(32, 32, k);
        for r in 0..32 {
            for c in 0..32 {
                if circle.normal_at(r, c, 0.0).is_some() {
                    stack.pixel_flat_mut(r * 32 + c).fill(1.0);
                }
            }
        }
        (stack, circle)
    }

    #[test]
    fn the_sample_is_the_silhouette_with_the_covered_parts_mean_normals() {
        let (stack, circle) = disc(3);
        let s = OutlineSample::of(&stack, &circle).unwrap();
        assert_eq!(s.tuples.len(), 3 * s.normals.len());
        // a ring one pixel wide around a circle of radius 10.3: about 2π·10.3 / 1.2
        assert!((40..=90).contains(&s.normals.len()), "{}", s.normals.len());
        assert!(s.tuples.iter().all(|&v| v == 1.0), "only sphere pixels");
        for n in &s.normals {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-5);
            // silhouette pixels: the covered part's mean normal is steep, at most a
            // pixel and a half from the rim (ρ ≥ 1 − 1.5 / R)
            let rho = (n[0] * n[0] + n[1] * n[1]).sqrt();
            assert!(rho > 1.0 - 1.5 / 10.3 && rho < 1.0, "{n:?}");
        }
    }

    #[test]
    fn a_rim_pixels_covered_mean_normal_is_near_its_centres_and_short_of_the_rim() {
        // a pixel whose centre lies 0.3 px inside the rim on the +x axis: the mean over
        // its covered part (x from 70 to the rim at 70.8) stays on the axis, within 5% of
        // the centre's tilt and short of the horizon
        let circle = Circle {
            cx: 50.0,
            cy: 50.5,
            radius: 20.8,
        };
        let n = covered_mean_normal(&circle, 50, 70);
        let centre_rho = (70.5 - 50.0) / 20.8;
        let rho = (n[0] * n[0] + n[1] * n[1]).sqrt() as f64;
        assert!(
            rho > 0.95 * centre_rho && rho < 1.0,
            "{rho} vs {centre_rho}"
        );
        assert!(n[1].abs() < 1e-6 && n[0] > 0.0, "{n:?}");
    }

    #[test]
    fn at_most_the_cap_is_kept_and_nothing_on_an_empty_image() {
        let circle = Circle {
            cx: 150.0,
            cy: 150.0,
            radius: 140.0,
        };
        let mut stack = ImageStack::zeros(300, 300, 3);
        stack.data.fill(0.5);
        let s = OutlineSample::of(&stack, &circle).unwrap();
        assert!(s.normals.len() <= MAX_OUTLINE_SAMPLE && s.normals.len() > 300);
        let empty = ImageStack::zeros(0, 0, 3);
        assert!(OutlineSample::of(&empty, &circle).is_none());
    }
}
