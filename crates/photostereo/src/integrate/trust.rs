//! How far each pixel's gradient can be trusted, from what the normals stage knows.
//!
//! Four factors, multiplied (each in [0, 1]):
//!
//! * **albedo**: a pixel that is dark in every image (albedo ≈ 0: a black mark, a hole,
//!   a shadow that no light reaches) gives a normal that is noise. With s = albedo /
//!   median albedo over the mask, the factor is smoothstep((s − a₀)/(a₁ − a₀)) with
//!   a₀ = [`TrustOptions::dark`] and a₁ = 4 a₀: 0 below a₀ of the median, 1 above a₁.
//! * **confidence** of the lookup (already in [0, 1]), when there is one.
//! * **slope**: at an object's outline n_z → 0 and the gradient −n_x/n_z explodes; a
//!   normal error of 1° there changes the slope by many pixels per pixel, and pixels
//!   that mix object and background give a wrong normal outright. The factor is
//!   min(1, n_z / [`TrustOptions::steep_nz`])², the square of the scale BiNI's
//!   equations put on each pixel (so an equation n_z (z_j − z_i) + n_x = 0 keeps its
//!   weight where it is well conditioned).
//!
//! * **outline**: pixels on the mask's outline mix object and background (and a mask
//!   drawn by hand or by a threshold is only right to a pixel or so); within
//!   [`TrustOptions::outline`] pixels of the outside the weight ramps up smoothly.
//!
//! The weighted solvers ([`super::Method::Lsq`], [`super::Method::Bilateral`]) use the
//! weights t ∈ [0, 1] as E = Σ_e t_e (Δz − g_e)² + ε (1 − t_e) Δz², with t_e the
//! smaller weight of the edge's two pixels and ε = [`super::lsq::PRIOR`]: a trusted edge
//! keeps its target, an untrusted one is filled by the smoothest (membrane) surface
//! between its trusted neighbours instead of integrating noise into a spike.

use crate::image::{GrayImage, Mask, NormalMap};

/// Settings of [`trust_weights`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrustOptions {
    /// Albedo, as a fraction of the median albedo over the mask, below which a pixel
    /// gets no weight (unitless, default 0.05; full weight from 4× this).
    pub dark: f32,
    /// n_z below which the slope factor falls off as (n_z / steep_nz)² (unitless,
    /// default 0.1, slopes above 9.9 px/px, 84°); 0 leaves the slope out.
    pub steep_nz: f32,
    /// Width of the band along the mask's outline whose pixels mix object and
    /// background (px, default 1: the outline pixels get half the weight): a pixel d steps (4-neighbour) from outside the mask
    /// gets the factor smoothstep(d / (outline + 1)); 0 leaves it out.
    pub outline: f32,
}

impl Default for TrustOptions {
    fn default() -> Self {
        TrustOptions {
            dark: 0.05,
            steep_nz: 0.1,
            outline: 1.0,
        }
    }
}

fn smoothstep(x: f32) -> f32 {
    let t = x.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Per-pixel trust in [0, 1] (0 outside the mask) from the normals and, when known, the
/// albedo and the lookup confidence; see the module documentation of
/// `integrate::trust`. Maps of another size than the normals are ignored.
pub fn trust_weights(
    normals: &NormalMap,
    mask: &Mask,
    albedo: Option<&GrayImage>,
    confidence: Option<&GrayImage>,
    opts: &TrustOptions,
) -> GrayImage {
    let (w, h) = (normals.width, normals.height);
    let fits = |m: &&GrayImage| m.width == w && m.height == h;
    let albedo = albedo.filter(fits);
    let confidence = confidence.filter(fits);
    let median = albedo.and_then(|a| median_in_mask(a, mask));
    let band = opts.outline.max(0.0);
    let dist = outline_distance(mask, band.ceil() as usize + 1);
    let mut out = GrayImage::filled(w, h, 0.0);
    for (i, n) in normals.data.iter().enumerate() {
        if !mask.data.get(i).copied().unwrap_or(false) {
            continue;
        }
        let nz = if n[2].is_finite() { n[2] } else { 0.0 };
        let mut t = if opts.steep_nz > 0.0 {
            (nz.max(0.0) / opts.steep_nz).min(1.0).powi(2)
        } else {
            1.0
        };
        if let (Some(a), Some(med)) = (albedo, median) {
            let s = a.data[i] / med;
            let a0 = opts.dark.max(0.0);
            t *= if s.is_finite() {
                smoothstep((s - a0) / (3.0 * a0).max(1e-6))
            } else {
                0.0
            };
        }
        if let Some(c) = confidence {
            let v = c.data[i];
            t *= if v.is_finite() {
                v.clamp(0.0, 1.0)
            } else {
                0.0
            };
        }
        if band > 0.0 {
            t *= smoothstep(dist[i] as f32 / (band + 1.0));
        }
        out.data[i] = t;
    }
    out
}

/// Per mask pixel: 1 + the number of 4-neighbour steps to the nearest pixel outside
/// the mask (the image border does not count as outside), capped at `cap`.
fn outline_distance(mask: &Mask, cap: usize) -> Vec<u8> {
    let (w, h) = (mask.width, mask.height);
    let cap = cap.min(255) as u8;
    let mut d: Vec<u8> = mask.data.iter().map(|&m| if m { cap } else { 0 }).collect();
    for step in 1..cap {
        let prev = d.clone();
        for i in (0..w * h).filter(|&i| prev[i] > step) {
            let (r, c) = (i / w, i % w);
            let near = (c > 0 && prev[i - 1] == step - 1)
                || (c + 1 < w && prev[i + 1] == step - 1)
                || (r > 0 && prev[i - w] == step - 1)
                || (r + 1 < h && prev[i + w] == step - 1);
            if near {
                d[i] = step;
            }
        }
    }
    d
}

/// Median of the finite values inside the mask, `None` when there is none or it is ≤ 0.
fn median_in_mask(img: &GrayImage, mask: &Mask) -> Option<f32> {
    let mut v: Vec<f32> = img
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(x, &m)| m && x.is_finite())
        .map(|(&x, _)| x)
        .collect();
    if v.is_empty() {
        return None;
    }
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, f32::total_cmp);
    (*m > 0.0).then_some(*m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    #[test]
    fn dark_steep_and_unsure_pixels_lose_weight() {
        let normals: NormalMap = Image::from_fn(4, 1, |_, c| match c {
            0 | 1 | 3 => [0.0, 0.0, 1.0],
            _ => [0.9987, 0.0, 0.05],
        });
        let mask = Mask::from_fn(4, 1, |_, _| true);
        // (A full mask has no outline: the image border is not outside.)
        let albedo = Image::from_fn(4, 1, |_, c| if c == 1 { 0.0 } else { 0.8 });
        let conf = Image::from_fn(4, 1, |_, c| if c == 3 { 0.5 } else { 1.0 });
        let t = trust_weights(
            &normals,
            &mask,
            Some(&albedo),
            Some(&conf),
            &TrustOptions::default(),
        );
        assert_eq!(t.data[0], 1.0);
        assert_eq!(t.data[1], 0.0);
        // (0.05 / 0.1)² = 0.25
        assert!((t.data[2] - 0.25).abs() < 1e-3, "{}", t.data[2]);
        assert_eq!(t.data[3], 0.5);
    }
}
