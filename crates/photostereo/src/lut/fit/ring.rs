//! The least-squares pieces of the rim model (`rim.rs`): the fit of β per sector and
//! light over a band of polar angle, and the masking factor m(n_z) with its derivative.

use crate::lut::table::Table;

/// Fewest lit entries that make a sector's fit for one light.
const MIN_SAMPLES: usize = 6;

/// β of every sector and light (`Rim::beta`'s layout), fitted by least squares to the
/// entries with polar angle in `band` lit above `dark`, with the masking width `a`;
/// `kp` is K padded as `Rim` pads it.
pub(crate) fn fit_beta(
    table: &Table,
    sectors: usize,
    kp: usize,
    band: (f64, f64),
    a: Option<f64>,
    dark: f32,
) -> Vec<f32> {
    let k = table.k;
    let width = std::f64::consts::TAU / sectors as f64;
    // per sector and light: Σ x xᵀ (6 values) and Σ I x (3 values), x = m(n_z)·n
    let mut acc = vec![([0.0f64; 6], [0.0f64; 3], 0usize); sectors * k];
    let e = &table.entries;
    for (i, n) in e.normals.iter().enumerate() {
        let n = [n[0] as f64, n[1] as f64, n[2] as f64];
        let theta = n[2].clamp(-1.0, 1.0).acos();
        if theta < band.0 || theta > band.1 {
            continue;
        }
        let phi = n[1].atan2(n[0]);
        let mf = masking(a, n[2]);
        let x = n.map(|v| v * mf);
        let outer = [
            x[0] * x[0],
            x[0] * x[1],
            x[0] * x[2],
            x[1] * x[1],
            x[1] * x[2],
            x[2] * x[2],
        ];
        let centre = (phi / width).round() as i64;
        for s in centre - 1..=centre + 1 {
            let d = phi - s as f64 * width;
            let d =
                (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
            if d.abs() > width {
                continue;
            }
            let s = s.rem_euclid(sectors as i64) as usize;
            let tuple = &e.tuples[i * k..(i + 1) * k];
            for (light, &v) in tuple.iter().enumerate() {
                if v <= dark {
                    continue;
                }
                let (m, b, count) = &mut acc[s * k + light];
                m.iter_mut().zip(outer).for_each(|(a, o)| *a += o);
                (0..3).for_each(|j| b[j] += v as f64 * x[j]);
                *count += 1;
            }
        }
    }
    let mut beta = vec![0.0f32; sectors * 3 * kp];
    for (i, (m, b, count)) in acc.iter().enumerate() {
        if *count < MIN_SAMPLES {
            continue;
        }
        let (s, light) = (i / k, i % k);
        if let Some(x) = solve3(m, b) {
            (0..3).for_each(|j| beta[(s * 3 + j) * kp + light] = x[j] as f32);
        }
    }
    beta
}

/// Solve the symmetric 3×3 system given by its upper triangle (xx, xy, xz, yy, yz, zz).
fn solve3(m: &[f64; 6], b: &[f64; 3]) -> Option<[f64; 3]> {
    let a = [[m[0], m[1], m[2]], [m[1], m[3], m[4]], [m[2], m[4], m[5]]];
    let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    let scale = m[0] + m[3] + m[5];
    if det.is_nan() || det.abs() <= 1e-12 * scale.powi(3) {
        return None;
    }
    let col = |j: usize| -> f64 {
        let mut c = a;
        (0..3).for_each(|i| c[i][j] = b[i]);
        c[0][0] * (c[1][1] * c[2][2] - c[1][2] * c[2][1])
            - c[0][1] * (c[1][0] * c[2][2] - c[1][2] * c[2][0])
            + c[0][2] * (c[1][0] * c[2][1] - c[1][1] * c[2][0])
    };
    Some([col(0) / det, col(1) / det, col(2) / det])
}

/// Smith's masking of the view over n_z, G₁(v)/(n·v) up to a constant:
/// m(u) = 1/(u + √(a² + (1 − a²)u²)); 1 without a width.
pub(crate) fn masking(a: Option<f64>, u: f64) -> f64 {
    match a {
        None => 1.0,
        Some(a) => {
            let u = u.max(0.0);
            1.0 / (u + (a * a + (1.0 - a * a) * u * u).sqrt())
        }
    }
}

/// d ln m / du.
pub(crate) fn masking_dlog(a: Option<f64>, u: f64) -> f64 {
    match a {
        None => 0.0,
        Some(a) => {
            let u = u.max(0.0);
            let s = (a * a + (1.0 - a * a) * u * u).sqrt();
            -(1.0 + (1.0 - a * a) * u / s) / (u + s)
        }
    }
}
