//! A pinhole camera for perspective integration.
//!
//! Pixel (row r, column c) has its centre at image coordinates (u, v) = (c, r) (the
//! OpenCV convention, which DiLiGenT's and BiNI's `K.txt` use). A point at distance t
//! along the optical axis seen at that pixel is, in the camera frame of the crate
//! (x right, y up, z toward the camera),
//!
//! X = t (c − c_x)/f_x,  Y = −t (r − c_y)/f_y,  Z = −t.
//!
//! The unit ray d = ((c − c_x)/f_x, (r − c_y)/f_y, 1) is written in the frame of the
//! intrinsics (x right, y down, z away from the camera); a normal of the crate's frame
//! n = (n_x, n_y, n_z) is n' = (n_x, −n_y, −n_z) there.

use crate::error::{Error, Result};

/// Pinhole intrinsics in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Focal length along columns (pixels).
    pub fx: f64,
    /// Focal length along rows (pixels).
    pub fy: f64,
    /// Principal point, column (pixels; pixel centres are at integers).
    pub cx: f64,
    /// Principal point, row (pixels, counted downward).
    pub cy: f64,
}

impl Camera {
    /// Focal length `f` (pixels) with the principal point at the image centre.
    pub fn centred(f: f64, width: usize, height: usize) -> Result<Self> {
        let cam = Camera {
            fx: f,
            fy: f,
            cx: (width as f64 - 1.0) / 2.0,
            cy: (height as f64 - 1.0) / 2.0,
        };
        cam.check()?;
        Ok(cam)
    }

    /// From a 3 × 3 intrinsics matrix [[f_x, s, c_x], [0, f_y, c_y], [0, 0, 1]] given as
    /// text (9 numbers separated by white space or commas, row by row; `#` starts a
    /// comment). A skew s ≠ 0 is rejected. `what` names the source in errors.
    pub fn from_text(text: &str, what: &str) -> Result<Self> {
        let mut v = Vec::with_capacity(9);
        for line in text.lines() {
            let line = line.split('#').next().unwrap_or("");
            for tok in line.split(|ch: char| ch.is_whitespace() || ch == ',') {
                if tok.is_empty() {
                    continue;
                }
                let x: f64 = tok.parse().map_err(|_| {
                    Error::invalid(
                        what,
                        format!("`{tok}` is not a number; write the 3x3 intrinsics matrix as 9 numbers, row by row"),
                    )
                })?;
                v.push(x);
            }
        }
        if v.len() != 9 {
            return Err(Error::invalid(
                what,
                format!(
                    "found {} numbers; write the 3x3 intrinsics matrix as 9 numbers, row by row",
                    v.len()
                ),
            ));
        }
        let bottom = [v[6], v[7], v[8]];
        if v[3] != 0.0 || bottom != [0.0, 0.0, 1.0] || v[1] != 0.0 {
            return Err(Error::invalid(
                what,
                "expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew)",
            ));
        }
        let cam = Camera {
            fx: v[0],
            fy: v[4],
            cx: v[2],
            cy: v[5],
        };
        cam.check().map_err(|_| {
            Error::invalid(
                what,
                "the focal lengths must be positive and all entries finite",
            )
        })?;
        Ok(cam)
    }

    fn check(&self) -> Result<()> {
        let ok = [self.fx, self.fy, self.cx, self.cy]
            .iter()
            .all(|v| v.is_finite())
            && self.fx > 0.0
            && self.fy > 0.0;
        if ok {
            Ok(())
        } else {
            Err(Error::invalid(
                "camera",
                "the focal length must be a positive number of pixels",
            ))
        }
    }

    /// The ray through the centre of pixel (r, c) with unit depth, intrinsics frame.
    pub fn ray(&self, r: usize, c: usize) -> [f64; 3] {
        [
            (c as f64 - self.cx) / self.fx,
            (r as f64 - self.cy) / self.fy,
            1.0,
        ]
    }

    /// The point at distance `t` along the optical axis seen at pixel (r, c), in the
    /// crate's camera frame (x right, y up, z toward the camera).
    pub fn back_project(&self, r: usize, c: usize, t: f64) -> [f64; 3] {
        let d = self.ray(r, c);
        [t * d[0], -t * d[1], -t]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_diligent_k() {
        let k = "3.772077e+03 0.0 3.058750e+02\n0.0 3.759005e+03 2.551250e+02\n0 0 1\n";
        let c = Camera::from_text(k, "K.txt").unwrap();
        assert_eq!(c.cx, 305.875);
        assert_eq!(c.fy, 3759.005);
        assert!(Camera::from_text("1 2 3", "K.txt").is_err());
        assert!(Camera::from_text("1 0 3\n0 1 2\n0 0 2", "K.txt").is_err());
        assert!(Camera::from_text("-1 0 3\n0 1 2\n0 0 1", "K.txt").is_err());
    }
}
