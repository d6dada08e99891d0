//! The sphere's table split into a diffuse and a specular part, for targets whose
//! albedo varies (`Options::split_specular`).
//!
//! Normalised matching scales the whole tuple by the albedo ratio, but on a shiny
//! dielectric only the diffuse part scales with the albedo; the highlight does not. So
//! each light's reflectance over the sphere is split into a Lambertian part
//! D_k(n) = max(0, n·g_k), g_k fitted to the sphere's samples of light k, and the
//! remainder S_k(n) = I_k(n) − D_k(n) (highlight, and whatever of the diffuse
//! reflectance is not Lambertian). The two parts become the two tables of the
//! Hertzmann & Seitz mixture (IEEE PAMI 27(8), 2005), t ≈ a·D(n) + b·S(n), a, b ≥ 0,
//! with one sphere: a is the target's diffuse albedo relative to the sphere's, b the
//! strength of its highlight.
//!
//! The fit of g_k is robust against the highlight: least squares over the lit entries,
//! then repeatedly over the entries whose residual lies within 2.5 robust standard
//! deviations (1.4826 × the median absolute residual) plus 0.5% of the light's peak,
//! and clear of the terminator (n·g_k above 5% of |g_k|): the highlight is a positive
//! outlier and drops out. Where the diffuse reflectance is not Lambertian (rough
//! plastics, Fresnel-weighted diffuse) the difference lands in S, which then does not
//! scale with the albedo: an approximation, small next to the highlight.
//!
//! **Up to 90°.** The mixture has no rim refit of its own, so its two tables are
//! extended instead ([`extend`], which also extends both tables of a two-material
//! mixture): past the table's last clean ring (θ_c, see `rim.rs`) every window pixel
//! takes D from the fitted g_k at its normal (clamped to the circle) and S = the
//! rim model of the whole reflectance there minus D, and the split tables' search
//! radius reaches [`REACH`] px short of the circle (about 89° on R = 100): a target
//! normal between θ_c and 90° is fitted on the model, not clamped to the table's edge.

use super::rim::{Rim, RimBuf};
use crate::lut::table::Table;

/// Rounds of the robust refit.
const ROUNDS: usize = 6;
/// Inlier band, in robust standard deviations.
const INLIER_SIGMAS: f32 = 2.5;
/// Inlier band floor, as a fraction of the light's peak sample.
const INLIER_FLOOR: f32 = 0.005;
/// Entries with n·g below this fraction of |g| (near the terminator) are left out.
const TERMINATOR: f64 = 0.05;

/// Distance (px) short of the circle that the split tables' search reaches, when the
/// rim model extends them.
const REACH: f64 = 0.02;

/// `table` extended past its last clean ring with the rim model (module docs): every
/// window pixel beyond the clean ring takes the model's tuple at its own normal (clamped
/// to the circle), and the search reaches [`REACH`] px short of the circle. Used for both
/// tables of a two-material mixture, which has no rim refit of its own. Unchanged when
/// the table is too small to hold a ring.
pub(crate) fn extend(table: &Table) -> Table {
    let mut out = table.clone();
    let Some(rim) = Rim::fit(table) else {
        return out;
    };
    let k = table.k;
    let ws = &mut out.window.stack;
    let (cgx, cgy) = table.to_grid(table.circle.cx, table.circle.cy);
    let clean = table.search_radius() + 1.0;
    let mut buf = RimBuf::new(k);
    for r in 0..ws.height {
        for c in 0..ws.width {
            let (x, y) = (c as f64, r as f64);
            if ((x - cgx).powi(2) + (y - cgy).powi(2)).sqrt() >= clean {
                let at = (r * ws.width + c) * k;
                let n = unit(table.grid_normal(x, y));
                ws.data[at..at + k].copy_from_slice(rim.tuple(n, &mut buf));
            }
        }
    }
    out.rim = REACH.min(table.rim);
    out
}

/// The diffuse and specular tables of `table` (same window, circle and entries), both
/// extended past the table's edge ([`extend`]).
pub(crate) fn split(table: &Table) -> [Table; 2] {
    let k = table.k;
    let g: Vec<[f64; 3]> = (0..k).map(|i| fit_light(table, i)).collect();
    let ext = extend(table);
    let extended = ext.rim < table.rim;
    let mut diffuse = ext.clone();
    let mut specular = ext.clone();
    diffuse.material = format!("{} (diffuse part)", table.material);
    specular.material = format!("{} (specular part)", table.material);
    let ws = &ext.window.stack;
    for r in 0..ws.height {
        for c in 0..ws.width {
            let at = (r * ws.width + c) * k;
            let (x, y) = (c as f64, r as f64);
            let n = if extended {
                unit(table.grid_normal(x, y))
            } else {
                // padded pixels take the normal of the nearest point of the search disc
                let (gx, gy) = table.clamp_grid(x, y);
                table.grid_normal(gx, gy)
            };
            let tuple = &ws.data[at..at + k];
            for (i, gi) in g.iter().enumerate() {
                let v = lambert(&n, gi);
                diffuse.window.stack.data[at + i] = v;
                specular.window.stack.data[at + i] = tuple[i] - v;
            }
        }
    }
    for (e, n) in table.entries.normals.iter().enumerate() {
        let at = e * k;
        let tuple = &table.entries.tuples[at..at + k];
        for (i, gi) in g.iter().enumerate() {
            let d = lambert(n, gi);
            diffuse.entries.tuples[at + i] = d;
            specular.entries.tuples[at + i] = tuple[i] - d;
        }
    }
    [diffuse, specular]
}

/// Share of the table's light that is not Lambertian: Σ|S| / Σ|I| over its entries and
/// lights, with S = I − D the remainder of [`split`] (the highlight of a plastic).
pub(crate) fn specular_share(table: &Table) -> f64 {
    let k = table.k;
    let g: Vec<[f64; 3]> = (0..k).map(|i| fit_light(table, i)).collect();
    let (mut rest, mut all) = (0.0f64, 0.0f64);
    for (e, n) in table.entries.normals.iter().enumerate() {
        let tuple = &table.entries.tuples[e * k..(e + 1) * k];
        for (gi, &v) in g.iter().zip(tuple) {
            rest += f64::from((v - lambert(n, gi)).abs());
            all += f64::from(v.abs());
        }
    }
    if all > 0.0 {
        rest / all
    } else {
        0.0
    }
}

/// `n` scaled to unit length (the sphere's normal clamped to the circle outside it).
fn unit(n: [f32; 3]) -> [f32; 3] {
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if l > 0.0 {
        n.map(|v| v / l)
    } else {
        n
    }
}

/// max(0, n·g).
fn lambert(n: &[f32; 3], g: &[f64; 3]) -> f32 {
    (n[0] as f64 * g[0] + n[1] as f64 * g[1] + n[2] as f64 * g[2]).max(0.0) as f32
}

/// Robust Lambertian fit g of light `i` over the table's entries (module docs).
fn fit_light(table: &Table, i: usize) -> [f64; 3] {
    let k = table.k;
    let samples: Vec<(f32, [f32; 3])> = table
        .entries
        .normals
        .iter()
        .enumerate()
        .map(|(e, n)| (table.entries.tuples[e * k + i], *n))
        .collect();
    let peak = samples.iter().map(|s| s.0).fold(0.0f32, f32::max);
    if peak <= 0.0 {
        return [0.0; 3];
    }
    // start: every clearly lit entry
    let mut g = least_squares(samples.iter().filter(|s| s.0 > 0.1 * peak));
    for _ in 0..ROUNDS {
        let Some(gv) = g else { break };
        let gn = (gv[0] * gv[0] + gv[1] * gv[1] + gv[2] * gv[2]).sqrt();
        let lit = |n: &[f32; 3]| {
            n[0] as f64 * gv[0] + n[1] as f64 * gv[1] + n[2] as f64 * gv[2] > TERMINATOR * gn
        };
        let mut res: Vec<f32> = samples
            .iter()
            .filter(|s| lit(&s.1))
            .map(|s| (s.0 - lambert(&s.1, &gv)).abs())
            .collect();
        if res.len() < 10 {
            break;
        }
        let mid = res.len() / 2;
        let mad = *res.select_nth_unstable_by(mid, f32::total_cmp).1;
        let band = INLIER_SIGMAS * 1.4826 * mad + INLIER_FLOOR * peak;
        g = least_squares(
            samples
                .iter()
                .filter(|s| lit(&s.1) && (s.0 - lambert(&s.1, &gv)).abs() <= band),
        )
        .or(g);
    }
    g.unwrap_or([0.0; 3])
}

/// Least-squares g of v ≈ n·g over `samples` (None when singular).
fn least_squares<'s>(samples: impl Iterator<Item = &'s (f32, [f32; 3])>) -> Option<[f64; 3]> {
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for (v, n) in samples {
        let n = [n[0] as f64, n[1] as f64, n[2] as f64];
        for r in 0..3 {
            for c in 0..3 {
                a[r][c] += n[r] * n[c];
            }
            b[r] += n[r] * *v as f64;
        }
    }
    solve3(a, b)
}

/// Solve the 3×3 system a·x = b by Cramer's rule (None when near singular).
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&a);
    let scale = a[0][0] * a[1][1] * a[2][2];
    if d.is_nan() || d.abs() <= 1e-9 * scale.abs() || scale == 0.0 {
        return None;
    }
    let mut x = [0.0; 3];
    for (j, xj) in x.iter_mut().enumerate() {
        let mut m = a;
        for r in 0..3 {
            m[r][j] = b[r];
        }
        *xj = det(&m) / d;
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solve3_solves_a_small_system() {
        let a = [[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]];
        let x = solve3(a, [1.0, 2.0, 3.0]).unwrap();
        for r in 0..3 {
            let v: f64 = (0..3).map(|c| a[r][c] * x[c]).sum();
            assert!((v - [1.0, 2.0, 3.0][r]).abs() < 1e-12);
        }
    }
}
