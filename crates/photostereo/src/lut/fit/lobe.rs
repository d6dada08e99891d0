//! A parametric reflectance per light, the rim model's second candidate (`rim.rs`):
//!
//! I_k(n) = c_k·max(0, l_k·n) + s_k·D(n·h_k; α)·G₁(n·l_k)·G₁(n·v)/(n·v),  v = (0, 0, 1),
//!
//! a Lambertian term plus a microfacet lobe (GGX D = α²/(π((n·h)²(α² − 1) + 1)²), Smith's
//! G₁(u) = 2u/(u + √(α² + (1 − α²)u²)); Fresnel depends on v·h only, fixed per light, and
//! goes into s_k), zero where n·l_k ≤ 0. The linear model max(0, β·n)·m(n_z) is local:
//! fitted on the table's outer ring it cannot follow a rough metal's D(n·h) over the 16°
//! between a small sphere's last clean ring (θ_c ≈ 73.7° at R = 50) and 90°. This one is
//! global: its shape comes from the whole table.
//!
//! The fit: each light's direction l_k and a width α_k by a pattern search over the
//! table's entries (a peak-weighted subset; c_k, s_k by non-negative least squares at
//! each point), started from the light's brightest entry taken as h_k (a specular peak)
//! and as l_k (a diffuse one); α is shared (the median of the α_k, then a 1-D search
//! over a few multiples of it on the held-out test), and c_k, s_k are refitted by linear
//! least squares on the ring of entries the rim model is fitted to. `rim.rs` keeps this
//! model only where it predicts the table's outermost band better than the linear one.

use super::ring::{masking, masking_dlog};
use crate::lut::table::Table;
use rayon::prelude::*;

/// Multiples of the median width α tried by the held-out test.
const ALPHA_STEPS: &[f64] = &[0.8, 0.9, 1.0, 1.1, 1.25];
/// Entries below this fraction of a light's brightest one are thinned in the geometry
/// fit (every [`THIN`]th kept): the lobe's core decides the direction.
const CORE: f32 = 0.02;
const THIN: usize = 4;
/// Most samples of one light's geometry fit.
const MAX_SAMPLES: usize = 2000;
/// A light whose brightest entries are equal to this fraction (three or more) is
/// clipped there.
const CLIPPED: f32 = 0.9999;
/// Pattern search: first and last step of the angles (radians) and of ln α.
const STEP0: f64 = 0.06;
const STEP_END: f64 = 1e-3;
/// Widths α tried at most (the search keeps α in this range).
const ALPHA_RANGE: (f64, f64) = (0.02, 1.0);

/// The fitted model (see the module docs).
pub(crate) struct Lobe {
    k: usize,
    /// Light directions and half vectors, unit.
    l: Vec<[f64; 3]>,
    h: Vec<[f64; 3]>,
    /// Diffuse and specular coefficients per light.
    c: Vec<f64>,
    s: Vec<f64>,
    alpha: f64,
}

/// GGX D(x) (without 1/π) and d ln D / dx.
#[inline(always)]
fn ggx(a2: f64, x: f64) -> (f64, f64) {
    let t = x * x * (a2 - 1.0) + 1.0;
    (a2 / (t * t), -4.0 * x * (a2 - 1.0) / t)
}

/// The two basis values (diffuse, specular) of one light at unit normal `n`, width α.
#[inline(always)]
fn basis(n: [f64; 3], l: [f64; 3], h: [f64; 3], alpha: f64) -> (f64, f64) {
    let nl = dot(n, l);
    if nl <= 0.0 || n[2] <= 0.0 {
        return (0.0, 0.0);
    }
    let (d, _) = ggx(alpha * alpha, dot(n, h).max(0.0));
    let a = Some(alpha);
    (nl, d * nl * masking(a, nl) * masking(a, n[2]))
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Half vector of light `l` and the view (0, 0, 1).
fn half(l: [f64; 3]) -> [f64; 3] {
    let h = [l[0], l[1], l[2] + 1.0];
    let n = dot(h, h).sqrt().max(1e-12);
    h.map(|v| v / n)
}

/// Unit vector at polar angle θ and azimuth φ.
fn unit(theta: f64, phi: f64) -> [f64; 3] {
    let s = theta.sin();
    [s * phi.cos(), s * phi.sin(), theta.cos()]
}

/// Non-negative least squares of v ≈ c·x + s·y from the sums (xx, xy, yy, xv, yv);
/// returns (c, s, residual − Σv²).
fn nnls2(m: [f64; 5]) -> (f64, f64, f64) {
    let [xx, xy, yy, xv, yv] = m;
    let cost =
        |c: f64, s: f64| c * c * xx + 2.0 * c * s * xy + s * s * yy - 2.0 * (c * xv + s * yv);
    let det = xx * yy - xy * xy;
    if det > 1e-12 * (xx * yy).max(1e-300) {
        let (c, s) = ((yy * xv - xy * yv) / det, (xx * yv - xy * xv) / det);
        if c >= 0.0 && s >= 0.0 {
            return (c, s, cost(c, s));
        }
    }
    let c = if xx > 0.0 { (xv / xx).max(0.0) } else { 0.0 };
    let s = if yy > 0.0 { (yv / yy).max(0.0) } else { 0.0 };
    let (a, b) = (cost(c, 0.0), cost(0.0, s));
    if a <= b {
        (c, 0.0, a)
    } else {
        (0.0, s, b)
    }
}

/// The entries one light's geometry is fitted to: (normal, value).
fn geometry_samples(table: &Table, light: usize) -> Vec<([f64; 3], f64)> {
    let (k, e) = (table.k, &table.entries);
    let peak = (0..e.normals.len())
        .map(|i| e.tuples[i * k + light])
        .fold(0.0f32, f32::max);
    // a clipped highlight: its flat top says only "at least this", and left in it
    // widens the fitted lobe
    let at_top = (0..e.normals.len())
        .filter(|&i| e.tuples[i * k + light] >= peak * CLIPPED)
        .count();
    let clipped = at_top >= 3;
    let mut thin = 0usize;
    let mut out = Vec::new();
    for (i, n) in e.normals.iter().enumerate() {
        let v = e.tuples[i * k + light];
        if clipped && v >= peak * CLIPPED {
            continue;
        }
        if v < CORE * peak {
            thin += 1;
            if thin % THIN != 0 {
                continue;
            }
        }
        out.push((n.map(f64::from), f64::from(v)));
    }
    // a large table's every n-th sample: the fit's cost bounded, its shape unchanged
    let stride = out.len().div_ceil(MAX_SAMPLES);
    if stride > 1 {
        out = out.into_iter().step_by(stride).collect();
    }
    out
}

/// Cost (up to a constant) of the best c, s at light direction (θ, φ) and width α.
fn geometry_cost(samples: &[([f64; 3], f64)], p: [f64; 3]) -> f64 {
    let l = unit(p[0], p[1]);
    let (h, alpha) = (half(l), p[2].exp());
    let mut m = [0.0f64; 5];
    for &(n, v) in samples {
        let (x, y) = basis(n, l, h, alpha);
        m[0] += x * x;
        m[1] += x * y;
        m[2] += y * y;
        m[3] += x * v;
        m[4] += y * v;
    }
    nnls2(m).2
}

/// Pattern search over (θ_l, φ_l, ln α) from `p`; returns the point and its cost.
fn pattern_search(samples: &[([f64; 3], f64)], mut p: [f64; 3]) -> ([f64; 3], f64) {
    let mut cost = geometry_cost(samples, p);
    let mut step = STEP0;
    let bounds = [
        (0.0, std::f64::consts::FRAC_PI_2 * 0.999),
        (f64::NEG_INFINITY, f64::INFINITY),
        (ALPHA_RANGE.0.ln(), ALPHA_RANGE.1.ln()),
    ];
    while step > STEP_END {
        let mut moved = false;
        for j in 0..3 {
            // ln α moves in larger steps than the angles
            let d = if j == 2 { 4.0 * step } else { step };
            for sign in [1.0, -1.0] {
                let mut q = p;
                q[j] = (q[j] + sign * d).clamp(bounds[j].0, bounds[j].1);
                let c = geometry_cost(samples, q);
                if c < cost {
                    (p, cost, moved) = (q, c, true);
                    break;
                }
            }
        }
        if !moved {
            step *= 0.5;
        }
    }
    (p, cost)
}

/// Direction and width of one light: the better of the searches started from its
/// brightest entry taken as the half vector and as the light.
fn fit_light(table: &Table, light: usize) -> Option<([f64; 3], f64)> {
    let samples = geometry_samples(table, light);
    let (_, top) = samples.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1))?;
    if top <= 0.0 || samples.len() < 12 {
        return None;
    }
    let n = samples.iter().find(|s| s.1 == top)?.0;
    // the light mirrored about the peak normal: l = 2(n·v)n − v
    let mirrored = [
        2.0 * n[2] * n[0],
        2.0 * n[2] * n[1],
        2.0 * n[2] * n[2] - 1.0,
    ];
    let mut best: Option<([f64; 3], f64)> = None;
    for l in [mirrored, n] {
        let start = [l[2].clamp(-1.0, 1.0).acos(), l[1].atan2(l[0]), 0.2f64.ln()];
        let (p, cost) = pattern_search(&samples, start);
        if best.is_none_or(|b| cost < b.1) {
            best = Some((p, cost));
        }
    }
    best.map(|(p, _)| (unit(p[0], p[1]), p[2].exp()))
}

impl Lobe {
    /// Each light's direction and the median width (module docs); `None` when a light
    /// has too few samples.
    pub fn geometry(table: &Table) -> Option<(Vec<[f64; 3]>, f64)> {
        let fits: Option<Vec<_>> = (0..table.k)
            .into_par_iter()
            .map(|light| fit_light(table, light))
            .collect();
        let (l, mut alphas): (Vec<_>, Vec<_>) = fits?.into_iter().unzip();
        alphas.sort_by(f64::total_cmp);
        Some((l, alphas[alphas.len() / 2]))
    }

    /// The model with directions `l`, width `alpha` and c_k, s_k fitted to the entries
    /// with polar angle in `band`.
    pub fn on_band(table: &Table, l: &[[f64; 3]], alpha: f64, band: (f64, f64)) -> Lobe {
        let k = table.k;
        let h: Vec<[f64; 3]> = l.iter().map(|&l| half(l)).collect();
        let mut m = vec![[0.0f64; 5]; k];
        let e = &table.entries;
        for (i, n) in e.normals.iter().enumerate() {
            let theta = f64::from(n[2]).clamp(-1.0, 1.0).acos();
            if theta < band.0 || theta > band.1 {
                continue;
            }
            let n = n.map(f64::from);
            for (light, m) in m.iter_mut().enumerate() {
                let v = f64::from(e.tuples[i * k + light]);
                let (x, y) = basis(n, l[light], h[light], alpha);
                m[0] += x * x;
                m[1] += x * y;
                m[2] += y * y;
                m[3] += x * v;
                m[4] += y * v;
            }
        }
        let (c, s) = m.iter().map(|&m| nnls2(m)).map(|(c, s, _)| (c, s)).unzip();
        Lobe {
            k,
            l: l.to_vec(),
            h,
            c,
            s,
            alpha,
        }
    }

    /// The model fitted on [`Lobe::on_band`]'s ring [lo, hi] with α chosen among
    /// [`ALPHA_STEPS`] × the median by how well the fit predicts the entries above
    /// `hi`; returns it with that held-out error (the same sum as `rim.rs`'s).
    pub fn choose(table: &Table, l: &[[f64; 3]], alpha: f64, lo: f64, hi: f64) -> (f64, f64) {
        let mut best = (f64::INFINITY, alpha);
        for f in ALPHA_STEPS {
            let a = (alpha * f).clamp(ALPHA_RANGE.0, ALPHA_RANGE.1);
            let err = Lobe::on_band(table, l, a, (lo, hi)).held_out_error(table, hi);
            if err < best.0 {
                best = (err, a);
            }
        }
        best
    }

    /// Sum of squared differences between the model and the entries with polar angle
    /// above `from`, over every light.
    fn held_out_error(&self, table: &Table, from: f64) -> f64 {
        let (k, e) = (self.k, &table.entries);
        let mut p = vec![0.0f32; k];
        let mut err = 0.0;
        for (i, n) in e.normals.iter().enumerate() {
            if f64::from(n[2]).clamp(-1.0, 1.0).acos() < from {
                continue;
            }
            self.value(n.map(f64::from), &mut p);
            let tuple = &e.tuples[i * k..(i + 1) * k];
            err += p
                .iter()
                .zip(tuple)
                .map(|(p, v)| f64::from(p - v).powi(2))
                .sum::<f64>();
        }
        err
    }

    /// The model's tuple at unit normal `n` into `p` (K values).
    #[inline(always)]
    pub fn value(&self, n: [f64; 3], p: &mut [f32]) {
        for (i, p) in p[..self.k].iter_mut().enumerate() {
            let (x, y) = basis(n, self.l[i], self.h[i], self.alpha);
            *p = (self.c[i] * x + self.s[i] * y) as f32;
        }
    }

    /// The tuple at `n` into `p` and its derivatives along `nt` and `np` (the normal's
    /// derivatives in θ and φ) into `pt`, `pp`.
    #[inline(always)]
    pub fn grad(
        &self,
        n: [f64; 3],
        (nt, np): ([f64; 3], [f64; 3]),
        p: &mut [f32],
        pt: &mut [f32],
        pp: &mut [f32],
    ) {
        let (alpha, a2) = (Some(self.alpha), self.alpha * self.alpha);
        let mz = masking(alpha, n[2]);
        let dmz = masking_dlog(alpha, n[2]);
        for i in 0..self.k {
            let (l, h) = (self.l[i], self.h[i]);
            let nl = dot(n, l);
            if nl <= 0.0 || n[2] <= 0.0 {
                (p[i], pt[i], pp[i]) = (0.0, 0.0, 0.0);
                continue;
            }
            let (d, dlnd) = ggx(a2, dot(n, h).max(0.0));
            let ml = masking(alpha, nl);
            // specular y = D·nl·m(nl)·m(n_z); ∂y/∂(n·l) = D·m(nl)(1 + nl·dln m)·m(n_z)
            let y = d * nl * ml * mz;
            let dy_nl = d * ml * (1.0 + nl * masking_dlog(alpha, nl)) * mz;
            let (c, s) = (self.c[i], self.s[i]);
            let along = |t: [f64; 3]| {
                c * dot(t, l) + s * (y * dlnd * dot(t, h) + dy_nl * dot(t, l) + y * dmz * t[2])
            };
            p[i] = (c * nl + s * y) as f32;
            pt[i] = along(nt) as f32;
            pp[i] = along(np) as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lut::table::BuildOptions;
    use crate::synth::{self, Material, SceneOptions};

    /// The fitted lights and width of `synth`'s GGX metal (R = 50, 16 lights) against the
    /// truth; and the model's value and derivatives against finite differences.
    #[test]
    fn lobe_recovers_a_ggx_metals_lights_and_width() {
        let opts = SceneOptions {
            material: Material::metal(),
            lights: synth::default_lights(16),
            camera: synth::Camera::quantized(16),
            ..SceneOptions::default()
        };
        // `synth --exposure auto`: the peak unclipped
        let mut opts = opts;
        opts.exposure = synth::exposure_for_full_scale(&opts, Some(50.0), 0.98).unwrap();
        let sphere = synth::render_calibration_sphere(&opts, 50.0).unwrap();
        let circle = crate::sphere::Circle {
            cx: 52.0,
            cy: 52.0,
            radius: 50.0,
        };
        let table = Table::build(&sphere.stack, &circle, &BuildOptions::default()).unwrap();
        let (l, alpha) = Lobe::geometry(&table).unwrap();
        let mut worst = 0.0f64;
        for (i, l) in l.iter().enumerate() {
            let t = opts.lights.directions[i].map(f64::from);
            worst = worst.max(dot(*l, t).clamp(-1.0, 1.0).acos().to_degrees());
        }
        println!("lobe: lights within {worst:.3}°, α {alpha:.4} (true 0.2)");
        assert!(worst < 0.5, "light directions {worst}° off");
        assert!((alpha - 0.2).abs() < 0.01, "α {alpha}");
        // derivatives
        let lobe = Lobe::on_band(&table, &l, alpha, (0.9, 1.3));
        let k = table.k;
        let (mut p, mut pt, mut pp) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
        let (theta, phi, eps) = (1.4f64, 0.7f64, 1e-4);
        let nt = [
            theta.cos() * phi.cos(),
            theta.cos() * phi.sin(),
            -theta.sin(),
        ];
        let np = [-theta.sin() * phi.sin(), theta.sin() * phi.cos(), 0.0];
        lobe.grad(unit(theta, phi), (nt, np), &mut p, &mut pt, &mut pp);
        let (mut a, mut b) = (vec![0.0; k], vec![0.0; k]);
        lobe.value(unit(theta + eps, phi), &mut a);
        lobe.value(unit(theta - eps, phi), &mut b);
        for i in 0..k {
            let fd = (a[i] as f64 - b[i] as f64) / (2.0 * eps);
            let tol = 1e-3 * (p[i] as f64 + 1e-2);
            assert!(
                (fd - pt[i] as f64).abs() < tol + 0.02 * fd.abs(),
                "θ light {i}: {fd} {}",
                pt[i]
            );
        }
    }
}
