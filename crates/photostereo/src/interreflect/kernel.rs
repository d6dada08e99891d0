//! The interreflection kernel between facets, with visibility over the height field.
//!
//! For facets i ≠ j with centres x, unit normals n and true areas A, and r = x_j − x_i:
//!
//! K_ij = (n_i·r)(n_j·(−r)) / (π |r|⁴) · V_ij · A_j,
//!
//! zero unless both cosines are positive. K_ij B_j is the irradiance that facet j of
//! radiosity B_j sends to facet i. Pairs closer than [`NEAR_CELLS`] grid cells split facet
//! j into 4×4 sub-facets in its tangent plane (the point-to-point formula is poor there).
//!
//! Visibility V_ij (see [`Visibility`]) uses the fact that on a height field the segment
//! from x_i to x_j projects onto the straight image line between the two facets, so it is
//! blocked exactly when some height along that line rises above the segment.

use super::facets::Facets;
use super::Visibility;
use crate::error::{Error, Result, Setting};
use crate::progress::Progress;
use rayon::prelude::*;
use std::f32::consts::PI;

/// Pairs closer than this many grid cells use a 4×4 subdivision of the emitting facet.
pub const NEAR_CELLS: f32 = 2.5;
/// Sub-facets per side in the near field.
const SUB: usize = 4;

/// Dense interreflection kernel over `n` facets (row-major `n × n`, `f32`).
#[derive(Clone, Debug)]
pub struct Kernel {
    /// Number of facets.
    pub n: usize,
    /// `k[i * n + j]` = K_ij (irradiance at i per unit radiosity of j).
    pub k: Vec<f32>,
    /// Facing pairs (both cosines positive) found occluded by the visibility test.
    pub occluded_pairs: u64,
    /// Facing pairs in total.
    pub facing_pairs: u64,
}

/// Options of [`Kernel::build`].
#[derive(Clone, Copy, Debug)]
pub struct KernelOptions {
    /// How visibility is decided.
    pub visibility: Visibility,
    /// Height tolerance (pixels) before a sample counts as an occluder; absorbs the
    /// discretisation of a smooth concave surface.
    pub vis_eps: f32,
    /// Largest number of facets accepted (the dense kernel takes 4·n² bytes).
    pub max_facets: usize,
}

impl Default for KernelOptions {
    fn default() -> Self {
        KernelOptions {
            visibility: Visibility::default(),
            vis_eps: 0.05,
            max_facets: 16_384,
        }
    }
}

impl Kernel {
    /// Build the kernel of `facets`. Cost O(n·D·L + n²) with [`Visibility::Horizon`]
    /// (D azimuths, L grid steps), O(n²·L) with [`Visibility::BruteForce`].
    pub fn build(facets: &Facets, opts: &KernelOptions, progress: &dyn Progress) -> Result<Self> {
        let n = facets.len();
        if n > opts.max_facets {
            return Err(Error::setting(
                Setting::FacetBlock,
                format!(
                    "interreflection kernel of {n} facets (limit {})",
                    opts.max_facets
                ),
                format!(
                    "use facet blocks larger than {} px (e.g. {} px) or a smaller mask",
                    facets.block,
                    facets.block * 2
                ),
            ));
        }
        if let Visibility::Horizon { azimuths } = opts.visibility {
            if azimuths < 4 {
                return Err(Error::invalid(
                    format!("horizon visibility with {azimuths} azimuths"),
                    "use at least 4 azimuths (32 or more is typical)",
                ));
            }
        }
        let grid: Vec<[f32; 2]> = (0..n).map(|i| grid_coords(facets, i)).collect();
        let mut k = vec![0.0f32; n * n];
        progress.start("interreflection kernel", n as u64);
        let counts: Vec<(u64, u64)> = k
            .par_chunks_mut(n.max(1))
            .enumerate()
            .map(|(i, row)| {
                let c = fill_row(facets, &grid, i, row, opts);
                progress.advance(1);
                c
            })
            .collect();
        progress.finish();
        let (occluded_pairs, facing_pairs) =
            counts.iter().fold((0, 0), |a, c| (a.0 + c.0, a.1 + c.1));
        Ok(Kernel {
            n,
            k,
            occluded_pairs,
            facing_pairs,
        })
    }

    /// G = K·B for facet-major values `b[j * channels + c]`.
    pub fn apply(&self, b: &[f32], channels: usize) -> Vec<f32> {
        let n = self.n;
        let mut out = vec![0.0f32; n * channels];
        out.par_chunks_mut(channels.max(1))
            .enumerate()
            .for_each(|(i, g)| {
                let row = &self.k[i * n..(i + 1) * n];
                for (j, &kij) in row.iter().enumerate() {
                    if kij != 0.0 {
                        let bj = &b[j * channels..(j + 1) * channels];
                        for (gc, bc) in g.iter_mut().zip(bj) {
                            *gc += kij * bc;
                        }
                    }
                }
            });
        out
    }

    /// Σ_j K_ij for each facet i: the fraction of the hemisphere of i covered by the surface.
    pub fn row_sums(&self) -> Vec<f32> {
        self.k
            .chunks(self.n.max(1))
            .map(|r| r.iter().sum())
            .collect()
    }
}

/// Continuous grid coordinates (row, col) of facet i; cell (R, C) is centred at (R+½, C+½).
fn grid_coords(f: &Facets, i: usize) -> [f32; 2] {
    let b = f.block as f32;
    let [x, y, _] = f.pos[i];
    [
        (f.height as f32 / 2.0 - y) / b,
        (x + f.width as f32 / 2.0) / b,
    ]
}

/// Fill row i of the kernel; returns (occluded, facing) pair counts.
fn fill_row(
    f: &Facets,
    grid: &[[f32; 2]],
    i: usize,
    row: &mut [f32],
    o: &KernelOptions,
) -> (u64, u64) {
    // Marched lazily: a facet that faces no other (a flat rim) never pays for it.
    let mut horizon: Option<Horizon> = None;
    let (mut occluded, mut facing) = (0u64, 0u64);
    let (xi, ni) = (f.pos[i], f.normal[i]);
    for (j, out) in row.iter_mut().enumerate() {
        if j == i {
            continue;
        }
        let dr = grid[j][0] - grid[i][0];
        let dc = grid[j][1] - grid[i][1];
        let rho = (dr * dr + dc * dc).sqrt();
        let kij = if rho < NEAR_CELLS {
            near_factor(f, i, j)
        } else {
            point_factor(xi, ni, f.pos[j], f.normal[j]) * f.area[j]
        };
        if kij <= 0.0 {
            continue;
        }
        facing += 1;
        let visible = match o.visibility {
            Visibility::None => true,
            Visibility::Horizon { azimuths } => horizon
                .get_or_insert_with(|| Horizon::march(f, grid[i], xi[2], azimuths))
                .visible(dr, dc, rho, f.pos[j][2] - xi[2], f.block as f32, o.vis_eps),
            Visibility::BruteForce => {
                segment_visible(f, grid[i], grid[j], xi[2], f.pos[j][2], o.vis_eps)
            }
        };
        if visible {
            *out = kij;
        } else {
            occluded += 1;
        }
    }
    (occluded, facing)
}

/// (n_i·r)(n_j·(−r)) / (π|r|⁴), zero unless both cosines are positive.
#[inline]
fn point_factor(xi: [f32; 3], ni: [f32; 3], xj: [f32; 3], nj: [f32; 3]) -> f32 {
    let r = [xj[0] - xi[0], xj[1] - xi[1], xj[2] - xi[2]];
    let d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    let ci = ni[0] * r[0] + ni[1] * r[1] + ni[2] * r[2];
    let cj = -(nj[0] * r[0] + nj[1] * r[1] + nj[2] * r[2]);
    if ci <= 0.0 || cj <= 0.0 || d2 <= 0.0 {
        return 0.0;
    }
    ci * cj / (PI * d2 * d2)
}

/// K_ij with facet j split into SUB×SUB sub-facets lying in its tangent plane.
fn near_factor(f: &Facets, i: usize, j: usize) -> f32 {
    let b = f.block as f32;
    let (xj, nj) = (f.pos[j], f.normal[j]);
    let mut sum = 0.0f32;
    for a in 0..SUB {
        for c in 0..SUB {
            let dx = ((c as f32 + 0.5) / SUB as f32 - 0.5) * b;
            let dy = ((a as f32 + 0.5) / SUB as f32 - 0.5) * b;
            let dz = -(nj[0] * dx + nj[1] * dy) / nj[2].max(1e-3);
            let xs = [xj[0] + dx, xj[1] + dy, xj[2] + dz];
            sum += point_factor(f.pos[i], f.normal[i], xs, nj);
        }
    }
    sum * f.area[j] / (SUB * SUB) as f32
}

/// Brute-force visibility: sample the image line from i to j every half cell (skipping half
/// a cell at each end) and compare the height field with the segment's height.
fn segment_visible(f: &Facets, gi: [f32; 2], gj: [f32; 2], zi: f32, zj: f32, eps: f32) -> bool {
    let (dr, dc) = (gj[0] - gi[0], gj[1] - gi[1]);
    let rho = (dr * dr + dc * dc).sqrt();
    let steps = (2.0 * rho).ceil() as usize;
    for m in 1..steps {
        let t = m as f32 / steps as f32;
        if t * rho < 0.5 || (1.0 - t) * rho < 0.5 {
            continue;
        }
        if let Some(h) = f.height_at(gi[0] + t * dr, gi[1] + t * dc) {
            if h > zi + t * (zj - zi) + eps {
                return false;
            }
        }
    }
    true
}

/// Running maximum elevation slope along D azimuths from one facet.
struct Horizon {
    azimuths: usize,
    /// Steps per azimuth (+1 for step 0).
    len: usize,
    /// `slope[a * len + s]`: max of (h − z_i)/distance over samples 1..=s on azimuth a.
    slope: Vec<f32>,
}

impl Horizon {
    /// March from grid point `g` (height `z`) one cell at a time along each azimuth.
    fn march(f: &Facets, g: [f32; 2], z: f32, azimuths: usize) -> Self {
        let len = ((f.grid_w * f.grid_w + f.grid_h * f.grid_h) as f32)
            .sqrt()
            .ceil() as usize
            + 2;
        let mut slope = vec![f32::NEG_INFINITY; azimuths * len];
        let b = f.block as f32;
        // Beyond the step where the horizon is above (z_max − z)/distance nothing can rise
        // over it any more: the rest of the ray keeps the same horizon.
        let rise = f.max_height - z;
        for a in 0..azimuths {
            let th = 2.0 * PI * a as f32 / azimuths as f32;
            let (sr, sc) = (th.sin(), th.cos());
            let line = &mut slope[a * len..(a + 1) * len];
            let mut run = f32::NEG_INFINITY;
            for s in 1..len {
                let (r, c) = (g[0] + s as f32 * sr, g[1] + s as f32 * sc);
                if r < 0.0 || c < 0.0 || r > f.grid_h as f32 || c > f.grid_w as f32 {
                    line[s..].iter_mut().for_each(|v| *v = run);
                    break;
                }
                if let Some(h) = f.height_at(r, c) {
                    run = run.max((h - z) / (s as f32 * b));
                }
                line[s] = run;
                if run >= rise / (s as f32 * b) {
                    line[s..].iter_mut().for_each(|v| *v = run);
                    break;
                }
            }
        }
        Horizon {
            azimuths,
            len,
            slope,
        }
    }

    /// Is a point at grid offset (dr, dc), distance `rho` cells and height `dz` above the
    /// origin above the horizon (blend of the two nearest azimuths, samples up to rho − ½)?
    fn visible(&self, dr: f32, dc: f32, rho: f32, dz: f32, block: f32, eps: f32) -> bool {
        let s = ((rho - 0.5).floor().max(0.0) as usize).min(self.len - 1);
        if s < 1 {
            return true;
        }
        let mut a = dr.atan2(dc) / (2.0 * PI) * self.azimuths as f32;
        if a < 0.0 {
            a += self.azimuths as f32;
        }
        let a0 = (a.floor() as usize) % self.azimuths;
        let a1 = (a0 + 1) % self.azimuths;
        let t = a - a.floor();
        let h0 = self.slope[a0 * self.len + s];
        let h1 = self.slope[a1 * self.len + s];
        let hz = if h0.is_finite() && h1.is_finite() {
            (1.0 - t) * h0 + t * h1
        } else {
            h0.min(h1)
        };
        (dz + eps) / (rho * block) >= hz
    }
}
