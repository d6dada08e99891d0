//! Calibration sphere: its occluding circle and the analytic normal of each of its pixels.
//!
//! Circle coordinates are continuous image coordinates: pixel (row r, col c) covers
//! [c, c+1) × [r, r+1), so its centre is at (c + 0.5, r + 0.5). `cx` runs along columns
//! (right), `cy` along rows (down).
//!
//! Under orthographic projection the visible hemisphere of a sphere with centre
//! (cx, cy) and radius R has, at the pixel centre (u, v), the unit normal
//! n = ((u − cx)/R, −(v − cy)/R, √(1 − n_x² − n_y²)) — y flips because rows grow downward.

/// A circle in continuous image coordinates (pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    /// Centre, along columns (pixels, right).
    pub cx: f64,
    /// Centre, along rows (pixels, down).
    pub cy: f64,
    /// Radius in pixels.
    pub radius: f64,
}

impl Circle {
    /// Analytic unit normal of the sphere at the centre of pixel (row, col), or `None`
    /// outside the circle shrunk by `rim` pixels (grazing normals and mixed pixels).
    pub fn normal_at(&self, row: usize, col: usize, rim: f64) -> Option<[f32; 3]> {
        let nx = (col as f64 + 0.5 - self.cx) / self.radius;
        let ny = -(row as f64 + 0.5 - self.cy) / self.radius;
        let rho2 = nx * nx + ny * ny;
        let inner = ((self.radius - rim) / self.radius).max(0.0);
        if rho2 >= inner * inner {
            return None;
        }
        Some([nx as f32, ny as f32, (1.0 - rho2).sqrt() as f32])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_points_out_of_the_sphere_in_camera_frame() {
        let c = Circle {
            cx: 50.0,
            cy: 50.0,
            radius: 40.0,
        };
        // centre pixel faces the camera
        let n = c.normal_at(49, 49, 0.0).unwrap();
        assert!(n[2] > 0.999);
        // a pixel above the centre (smaller row) faces up (+y)
        let n = c.normal_at(20, 49, 0.0).unwrap();
        assert!(n[1] > 0.7 && n[0].abs() < 0.02);
        // a pixel right of the centre faces right (+x)
        let n = c.normal_at(49, 80, 0.0).unwrap();
        assert!(n[0] > 0.7);
        // outside, and inside the skipped rim
        assert!(c.normal_at(49, 95, 0.0).is_none());
        assert!(c.normal_at(49, 88, 2.0).is_none());
    }
}
