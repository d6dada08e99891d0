//! Cast shadows by ray marching over the analytic height field.
//!
//! From the surface point above the centre of pixel (r, c), at height z₀, a ray goes
//! toward the light l = (l_x, l_y, l_z): per unit of horizontal travel it moves
//! (l_x, l_y)/‖l_xy‖ in camera (x, y) — i.e. (+l_x, −l_y) in (column, row), since rows
//! grow downward — and rises by l_z/‖l_xy‖. It advances in steps of [`STEP`] pixels and
//! the point is in cast shadow when the surface height at a step exceeds the ray.
//!
//! Heights are the shape's own closed form ([`Shape::height`]), not an interpolation of
//! the sampled depth map: the shadows are exact up to the step (features narrower than
//! half a pixel can be stepped over), there is no false self-shadowing from chords of
//! the sampled surface at grazing angles, and the flat rims of the bowl and the groove
//! continue beyond the image border as the analytic shape does.
//! The march stops when the ray rises above the highest point of the shape, or after a
//! horizontal distance of 2·(W + H) (for lights at or below the horizon).

use super::shapes::Shape;

/// Horizontal step of the march (pixels).
pub const STEP: f64 = 0.5;
/// Tolerance in height before a sample counts as an occluder (pixels).
pub const EPS: f64 = 1e-6;

/// The height field the rays march over.
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
    pub fn in_shadow(&self, row: usize, col: usize, l: [f32; 3]) -> bool {
        let (x0, y0) = crate::image::pixel_to_xy(row, col, self.width, self.height);
        let z0 = self.shape.height(x0, y0);
        let (lx, ly, lz) = (l[0] as f64, l[1] as f64, l[2] as f64);
        let horiz = (lx * lx + ly * ly).sqrt();
        if !z0.is_finite() || horiz < 1e-9 {
            return false;
        }
        let (dx, dy, dz) = (lx / horiz * STEP, ly / horiz * STEP, lz / horiz * STEP);
        let max_steps = (2.0 * (self.width + self.height) as f64 / STEP) as usize + 2;
        for i in 1..=max_steps {
            let t = i as f64;
            let z = z0 + t * dz;
            if z > self.max_z + EPS {
                return false;
            }
            if self.shape.height(x0 + t * dx, y0 + t * dy) > z + EPS {
                return true;
            }
        }
        false
    }
}
