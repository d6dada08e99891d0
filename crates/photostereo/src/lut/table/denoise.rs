//! Denoising the table as a function on the normal sphere (local polynomial regression).
//!
//! Each light's sphere intensity I_k(n) is a smooth function of the normal n, not of
//! the image position: a sphere pixel at (x, y) from the circle's centre has
//! n = (x/R, y/R, √(1 − ρ²)), and near the rim one pixel spans 1/(R n_z) radians, so
//! in image coordinates I has derivatives that grow like n_z⁻¹ (first) and n_z⁻³
//! (second). A Gaussian blur of the images of σ pixels therefore biases each sample by
//! about σ²/2 · Δ_xy I, and that bias grows towards the rim, the band that grazing
//! target pixels are matched against.
//!
//! Here each sample inside the table's support (R − rim + 1 from the centre) is
//! replaced by the value at its own normal n_i of a **weighted least-squares fit of a
//! quadratic over the normal sphere's tangent plane at n_i** (locally weighted
//! regression, Cleveland & Devlin, "Locally weighted regression", JASA 83(403), 1988;
//! Fan & Gijbels, *Local Polynomial Modelling and Its Applications*, 1996):
//!
//! Î_k(n_i) = â₀,  (â) = argmin Σ_j w_ij (I_k(n_j) − φ(u_j, v_j)·a)²,
//! φ = (1, u, v, u², uv, v²),  (u_j, v_j) = (t₁·n_j, t₂·n_j) R/h,
//!
//! with (t₁, t₂, n_i) an orthonormal frame at n_i (Duff et al., "Building an
//! orthonormal basis, revisited", JCGT 6(1), 2017), so (u, v) are smooth coordinates of
//! the normal around n_i (orthographic projection on the tangent plane) whatever n_z.
//! The weights are Gaussian in the pixel distance, w_ij = exp(−d_ij²/(2h²)), over the
//! samples inside the support only (no background, no padding): every sample is fitted
//! on about the same number of pixels (the local sample density: R² n_z pixels per
//! steradian, so the kernel is wider in angle where pixels are sparser, near the rim,
//! and the variance stays even), while the model follows I on the sphere, not in the
//! image. The estimate is linear in the data, Î_k(n_i) = Σ_j ℓ_ij I_k(n_j) with
//! ℓ_i = e₁ᵀ (ΦᵀWΦ)⁻¹ ΦᵀW, and ℓ_i depends only on the geometry, so it is computed once
//! per pixel and applied to all K lights.
//!
//! **Bias and variance.** The fit reproduces any quadratic in (u, v) exactly, so the
//! σ²/2 · ΔI bias of a blur is gone (what is left is of order h³–h⁴ times the third
//! and fourth derivatives of I on the sphere), also at the support's edge, where a
//! blur is one-sided. Its price is variance: at an interior point the equivalent
//! kernel of a Gaussian-weighted quadratic is ℓ(d) ∝ (2 − d²/(2h²)) e^(−d²/(2h²)), whose
//! Σℓ² is 2.5/(4πh²) against 1/(4πσ²) for a blur; a width h = √2.5 σ ≈ 1.58 σ gives
//! the same noise as the blur of σ at the centre, with far less bias. The width
//! follows the noise measured on the sphere: the blur's rule σ ([`super::BuildOptions`])
//! times a factor chosen by leave-one-out cross-validation on the sphere itself
//! (Allen 1974; Stone 1974): for a linear smoother the prediction error of sample i
//! from the others is (I_ik − Î_ik)/(1 − ℓ_ii), and its mean square over the samples
//! and lights, CV(h), estimates the fit's mean squared error plus σ², so the factor of
//! [`WIDTH_FACTORS`] with the lowest CV(h) balances bias (sharp highlights, few lights
//! → narrow) against variance (smooth shading, dark noisy lobes → wide). Measured on
//! the project's renders (K = 16, 1% noise) it picks 2–2.5 σ, on DiLiGenT's ball
//! (K = 96) 1.6 σ.

use rayon::prelude::*;

use super::window::Window;
use crate::sphere::Circle;

/// How the sphere's samples are denoised before the table is built (see the module
/// docs of `lut::denoise`). Either way the width follows the noise measured on the
/// sphere ([`super::BuildOptions::smooth`]), and a clean sphere is left as it is.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Denoise {
    /// `NormalSpace { width: None }` when the noise rule's σ is at least
    /// [`FIT_FROM_PX`] pixels, else `ImageBlur` (default). Below that width the
    /// quadratic's kernel holds too few pixels for its 6 coefficients: on DiLiGenT's
    /// ball (K = 96, σ = 0.55 px) the fit gave 0.088° and a confidence–error Spearman of
    /// −0.55 in `lut_shared`, the blur 0.082° and −0.63.
    #[default]
    Auto,
    /// Gaussian blur of the sphere images of σ = [`super::BuildOptions::smooth`] pixels
    /// (the table before the normal-space fit).
    ImageBlur,
    /// Local quadratic regression over the normal sphere with Gaussian weights of
    /// `width` × σ pixels, σ = [`super::BuildOptions::smooth`] (the blur's width).
    /// `None`: the factor among [`WIDTH_FACTORS`] with the lowest
    /// leave-one-out cross-validation error on the sphere itself.
    NormalSpace {
        /// Kernel width as a multiple of the blur's σ (dimensionless, > 0), or `None`
        /// to choose it by cross-validation.
        width: Option<f64>,
    },
}

impl Denoise {
    /// The denoising actually applied for a noise rule's blur width of `sigma_px`
    /// pixels: [`Denoise::Auto`] becomes the normal-space fit from [`FIT_FROM_PX`] on
    /// and the image blur below it; the other variants stay as they are. (Nothing is
    /// denoised at all when `sigma_px` ≤ 0.)
    pub fn resolve(self, sigma_px: f64) -> Denoise {
        match self {
            Denoise::Auto if sigma_px >= FIT_FROM_PX => Denoise::NormalSpace { width: None },
            Denoise::Auto => Denoise::ImageBlur,
            other => other,
        }
    }
}

impl std::str::FromStr for Denoise {
    type Err = crate::Error;

    /// `"normal"` (the fit over the normal sphere, width by cross-validation), `"image"`
    /// (the blur of the sphere images) or `"auto"`, as the CLI's `--denoise` and
    /// Python's `denoise=` spell them.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "auto" => Ok(Denoise::Auto),
            "normal" => Ok(Denoise::NormalSpace { width: None }),
            "image" => Ok(Denoise::ImageBlur),
            other => Err(crate::Error::invalid(
                format!("denoising {other:?}"),
                "give \"normal\" (a fit over the normal sphere), \"image\" (a blur of the sphere images) or \"auto\" (the fit when the noise asks for a blur of at least 1 px)",
            )),
        }
    }
}

/// Smallest blur width σ (pixels) at which [`Denoise::Auto`] fits in normal space.
pub const FIT_FROM_PX: f64 = 1.0;

/// Kernel widths (multiples of the blur's σ) tried by the cross-validation: from the
/// blur's own width to 4×; √2.5 ≈ 1.6 has the blur's variance at the sphere's centre.
pub const WIDTH_FACTORS: [f64; 7] = [1.0, 1.3, 1.6, 2.0, 2.5, 3.0, 4.0];

/// Number of monomials of the local quadratic.
const TERMS: usize = 6;

/// Orthonormal tangent vectors (t₁, t₂) at unit normal n with n_z ≥ 0 (Duff et al. 2017).
fn frame(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let a = -1.0 / (1.0 + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + n[0] * n[0] * a, b, -n[0]],
        [b, 1.0 + n[1] * n[1] * a, -n[1]],
    )
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[allow(clippy::needless_range_loop)]
/// Solve the symmetric positive definite system A x = b (Cholesky, in place); false
/// when A is (numerically) singular.
fn solve_spd(a: &mut [[f64; TERMS]; TERMS], b: &mut [f64; TERMS]) -> bool {
    let scale = (0..TERMS).map(|i| a[i][i]).fold(0.0, f64::max);
    for j in 0..TERMS {
        let mut d = a[j][j];
        for p in 0..j {
            d -= a[j][p] * a[j][p];
        }
        if d.is_nan() || d <= 1e-10 * scale {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..TERMS {
            let mut s = a[i][j];
            for p in 0..j {
                s -= a[i][p] * a[j][p];
            }
            a[i][j] = s / d;
        }
    }
    for i in 0..TERMS {
        let s = (0..i).fold(b[i], |s, p| s - a[i][p] * b[p]);
        b[i] = s / a[i][i];
    }
    for i in (0..TERMS).rev() {
        let s = (i + 1..TERMS).fold(b[i], |s, p| s - a[p][i] * b[p]);
        b[i] = s / a[i][i];
    }
    true
}

/// The sphere's geometry on the window: centre in grid coordinates, radius, support.
struct Geometry {
    gcx: f64,
    gcy: f64,
    radius: f64,
    support: f64,
}

impl Geometry {
    /// Unit normal of window pixel (r, c), or None outside the support.
    fn normal(&self, r: usize, c: usize) -> Option<[f64; 3]> {
        let (dx, dy) = (c as f64 - self.gcx, r as f64 - self.gcy);
        if (dx * dx + dy * dy).sqrt() >= self.support {
            return None;
        }
        let (x, y) = (dx / self.radius, dy / self.radius);
        Some([x, y, (1.0 - x * x - y * y).max(0.0).sqrt()])
    }
}

#[allow(clippy::needless_range_loop)]
/// Equivalent-kernel weights ℓ_ij of pixel (r, c) over its neighbours: pushes
/// (flat index, ℓ) into `out`. Falls back to the Gaussian mean when the quadratic is
/// not determined.
fn kernel(
    geo: &Geometry,
    w: usize,
    h: usize,
    r: usize,
    c: usize,
    width: f64,
    out: &mut Vec<(usize, f64)>,
) {
    out.clear();
    let Some(ni) = geo.normal(r, c) else {
        return;
    };
    let (t1, t2) = frame(ni);
    let reach = (3.0 * width).ceil() as isize;
    let (inv2h2, s) = (1.0 / (2.0 * width * width), geo.radius / width);
    let mut rows: Vec<(usize, f64, [f64; TERMS])> = Vec::new();
    let mut a = [[0.0f64; TERMS]; TERMS];
    for dr in -reach..=reach {
        for dc in -reach..=reach {
            let (rr, cc) = (r as isize + dr, c as isize + dc);
            if rr < 0 || cc < 0 || rr >= h as isize || cc >= w as isize {
                continue;
            }
            let d2 = (dr * dr + dc * dc) as f64;
            if d2 > (reach * reach) as f64 {
                continue;
            }
            let Some(nj) = geo.normal(rr as usize, cc as usize) else {
                continue;
            };
            let wt = (-d2 * inv2h2).exp();
            let (u, v) = (s * dot(t1, nj), s * dot(t2, nj));
            let phi = [1.0, u, v, u * u, u * v, v * v];
            for i in 0..TERMS {
                for j in 0..=i {
                    a[i][j] += wt * phi[i] * phi[j];
                }
            }
            rows.push((rr as usize * w + cc as usize, wt, phi));
        }
    }
    for i in 0..TERMS {
        for j in i + 1..TERMS {
            a[i][j] = a[j][i];
        }
    }
    let mut e = [0.0f64; TERMS];
    e[0] = 1.0;
    if solve_spd(&mut a, &mut e) {
        out.extend(rows.iter().map(|(j, wt, phi)| {
            let l: f64 = phi.iter().zip(&e).map(|(p, q)| p * q).sum();
            (*j, wt * l)
        }));
    } else {
        let total: f64 = rows.iter().map(|x| x.1).sum();
        out.extend(rows.iter().map(|(j, wt, _)| (*j, wt / total)));
    }
}

/// Leave-one-out cross-validation score of the fit of kernel width `width` (pixels):
/// Σ_i Σ_k ((I_ik − Î_ik) / (1 − ℓ_ii))² / count over every `step`-th row and column of
/// the support (for a linear smoother this is the prediction error of each sample from
/// the others, an unbiased estimate of the fit's mean squared error plus σ²).
fn cross_validation(window: &Window, geo: &Geometry, width: f64, step: usize) -> f64 {
    let ws = &window.stack;
    let (w, h, k) = (ws.width, ws.height, ws.k);
    let src = &ws.data;
    let (sum, count) = (0..h)
        .into_par_iter()
        .step_by(step)
        .map(|r| {
            let mut ell = Vec::new();
            let (mut sum, mut count) = (0.0f64, 0usize);
            for c in (0..w).step_by(step) {
                kernel(geo, w, h, r, c, width, &mut ell);
                let i = r * w + c;
                let Some(&(_, self_weight)) = ell.iter().find(|x| x.0 == i) else {
                    continue;
                };
                if self_weight >= 0.95 {
                    return (f64::INFINITY, 1);
                }
                for light in 0..k {
                    let fit: f64 = ell
                        .iter()
                        .map(|&(j, l)| l * src[j * k + light] as f64)
                        .sum();
                    sum += ((src[i * k + light] as f64 - fit) / (1.0 - self_weight)).powi(2);
                }
                count += k;
            }
            (sum, count)
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if count == 0 {
        f64::INFINITY
    } else {
        sum / count as f64
    }
}

/// The kernel width (pixels) among `base` × `factors` with the lowest cross-validation
/// score ([`cross_validation`], on every 4th row and column), and its score.
pub(crate) fn choose_width(
    window: &Window,
    circle: &Circle,
    rim: f64,
    base: f64,
    factors: &[f64],
) -> (f64, f64) {
    let geo = geometry(window, circle, rim);
    factors
        .iter()
        .map(|f| {
            let width = f * base;
            (width, cross_validation(window, &geo, width, 4))
        })
        .fold((base, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a })
}

fn geometry(window: &Window, circle: &Circle, rim: f64) -> Geometry {
    Geometry {
        gcx: circle.cx - 0.5 - window.col0 as f64,
        gcy: circle.cy - 0.5 - window.row0 as f64,
        radius: circle.radius,
        support: circle.radius - rim + 1.0,
    }
}

/// Replace each window sample inside the support (R − rim + 1 from the centre) by its
/// local quadratic fit over the normal sphere (module docs); `width` = the kernel's σ
/// in pixels. Samples outside the support are left as they are (the table pads them).
pub(crate) fn fit_in_normal_space(window: &mut Window, circle: &Circle, rim: f64, width: f64) {
    let ws = &window.stack;
    let (w, h, k) = (ws.width, ws.height, ws.k);
    if w == 0 || h == 0 || k == 0 || width.is_nan() || width <= 0.0 || circle.radius <= 0.0 {
        return;
    }
    let geo = geometry(window, circle, rim);
    let src = &ws.data;
    let fitted: Vec<f32> = (0..h)
        .into_par_iter()
        .flat_map_iter(|r| {
            let mut row = src[r * w * k..(r + 1) * w * k].to_vec();
            let mut ell = Vec::new();
            let mut acc = vec![0.0f64; k];
            for c in 0..w {
                kernel(&geo, w, h, r, c, width, &mut ell);
                if ell.is_empty() {
                    continue;
                }
                acc.fill(0.0);
                for &(j, l) in &ell {
                    let s = &src[j * k..(j + 1) * k];
                    acc.iter_mut().zip(s).for_each(|(a, v)| *a += l * *v as f64);
                }
                let dst = &mut row[c * k..(c + 1) * k];
                dst.iter_mut()
                    .zip(&acc)
                    .for_each(|(d, a)| *d = a.max(0.0) as f32);
            }
            row
        })
        .collect();
    window.stack.data = fitted;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::ImageStack;

    const RADIUS: f64 = 50.0;
    const RIM: f64 = 2.0;

    #[test]
    fn auto_fits_from_one_pixel_and_names_parse() {
        let fit = Denoise::NormalSpace { width: None };
        assert_eq!(Denoise::Auto.resolve(FIT_FROM_PX), fit);
        assert_eq!(Denoise::Auto.resolve(0.99), Denoise::ImageBlur);
        assert_eq!(Denoise::ImageBlur.resolve(3.0), Denoise::ImageBlur);
        let fixed = Denoise::NormalSpace { width: Some(2.0) };
        assert_eq!(fixed.resolve(0.5), fixed);
        assert_eq!("normal".parse::<Denoise>().unwrap(), fit);
        assert_eq!("image".parse::<Denoise>().unwrap(), Denoise::ImageBlur);
        assert_eq!("auto".parse::<Denoise>().unwrap(), Denoise::Auto);
        let err = "median".parse::<Denoise>().unwrap_err().to_string();
        assert!(
            err.contains("\"median\"") && err.contains("normal"),
            "{err}"
        );
    }

    /// A sphere of radius 50 px whose one image is f(n), and its circle.
    fn sphere_window(f: impl Fn([f64; 3]) -> f64) -> (Window, Circle) {
        let size = (2.0 * RADIUS) as usize + 4;
        let circle = Circle {
            cx: size as f64 / 2.0,
            cy: size as f64 / 2.0,
            radius: RADIUS,
        };
        let mut stack = ImageStack::zeros(size, size, 1);
        for r in 0..size {
            for c in 0..size {
                let x = (c as f64 + 0.5 - circle.cx) / RADIUS;
                let y = (r as f64 + 0.5 - circle.cy) / RADIUS;
                let z = (1.0 - x * x - y * y).max(0.0).sqrt();
                stack.pixel_flat_mut(r * size + c)[0] = f([x, y, z]) as f32;
            }
        }
        let window = Window {
            col0: 0,
            row0: 0,
            stack,
        };
        (window, circle)
    }

    /// Largest |change| of the samples inside the support.
    fn largest_change(a: &Window, b: &Window, circle: &Circle) -> f64 {
        let geo = geometry(a, circle, RIM);
        let w = a.stack.width;
        let mut worst = 0.0f64;
        for r in 0..a.stack.height {
            for c in 0..w {
                if geo.normal(r, c).is_some() {
                    let d = (a.stack.data[r * w + c] - b.stack.data[r * w + c]).abs();
                    worst = worst.max(d as f64);
                }
            }
        }
        worst
    }

    /// A quadratic in the normal's tangent coordinates is kept (up to the n_z term's
    /// quartic), out to the support's edge; the image blur of the same σ is not.
    #[test]
    fn keeps_smooth_shading_out_to_the_rim() {
        // Lambertian plus ambient, unshadowed (positive everywhere): linear in n
        let shade = |n: [f64; 3]| 0.6 + 0.2 * n[0] - 0.2 * n[1] + 0.3 * n[2];
        let (win, circle) = sphere_window(shade);
        let mut fitted = win.clone();
        fit_in_normal_space(&mut fitted, &circle, RIM, 2.0);
        let fit_err = largest_change(&fitted, &win, &circle);
        let mut blurred = win.clone();
        super::super::window::blur_for_tests(&mut blurred, &circle, RIM, 2.0);
        let blur_err = largest_change(&blurred, &win, &circle);
        println!("largest change: fit {fit_err:.2e}, blur {blur_err:.2e}");
        // measured: fit 1.4e-5, blur 4.1e-2 (at the support's edge)
        assert!(
            fit_err < 1e-3 && blur_err > 20.0 * fit_err,
            "{fit_err} {blur_err}"
        );
        // outside the support nothing changes
        assert_eq!(fitted.stack.data[0], win.stack.data[0]);
    }

    /// Noise at the centre falls by about the equivalent kernel's Σℓ² = 2.5/(4πh²)
    /// (h = 2 px: σ × 0.22 in the continuum limit), and at the support's edge it still
    /// falls.
    #[test]
    fn noise_falls_at_the_centre_and_at_the_edge() {
        let mut g = crate::synth::random::SplitMix64::new(3);
        let (mut noisy, circle) = sphere_window(|_| 0.5);
        noisy
            .stack
            .data
            .iter_mut()
            .for_each(|v| *v += 0.1 * g.normal() as f32);
        let mut fitted = noisy.clone();
        fit_in_normal_space(&mut fitted, &circle, RIM, 2.0);
        let geo = geometry(&noisy, &circle, RIM);
        let w = noisy.stack.width;
        let spread = |s: &Window, lo: f64, hi: f64| {
            let (mut ss, mut n) = (0.0f64, 0usize);
            for r in 0..s.stack.height {
                for c in 0..w {
                    let d = ((c as f64 - geo.gcx).powi(2) + (r as f64 - geo.gcy).powi(2)).sqrt();
                    if d >= lo && d < hi && geo.normal(r, c).is_some() {
                        ss += (s.stack.data[r * w + c] as f64 - 0.5).powi(2);
                        n += 1;
                    }
                }
            }
            (ss / n as f64).sqrt()
        };
        let centre = spread(&fitted, 0.0, 20.0) / spread(&noisy, 0.0, 20.0);
        let edge = spread(&fitted, RADIUS - RIM - 2.0, RADIUS)
            / spread(&noisy, RADIUS - RIM - 2.0, RADIUS);
        println!("noise ratio: centre {centre:.3}, edge {edge:.3}");
        // measured: centre 0.25, edge 0.38 (one-sided fits at the edge)
        assert!(centre < 0.3 && edge < 0.6, "{centre} {edge}");
    }

    /// The cross-validation picks a wide kernel for smooth shading and a narrow one for
    /// a sharp lobe.
    #[test]
    fn cross_validation_follows_the_shading() {
        let mut g = crate::synth::random::SplitMix64::new(5);
        let mut widths = Vec::new();
        for sharp in [false, true] {
            let (mut win, circle) = sphere_window(|n| {
                if sharp {
                    // a highlight of about 3° (2.6 px at the centre)
                    0.1 + 0.8 * (-(n[0].powi(2) + n[1].powi(2)) / (2.0 * 0.05f64.powi(2))).exp()
                } else {
                    0.2 + 0.5 * n[2]
                }
            });
            win.stack
                .data
                .iter_mut()
                .for_each(|v| *v += 0.01 * g.normal() as f32);
            widths.push(choose_width(&win, &circle, RIM, 1.0, &WIDTH_FACTORS).0);
        }
        println!(
            "chosen widths: smooth {:.1} px, sharp {:.1} px",
            widths[0], widths[1]
        );
        // measured: 4.0 and 1.6 px
        assert!(widths[0] >= 3.0 && widths[1] <= 2.0, "{widths:?}");
    }
}
