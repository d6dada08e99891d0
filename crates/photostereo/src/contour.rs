//! Occluding-contour prior for the target's boundary pixels (after the lookup).
//!
//! Where the mask's boundary is an **occluding contour** — the surface turns away from
//! the camera there — the normal on the contour is perpendicular to the view and to the
//! contour (Ikeuchi & Horn, "Numerical shape from shading and occluding boundaries",
//! Artificial Intelligence 17, 1981): n = (t_out, 0), t_out the outward normal of the
//! silhouette in the image plane. A lookup table stops short of 90° (its sphere's rim
//! is left out), so the lookup clamps such pixels to the table's edge with low
//! confidence; this stage replaces them with the contour's evidence.
//!
//! # Method ([`solve`])
//!
//! For each **boundary pixel** (a mask pixel with a 4-neighbour outside) where the
//! lookup is uncertain — confidence below [`Options::min_confidence`], or polar angle
//! within 1° of [`Options::table_edge_deg`] (beyond the table's rim):
//!
//! 1. **Azimuth**: the outward normal of the silhouette, −∇ of the mask blurred by a
//!    Gaussian of σ = 1.5 px (camera frame: x right, y up).
//! 2. **Polar angle**: near an occluding contour n_z² ≈ 2κ·d, d the distance into the
//!    silhouette and κ the surface's normal curvature across the contour (for a sphere
//!    of radius R, n_z² = 2d/R − d²/R²). κ is fitted by least squares (n_z² = c·d,
//!    through the origin) to the lookup's **confident** normals (confidence ≥
//!    `min_confidence`, polar angle at least 2° inside the table's edge) within
//!    [`Options::radius_px`] of the pixel and 1.5–8 px inside the contour; the pixel
//!    gets n_z = √(c·d). d is the distance from the pixel's centre to the nearest
//!    midpoint between a mask pixel and a 4-neighbour outside it (0.5 for a pixel on a
//!    straight edge). Without such neighbours the pixel is left as it is.
//!
//! The adjusted pixels keep the lookup's confidence; [`Output::adjusted`] marks them.
//!
//! # When it applies
//!
//! Only where the silhouette is an occluding contour of a smooth surface. **Not** where
//! the object rests on a support or touches another object (the boundary there is a
//! contact, not a contour), nor where it is cut by the image border: pixels on the
//! image border, or with an outside neighbour on it, are never adjusted. For other
//! non-contour boundaries (a support, a mask drawn inside the object, a crease) turn
//! the stage off ([`Options::enabled`]; CLI `--no-contour`).

use crate::error::Result;
use crate::image::{GrayImage, Mask, NormalMap};

/// Settings of [`solve`].
#[derive(Clone, Debug)]
pub struct Options {
    /// Apply the prior (default true). Off: the lookup's normals are returned as they are.
    pub enabled: bool,
    /// Boundary pixels with a lookup confidence below this are adjusted, and interior
    /// pixels at least this confident inform the curvature (default 0.5).
    pub min_confidence: f32,
    /// Polar angle (degrees from the view axis) of the table's edge: boundary pixels
    /// looked up within 1° of it are adjusted whatever their confidence (default 90:
    /// off; the pipeline passes the table's own edge).
    pub table_edge_deg: f64,
    /// Radius of the neighbourhood whose confident normals give the curvature (pixels,
    /// default 6).
    pub radius_px: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            enabled: true,
            min_confidence: 0.5,
            table_edge_deg: 90.0,
            radius_px: 6.0,
        }
    }
}

/// Result of [`solve`].
#[derive(Clone, Debug)]
pub struct Output {
    /// The normals, boundary pixels adjusted.
    pub normals: NormalMap,
    /// The confidence (unchanged).
    pub confidence: GrayImage,
    /// The pixels the prior adjusted.
    pub adjusted: Mask,
    /// Boundary pixels considered (uncertain, not on the image border).
    pub candidates: usize,
}

/// Apply the occluding-contour prior (see the module docs) to the lookup's `normals`
/// and `confidence` inside `mask`.
///
/// Errors: [`Error::SizeMismatch`] when the three images differ in size.
pub fn solve(
    normals: &NormalMap,
    confidence: &GrayImage,
    mask: &Mask,
    opts: &Options,
) -> Result<Output> {
    let (w, h) = (mask.width, mask.height);
    normals.check_size(w, h, "contour prior: normals")?;
    confidence.check_size(w, h, "contour prior: confidence")?;
    let mut out = Output {
        normals: normals.clone(),
        confidence: confidence.clone(),
        adjusted: Mask::filled(w, h, false),
        candidates: 0,
    };
    if !opts.enabled || w < 3 || h < 3 {
        return Ok(out);
    }
    let dist = contour_distance(mask, (opts.radius_px + 8.0).ceil() as usize);
    let blurred = blur(mask, 1.5);
    for r in 1..h - 1 {
        for c in 1..w - 1 {
            if !is_candidate(mask, normals, confidence, opts, r, c) {
                continue;
            }
            out.candidates += 1;
            let Some(n) = contour_normal(&blurred, &dist, normals, confidence, mask, opts, r, c)
            else {
                continue;
            };
            *out.normals.get_mut(r, c) = n;
            *out.adjusted.get_mut(r, c) = true;
        }
    }
    Ok(out)
}

/// A boundary pixel away from the image border where the lookup is uncertain.
fn is_candidate(
    mask: &Mask,
    normals: &NormalMap,
    confidence: &GrayImage,
    opts: &Options,
    r: usize,
    c: usize,
) -> bool {
    let (w, h) = (mask.width, mask.height);
    if !*mask.get(r, c) {
        return false;
    }
    let neighbours = [(r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)];
    let outside: Vec<_> = neighbours.iter().filter(|&&(i, j)| !*mask.get(i, j)).collect();
    if outside.is_empty() {
        return false;
    }
    // an outside neighbour on the image border: the silhouette may be cut there
    if outside
        .iter()
        .any(|&&(i, j)| i == 0 || j == 0 || i + 1 == h || j + 1 == w)
    {
        return false;
    }
    let angle = polar_deg(*normals.get(r, c));
    *confidence.get(r, c) < opts.min_confidence || angle >= opts.table_edge_deg - 1.0
}

fn polar_deg(n: [f32; 3]) -> f64 {
    (n[2] as f64).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Steps 1–2 of the module docs at boundary pixel (r, c).
#[allow(clippy::too_many_arguments)]
fn contour_normal(
    blurred: &[f64],
    dist: &[f64],
    normals: &NormalMap,
    confidence: &GrayImage,
    mask: &Mask,
    opts: &Options,
    r: usize,
    c: usize,
) -> Option<[f32; 3]> {
    let w = mask.width;
    // outward direction in the image plane: −∇(blurred mask), central differences
    let gx = blurred[r * w + c + 1] - blurred[r * w + c - 1];
    let grow = blurred[(r + 1) * w + c] - blurred[(r - 1) * w + c];
    let (ox, oy) = (-gx, grow); // x right; y up = −row
    let norm = ox.hypot(oy);
    if norm <= 1e-9 {
        return None;
    }
    // curvature: n_z² = k·d over confident neighbours
    let rad = opts.radius_px.ceil() as isize;
    let edge = opts.table_edge_deg - 2.0;
    let (mut sdd, mut sdz) = (0.0, 0.0);
    let mut used = 0;
    for dr in -rad..=rad {
        for dc in -rad..=rad {
            let (i, j) = (r as isize + dr, c as isize + dc);
            if i < 0 || j < 0 || i >= mask.height as isize || j >= w as isize {
                continue;
            }
            if ((dr * dr + dc * dc) as f64).sqrt() > opts.radius_px {
                continue;
            }
            let (i, j) = (i as usize, j as usize);
            let d = dist[i * w + j];
            let n = *normals.get(i, j);
            if !*mask.get(i, j)
                || !(1.5..=8.0).contains(&d)
                || *confidence.get(i, j) < opts.min_confidence
                || polar_deg(n) > edge
            {
                continue;
            }
            let nz2 = (n[2] as f64).powi(2);
            sdd += d * d;
            sdz += d * nz2;
            used += 1;
        }
    }
    if used < 3 || sdd <= 0.0 {
        return None;
    }
    let k = (sdz / sdd).max(0.0);
    let nz = (k * dist[r * w + c]).clamp(0.0, 1.0).sqrt();
    let s = (1.0 - nz * nz).sqrt();
    Some([(s * ox / norm) as f32, (s * oy / norm) as f32, nz as f32])
}

/// Distance (pixels) from each mask pixel's centre to the nearest midpoint between a
/// mask pixel and a 4-neighbour outside it, searched up to `reach` pixels away
/// (f64::INFINITY beyond, and outside the mask). Image-border sides do not count.
fn contour_distance(mask: &Mask, reach: usize) -> Vec<f64> {
    let (w, h) = (mask.width, mask.height);
    let mut mids: Vec<(f64, f64)> = Vec::new();
    for r in 0..h {
        for c in 0..w {
            if !*mask.get(r, c) {
                continue;
            }
            let (y, x) = (r as f64 + 0.5, c as f64 + 0.5);
            if c + 1 < w && !*mask.get(r, c + 1) {
                mids.push((x + 0.5, y));
            }
            if c > 0 && !*mask.get(r, c - 1) {
                mids.push((x - 0.5, y));
            }
            if r + 1 < h && !*mask.get(r + 1, c) {
                mids.push((x, y + 0.5));
            }
            if r > 0 && !*mask.get(r - 1, c) {
                mids.push((x, y - 0.5));
            }
        }
    }
    // bucket the midpoints on a grid of `reach` cells for a local search
    let cell = reach.max(1);
    let (gw, gh) = (w / cell + 1, h / cell + 1);
    let mut grid: Vec<Vec<(f64, f64)>> = vec![Vec::new(); gw * gh];
    for &(x, y) in &mids {
        let (gc, gr) = ((x as usize / cell).min(gw - 1), (y as usize / cell).min(gh - 1));
        grid[gr * gw + gc].push((x, y));
    }
    let mut dist = vec![f64::INFINITY; w * h];
    for r in 0..h {
        for c in 0..w {
            if !*mask.get(r, c) {
                continue;
            }
            let (x, y) = (c as f64 + 0.5, r as f64 + 0.5);
            let (gc, gr) = (c / cell, r / cell);
            let mut best = f64::INFINITY;
            for i in gr.saturating_sub(1)..=(gr + 1).min(gh - 1) {
                for j in gc.saturating_sub(1)..=(gc + 1).min(gw - 1) {
                    for &(mx, my) in &grid[i * gw + j] {
                        best = best.min((mx - x).hypot(my - y));
                    }
                }
            }
            dist[r * w + c] = best;
        }
    }
    dist
}

/// The mask as 0/1, blurred by a separable Gaussian of `sigma` pixels (clamped borders).
fn blur(mask: &Mask, sigma: f64) -> Vec<f64> {
    let (w, h) = (mask.width, mask.height);
    let half = (3.0 * sigma).ceil() as isize;
    let k: Vec<f64> = (-half..=half)
        .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let norm: f64 = k.iter().sum();
    let src: Vec<f64> = mask.data.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
    let pass = |src: &[f64], horizontal: bool| -> Vec<f64> {
        let mut out = vec![0.0; w * h];
        for r in 0..h {
            for c in 0..w {
                let mut acc = 0.0;
                for (t, kv) in k.iter().enumerate() {
                    let o = t as isize - half;
                    let (rr, cc) = if horizontal {
                        (r as isize, (c as isize + o).clamp(0, w as isize - 1))
                    } else {
                        ((r as isize + o).clamp(0, h as isize - 1), c as isize)
                    };
                    acc += kv * src[rr as usize * w + cc as usize];
                }
                out[r * w + c] = acc / norm;
            }
        }
        out
    };
    pass(&pass(&src, true), false)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere of radius 30 looked up with a table that stops at 78°: the boundary
    /// pixels get the table's edge; the prior brings them back toward the truth.
    #[test]
    fn sphere_boundary_pixels_get_closer_to_the_truth() {
        let (w, h, cx, cy, rad) = (80usize, 80usize, 40.3, 39.6, 30.0);
        let truth = |r: usize, c: usize| {
            let nx = (c as f64 + 0.5 - cx) / rad;
            let ny = -(r as f64 + 0.5 - cy) / rad;
            let nz = (1.0 - nx * nx - ny * ny).max(0.0).sqrt();
            [nx as f32, ny as f32, nz as f32]
        };
        let mask = Mask::from_fn(w, h, |r, c| {
            (c as f64 + 0.5 - cx).hypot(r as f64 + 0.5 - cy) < rad
        });
        let edge = 78f64.to_radians();
        let looked_up = NormalMap::from_fn(w, h, |r, c| {
            let n = truth(r, c);
            let polar = (n[2] as f64).acos();
            if polar <= edge {
                return n;
            }
            let s = edge.sin() / (n[0].hypot(n[1]) as f64);
            [(n[0] as f64 * s) as f32, (n[1] as f64 * s) as f32, edge.cos() as f32]
        });
        let conf = GrayImage::from_fn(w, h, |r, c| {
            if (n_polar(&looked_up, r, c) - 78.0).abs() < 0.01 {
                0.2
            } else {
                0.9
            }
        });
        let out = solve(&looked_up, &conf, &mask, &Options::default()).unwrap();
        let (mut before, mut after, mut n) = (0.0, 0.0, 0);
        for r in 0..h {
            for c in 0..w {
                if *out.adjusted.get(r, c) {
                    before += angle(*looked_up.get(r, c), truth(r, c));
                    after += angle(*out.normals.get(r, c), truth(r, c));
                    n += 1;
                }
            }
        }
        let (before, after) = (before / n as f64, after / n as f64);
        println!("{n} boundary pixels: {before:.2}° before, {after:.2}° after the prior");
        assert!(n > 100, "{n} pixels adjusted");
        assert!(after < 0.5 * before, "{after:.2}° vs {before:.2}°");
        let off = solve(
            &looked_up,
            &conf,
            &mask,
            &Options {
                enabled: false,
                ..Options::default()
            },
        )
        .unwrap();
        assert_eq!(off.normals.data, looked_up.data);
    }

    fn n_polar(n: &NormalMap, r: usize, c: usize) -> f64 {
        polar_deg(*n.get(r, c))
    }

    fn angle(a: [f32; 3], b: [f32; 3]) -> f64 {
        let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        (d as f64).clamp(-1.0, 1.0).acos().to_degrees()
    }
}
