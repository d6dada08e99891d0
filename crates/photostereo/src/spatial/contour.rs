//! The mask's edge as an occluding contour: there the surface turns away from the camera
//! and its normal is the outward normal of the silhouette, n = (m_x, m_y, 0) (Ikeuchi &
//! Horn, "Numerical shape from shading and occluding boundaries", AI 17, 1981). At a
//! pixel centre half a pixel inside, (n_x, n_y) ≈ 0.995·m. The outward direction m is the
//! negated gradient of the mask smoothed by a Gaussian of 2 px (camera frame: y up).
//! Pixels on the image border are not contour pixels (the object may continue).
//!
//! The prior is anisotropic. Along the contour's tangent t the normal's component is 0
//! whatever the surface's curvature; its σ is given (`Options::contour_sigma`, 0.03 by
//! default: the direction m of the smoothed mask is itself a few degrees off on a
//! disc). The tilt along m depends on the curvature: a pixel centre d px inside the
//! silhouette of a surface with radius of curvature R (across the contour) has
//! |(n_x, n_y)| ≈ 1 − d/R. With d spread over (0, 1) (mean ½)
//! that is 0.995 for R = 100 px, 0.99 for 50 px and 0.98 for 25 px, so the tilt is held
//! at [`RIM_TILT`] = 0.995 with its own σ [`TILT_SIGMA`] = 0.01.
//!
//! Why these: the prior decides the rim wherever the data are dark there (a rough metal
//! lit from within 60° of the view). Measured 2026-12-07 (`normals`, circle found, the
//! prior's largest scale 0.005): with 0.98 ± 0.03 the dark rim of Mitsuba's aluminium
//! blob with 1% noise came out 0.03 short of the truth's 0.994 on its edge pixels, 8.8°
//! off, and tilted inward over 16 px (mean 1.32°); with 0.995 ± 0.01, 2.5° on the edge
//! and 0.95° over the mask. Every metal case measured gained: own GGX blob with 1% noise
//! at 128, 256 and 512 px 1.34 / 1.21 / 1.37° → 0.82 / 0.85 / 1.14°, a sphere of radius
//! 43 with 1% noise 1.58° → 0.81°, the vase 0.66° → 0.49°, 8-bit aluminium 0.32–0.34°
//! → 0.29–0.30°. Plastic and Lambertian renders moved by less than 0.005°, but for a
//! plastic sphere of radius 43 with 2% noise, 0.414° → 0.401°. The one loss: DiLiGenT's
//! ball at 0.75× through an 8-bit camera, 1–4% (0.227° → 0.235° at its plain exposure;
//! `lut_camera_ball`), monotonic in how tight the prior is. 0.99 ± 0.01 and
//! 0.998 ± 0.01 were within 10% of 0.995 ± 0.01 on every render; ± 0.005 gained on the
//! Mitsuba metal and lost on the small sphere, the small blob and the vase; ± 0.02 gave
//! back a third of the gain. It assumes the mask's edge is the silhouette to within a
//! pixel: on a mask eroded by 2–3 px the old 0.98 ± 0.03 did better on the dark rims (own
//! blob 0.73 / 0.68° against 0.89 / 0.98°), both better than no contour prior
//! (docs/accuracy.md, "The contour's tilt").

use crate::image::Mask;

/// |(n_x, n_y)| assumed at a contour pixel's centre.
const RIM_TILT: f32 = 0.995;
/// Standard error (unit-normal components) of the prior's tilt along the outward direction.
const TILT_SIGMA: f32 = 0.01;
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

/// The contour prior of one pixel as additions to its quadratic cost
/// ½ uᵀAu − bᵀu in u = (n_x, n_y): A as [a_xx, a_xy, a_yy] and b. `u` is
/// [`RIM_TILT`]·m from [`contour_normals`]; `sigma` is the tangential standard error.
pub(crate) fn prior(u: [f32; 2], sigma: f32) -> ([f32; 3], [f32; 2]) {
    let m = [u[0] / RIM_TILT, u[1] / RIM_TILT];
    let t = [-m[1], m[0]];
    let (it, im) = (1.0 / (sigma * sigma), 1.0 / (TILT_SIGMA * TILT_SIGMA));
    let a = [
        it * t[0] * t[0] + im * m[0] * m[0],
        it * t[0] * t[1] + im * m[0] * m[1],
        it * t[1] * t[1] + im * m[1] * m[1],
    ];
    // the tangential target is 0; the radial one is RIM_TILT·m, so b = im·u
    (a, [im * u[0], im * u[1]])
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
