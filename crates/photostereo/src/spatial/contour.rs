//! The mask's edge as an occluding contour: there the surface turns away from the camera
//! and its normal is the outward normal of the silhouette, n = (m_x, m_y, 0) (Ikeuchi &
//! Horn, "Numerical shape from shading and occluding boundaries", AI 17, 1981). At a
//! pixel centre half a pixel inside, (n_x, n_y) ≈ 0.98·m. The outward direction m is the
//! negated gradient of the mask smoothed by a Gaussian of 2 px (camera frame: y up).
//! Pixels on the image border are not contour pixels (the object may continue).

use crate::image::Mask;

/// |(n_x, n_y)| assumed at a contour pixel's centre.
const RIM_TILT: f32 = 0.98;
/// Standard deviation (pixels) of the smoothing of the mask.
const SMOOTH: f32 = 2.0;

/// (pixel index, (n_x, n_y)) of every contour pixel of `mask`.
pub(crate) fn contour_normals(mask: &Mask) -> Vec<(usize, [f32; 2])> {
    let (w, h) = (mask.width, mask.height);
    if w < 3 || h < 3 {
        return Vec::new();
    }
    let m = |r: usize, c: usize| -> bool { *mask.get(r, c) };
    let mut edge = Vec::new();
    for r in 1..h - 1 {
        for c in 1..w - 1 {
            if m(r, c) && (!m(r - 1, c) || !m(r + 1, c) || !m(r, c - 1) || !m(r, c + 1)) {
                edge.push((r, c));
            }
        }
    }
    let radius = (3.0 * SMOOTH).ceil() as i64;
    let side = (2 * radius + 1) as usize;
    let gauss: Vec<f32> = (0..side * side)
        .map(|j| {
            let (dr, dc) = ((j / side) as i64 - radius, (j % side) as i64 - radius);
            (-((dr * dr + dc * dc) as f32) / (2.0 * SMOOTH * SMOOTH)).exp()
        })
        .collect();
    edge.into_iter()
        .filter_map(|(r, c)| {
            // gradient of the Gaussian-smoothed mask at (r, c): Σ m · ∇G
            let (mut gr, mut gc) = (0.0f32, 0.0f32);
            for dr in -radius..=radius {
                for dc in -radius..=radius {
                    let (rr, cc) = (r as i64 + dr, c as i64 + dc);
                    let inside = rr >= 0
                        && cc >= 0
                        && (rr as usize) < h
                        && (cc as usize) < w
                        && m(rr as usize, cc as usize);
                    if !inside {
                        continue;
                    }
                    let g = gauss[(dr + radius) as usize * side + (dc + radius) as usize];
                    gr += g * dr as f32;
                    gc += g * dc as f32;
                }
            }
            // the mask grows towards +gradient; outward = −gradient; camera y = −row
            let (mx, my) = (-gc, gr);
            let norm = (mx * mx + my * my).sqrt();
            (norm > 1e-3).then(|| (r * w + c, [RIM_TILT * mx / norm, RIM_TILT * my / norm]))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_contour_points_outward() {
        let (w, h, rad) = (64usize, 64usize, 20.0f32);
        let mask = Mask::from_fn(w, h, |r, c| {
            let (x, y) = (c as f32 + 0.5 - 32.0, 32.0 - r as f32 - 0.5);
            x * x + y * y < rad * rad
        });
        let cn = contour_normals(&mask);
        assert!(cn.len() > 100);
        for (i, u) in cn {
            let (r, c) = (i / w, i % w);
            let (x, y) = (c as f32 + 0.5 - 32.0, 32.0 - r as f32 - 0.5);
            let d = (x * x + y * y).sqrt();
            let cos = (u[0] * x + u[1] * y) / (d * RIM_TILT);
            // measured: the worst contour pixel is 4° off the radius
            assert!(cos > 0.99, "pixel ({r}, {c}): {u:?}");
        }
    }
}
