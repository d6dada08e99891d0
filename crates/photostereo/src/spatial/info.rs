//! The evidence of each pixel about its own normal: the match u = (n_x, n_y) and the
//! information matrix A = Jᵀ W J of the cost ‖t − c·I(u)‖²_W around it, with J = c·∂I/∂u
//! (the table's intensity field differentiated in normal space) or, for Lambertian
//! pixels, J = ρ·∂(L n)/∂u; W = diag(1/σ²(I_k)) from the noise model. A pixel's normal
//! then has covariance C = A⁻¹ in (n_x, n_y); its angular standard error is
//! √tr(M C) with M = I + u uᵀ / n_z² (the metric of the unit sphere in these coordinates).
//!
//! **Censored samples** ([`Censor`], measured once on the whole capture): a sample at its
//! image's floor (the darkest value of the mask: 0, or the black level) says only "at
//! most half a step above the floor", one at its image's clipping level says only "at
//! least this". Where the prediction agrees
//! with that bound (within a step) the sample is left out of A and g: it is a bound
//! that holds, not a measurement of known variance — on an 8-bit metal most samples
//! are such zeros, and counting them as exact made dark pixels look certain.
//!
//! **Past the table's edge** ([`Reflectance`]): the table's entries stop at its last
//! clean ring (θ_c, 78.5° for a sphere of radius 100 px and a 2 px rim). The lookup
//! extends the reflectance beyond it by the table's rim model (`lut`'s rim extension,
//! a linear or microfacet model fitted to the outer rings), and so does the evidence
//! here: I(u) and its slope past θ_c come from that model, not from the table clamped
//! to its edge. Clamped, every normal beyond θ_c predicted the edge's tuple, so a
//! grazing pixel's own data could not tell 79° from 89°, and the prior moved such
//! pixels freely (clean 16-bit GGX metal α 0.15: pixels matched within 0.05° came out
//! 10° off).
//!
//! **The mask's outline** (pixels next to background): a pixel partly over the background
//! holds t = g·T + (1 − g)·f (T the table's tuple, f each light's floor, g the covered
//! share). As the lookup does (`lut/outline.rs`), where the dimmed tuple f + g·(p − f)
//! fits the prediction p clearly better than p itself (squared residual below 1/9 of it,
//! the lookup's ratio of 3 on the RMS), the evidence is taken on t' = f + (t − f)/g,
//! g = ⟨t − f, p − f⟩/⟨p − f, p − f⟩ clamped to [½, 1].
//!
//! **Lack of fit** ([`MISFIT_LIMIT`]): where a pixel's reduced chi-square at the normal,
//! χ²ᵣ = Σ (t − p)²/σ² / (m − 2) over its m used samples, exceeds τ = 9 (an RMS residual
//! of 3σ), no normal of the table explains its tuple — an optical blur mixed it with its
//! neighbours' or the background's light — and its A and g are scaled by τ/χ²ᵣ: its own
//! data count as if their noise were as large as its misfit, and its neighbours decide
//! more of it. Measured 2026-12-06 (found circle, default): blurred 8-bit plastic with a
//! 3% black level 0.116 → 0.083° (own render), 0.178 → 0.158° (Mitsuba); DiLiGenT's ball
//! at 0.75× 0.0736 → 0.0697°; sharp 8-bit Lambertian and plastic 0.042 → 0.046° and
//! 0.063 → 0.067° (their quantised tables' interpolation error exceeds σ there).
//!
//! **Blurred outlines** ([`outline_weight`]): an optical blur mixes an outline pixel
//! with the background and with its neighbours, whose normals turn fast there; the
//! coverage model above covers the first, nothing model-free the second, and such a
//! pixel's tuple can match a wrong normal well. Where the sphere's rim shows a blur above
//! [`SHARP_OUTLINE_PX`] (measured when its table is built, [`Table::rim_blur`]), an
//! outline pixel's A, g and cost rise (the rejection rule) are weighted by
//! (0.35 px / blur)², and its neighbours decide more of it. The rims of sharp captures
//! read 0.06 px (Mitsuba renders), 0.14 px (DiLiGenT's ball) and 0.16 px (psmImages'
//! chrome sphere): unchanged. Measured 2026-12-07 on 8-bit captures with a 0.8 px blur
//! and a 3% black level (rim read about 0.77 px, weight 0.2; circle found, default
//! before → after): Mitsuba plastic 0.158 → 0.146°, its 16 lights 0.174 → 0.157°,
//! Mitsuba aluminium 0.473 → 0.340°; own metal 0.496 → 0.346°, own Lambertian 0.095 →
//! 0.081°, own plastic 0.083 → 0.080° (docs/accuracy.md). Weights 0.3 / 0.2 / 0.15 /
//! 0.1 / 0 on A and g alone were swept: 0 (the outline's evidence dropped) made own
//! blurred Lambertian and plastic worse (0.108°, 0.116°: the ellipsoid's rim bends
//! faster than the prior follows), 0.1 own plastic (0.092°); 0.2 was the best all round.
//! Weighting the cost rise as well keeps the rejection rule from handing the outline
//! back to its matches (own metal 0.346° instead of 0.479°, Mitsuba aluminium 0.340°
//! instead of 0.457°).

use super::levels::Censor;
use super::noise::NoiseModel;
use crate::image::{GrayImage, ImageStack, Lights, Mask, NormalMap};
use crate::lut::fit::rim::{Rim, RimBuf, DARK};
use crate::lut::{self, outline, Table};
use rayon::prelude::*;

/// Angular standard errors are capped at this (degrees): no information.
pub const MAX_SIGMA_DEG: f32 = 90.0;
/// n_z² is floored at this in the angular metric (grazing normals).
const MIN_NZ2: f32 = 0.01;
/// Reduced chi-square above which a pixel's evidence is scaled down (module docs, "Lack
/// of fit"): an RMS residual of 3 noise standard deviations.
pub const MISFIT_LIMIT: f64 = 9.0;

/// The per-pixel evidence (dense arrays over the image, zero outside the mask).
#[derive(Clone, Debug)]
pub struct Evidence {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// (n_x, n_y) of the per-pixel match.
    pub u: Vec<[f32; 2]>,
    /// Information matrix (A₁₁, A₁₂, A₂₂) in (n_x, n_y), 1/(unit normal component)².
    pub a: Vec<[f32; 3]>,
    /// Gradient g = JᵀW r of the cost's linearisation at `u` (r = t − c·I(u)): the
    /// pixel's cost is (u' − u)ᵀ A (u' − u) − 2 gᵀ(u' − u) + const near `u`; empty when
    /// `u` is the pixel's own best match (g = 0 there).
    pub g: Vec<[f32; 2]>,
}

impl Evidence {
    /// Angular standard error (degrees) of each pixel's own match, capped at
    /// [`MAX_SIGMA_DEG`]; 0 outside the mask.
    pub fn sigma_deg(&self, mask: &Mask) -> GrayImage {
        GrayImage::from_fn(self.width, self.height, |r, c| {
            let i = r * self.width + c;
            if *mask.get(r, c) {
                angular_sigma_deg(self.u[i], self.a[i])
            } else {
                0.0
            }
        })
    }
}

/// √tr(M A⁻¹) in degrees (see the module docs).
pub fn angular_sigma_deg(u: [f32; 2], a: [f32; 3]) -> f32 {
    let det = a[0] as f64 * a[2] as f64 - (a[1] as f64).powi(2);
    let tr = (a[0] + a[2]) as f64;
    if det.is_nan() || det <= 1e-12 * tr * tr || det <= 0.0 {
        return MAX_SIGMA_DEG;
    }
    let (c11, c12, c22) = (a[2] as f64 / det, -a[1] as f64 / det, a[0] as f64 / det);
    let nz2 = (1.0 - (u[0] * u[0] + u[1] * u[1]) as f64).max(MIN_NZ2 as f64);
    let (x, y) = (u[0] as f64, u[1] as f64);
    let tr_mc = c11 + c22 + (x * x * c11 + 2.0 * x * y * c12 + y * y * c22) / nz2;
    (tr_mc.max(0.0).sqrt().to_degrees() as f32).min(MAX_SIGMA_DEG)
}

/// Accumulate w·J Jᵀ of one light into `a`.
#[inline]
fn add(a: &mut [f64; 3], j: [f64; 2], w: f64) {
    a[0] += w * j[0] * j[0];
    a[1] += w * j[0] * j[1];
    a[2] += w * j[1] * j[1];
}

/// The sphere's reflectance as the evidence reads it (module docs): the table inside its
/// last clean ring and, past it, the table's rim model.
pub struct Reflectance<'a> {
    /// The lookup table.
    pub table: &'a Table,
    /// The rim model (`None`: the table clamped to its edge, as before it existed).
    rim: Option<Rim>,
    /// Each light's floor (`Table::floors`): the cast-shadow test measures "dark" above
    /// it, as the lookup does.
    floors: Vec<f32>,
    /// The camera's black level ([`Table::black_level`]): a brightness c scales the light
    /// above it, p = b + c·(I − b), as the lookup matches it.
    black: f32,
    /// Weight of the evidence of the mask's outline pixels (module docs, "Blurred
    /// outlines"): [`outline_weight`] of the table's measured blur.
    outline_weight: f32,
}

/// Blur of the calibration images (pixels, [`Table::rim_blur`]) up to which the mask's
/// outline pixels keep their full evidence (module docs, "Blurred outlines").
pub const SHARP_OUTLINE_PX: f64 = 0.35;

/// The weight of an outline pixel's evidence under a measured blur of `blur` pixels:
/// 1 up to [`SHARP_OUTLINE_PX`], then (`SHARP_OUTLINE_PX` / blur)²; 1 when the blur is
/// not known.
pub fn outline_weight(blur: Option<f64>) -> f32 {
    match blur {
        Some(b) if b > SHARP_OUTLINE_PX => (SHARP_OUTLINE_PX / b).powi(2) as f32,
        _ => 1.0,
    }
}

/// The blur measured on `table`'s sphere and the weight it gives the mask's outline
/// ([`outline_weight`]), where that weight is below 1; `None` for a sharp (or unmeasured)
/// rim.
pub fn blurred_outline(table: &Table) -> Option<(f64, f32)> {
    let weight = outline_weight(table.rim_blur);
    table.rim_blur.filter(|_| weight < 1.0).map(|b| (b, weight))
}

impl<'a> Reflectance<'a> {
    /// The table with its rim model (fitted as the lookup fits it: the same model the
    /// lookup extrapolated with) where the capture's noise floor σ(0) is below the
    /// model's own floor, 0.1% of the table's peak (`lut`'s `DARK`: samples under it
    /// were left out of the model's fit as unlit); else the table clamped to its edge.
    ///
    /// Why the gate: a rough metal's rim model rises towards grazing view, so a pixel
    /// matched there gets a confident quadratic. Where its match is right (clean 16-bit
    /// metal α 0.15: 0.064 → 0.047°, the grazing bands held instead of moved) that is the
    /// point; where noise decides the match (1% noise on metal α 0.2: dark pixels at
    /// 45–70° matched to the rim) it holds wrong normals against their neighbours
    /// (1.42 → 2.04°), and with an 8-bit capture (quantisation floor above DARK) the
    /// rim model fitted to a few grey levels pushed the outline inwards (α 0.15 0.754 →
    /// 0.799°).
    pub fn new(table: &'a Table, noise: &NoiseModel) -> Self {
        let clean = noise.sigma(0.0) < DARK * table.peak();
        Reflectance {
            table,
            rim: if clean { Rim::fit(table) } else { None },
            floors: table.floors(),
            black: table.black_level(),
            outline_weight: outline_weight(table.rim_blur),
        }
    }
}

/// Evidence of a lookup: `normals` from [`crate::lut::solve`] with `table`, `albedo` its
/// albedo ratio (normalised matching) or `None` (c = 1). Lights the lookup would treat as
/// cast-shadowed (t_k within `shadow_level` · c · peak of its floor, the black level, while
/// the match is lit) are left out.
pub fn from_table(
    stack: &ImageStack,
    mask: &Mask,
    table: &Reflectance,
    normals: &NormalMap,
    albedo: Option<&GrayImage>,
    (noise, censor): (&NoiseModel, &Censor),
    shadow_level: f32,
) -> Evidence {
    let sel = |r: usize, c: usize| *mask.get(r, c);
    let model = (noise, censor, shadow_level);
    let mut ev = linearise_where(stack, mask, table, normals, albedo, model, sel);
    ev.g = Vec::new();
    ev
}

/// The cost of each pixel with `only[i]` linearised at `normals` (any field, e.g. a
/// spatial solution): A and the gradient g at that normal ([`Evidence::g`]); zeros at
/// the other pixels.
#[allow(clippy::too_many_arguments)]
pub fn linearise(
    stack: &ImageStack,
    mask: &Mask,
    table: &Reflectance,
    normals: &NormalMap,
    albedo: Option<&GrayImage>,
    (noise, censor): (&NoiseModel, &Censor),
    shadow_level: f32,
    only: &[bool],
) -> Evidence {
    let w = mask.width;
    let sel = |r: usize, c: usize| *mask.get(r, c) && only[r * w + c];
    let model = (noise, censor, shadow_level);
    linearise_where(stack, mask, table, normals, albedo, model, sel)
}

fn linearise_where(
    stack: &ImageStack,
    mask: &Mask,
    table: &Reflectance,
    normals: &NormalMap,
    albedo: Option<&GrayImage>,
    (noise, censor, shadow_level): (&NoiseModel, &Censor, f32),
    select: impl Fn(usize, usize) -> bool + Sync,
) -> Evidence {
    let (w, h, k) = (stack.width, stack.height, stack.k);
    let px = TablePixel::new(table, noise, censor, shadow_level, albedo.is_some());
    let mut u = vec![[0.0f32; 2]; w * h];
    let mut a = vec![[0.0f32; 3]; w * h];
    let mut g = vec![[0.0f32; 2]; w * h];
    u.par_chunks_mut(w)
        .zip(a.par_chunks_mut(w))
        .zip(g.par_chunks_mut(w))
        .enumerate()
        .for_each(|(r, ((urow, arow), grow))| {
            let mut buf = vec![0.0f32; 6 * k];
            let mut rb = RimBuf::new(k);
            for c in 0..w {
                if !select(r, c) {
                    continue;
                }
                let n = *normals.get(r, c);
                let scale = albedo.map_or(1.0, |img| *img.get(r, c));
                urow[c] = [n[0], n[1]];
                let t = stack.pixel(r, c);
                let edge = outline::on_outline_at(mask, r * w + c);
                (arow[c], grow[c]) = px.information(t, n, scale, (&mut buf, &mut rb), edge);
            }
        });
    Evidence {
        width: w,
        height: h,
        u,
        a,
        g,
    }
}

/// What the linearisation of a table pixel needs.
struct TablePixel<'a> {
    table: &'a Table,
    /// The rim model and the n_z of the table's last clean ring, below which it is used.
    rim: Option<(&'a Rim, f32)>,
    /// Each light's floor (black level).
    floors: &'a [f32],
    /// The black level under a fitted brightness ([`Reflectance`]'s; 0 without
    /// normalised matching, where the brightness is 1 and the offset cancels).
    black: f32,
    noise: &'a NoiseModel,
    censor: &'a Censor,
    shadow_level: f32,
    peak: f32,
    floor: f32,
    radius: f32,
    normalized: bool,
    /// [`Reflectance`]'s weight of an outline pixel's evidence.
    outline_weight: f32,
}

/// Each sample's term of [`TablePixel::cost`] is capped at this (a 4σ residual): a
/// sample no normal explains (a cast shadow, an interreflection) costs the same at any
/// normal instead of deciding the comparison.
const MAX_SAMPLE_COST: f64 = 16.0;

/// For each `select`ed pixel, by how much its own data reject the normal of `other`
/// against its `own` normal: C(other) − C(own) in units of the noise variance (twice a
/// log-likelihood ratio), with C(n) = Σ_k min(r_k²/σ², `MAX_SAMPLE_COST`) and censored
/// samples as one-sided bounds; 0 elsewhere.
///
/// Not made here: a correction for the optimism of the match (searched over the whole
/// table, it fits part of the noise). Gating the rise by the χ² of the uncensored
/// samples (reject only where `other` also fits worse than m + 3√(2m)) kept the 1%-noise
/// rough metal at 1.93° (1.90° without the rule) but let 8-bit metal through at 1.21°
/// against the lookup's 1.16°: with quantisation as the only noise, the table's own
/// interpolation error is larger than σ and the χ² no longer measures the fit.
#[allow(clippy::too_many_arguments)]
pub fn cost_increase(
    stack: &ImageStack,
    mask: &Mask,
    table: &Reflectance,
    (own, other): (&NormalMap, &NormalMap),
    albedo: Option<&GrayImage>,
    (noise, censor): (&NoiseModel, &Censor),
    shadow_level: f32,
    select: &[bool],
) -> Vec<f32> {
    let px = TablePixel::new(table, noise, censor, shadow_level, albedo.is_some());
    let w = stack.width;
    let mut out = vec![0f32; stack.pixels()];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(r, row)| {
            let mut buf = vec![0f32; stack.k];
            let mut rb = RimBuf::new(stack.k);
            for (c, v) in row.iter_mut().enumerate() {
                let i = r * w + c;
                if !(mask.data[i] && select[i]) {
                    continue;
                }
                let (t, scale) = (stack.pixel(r, c), albedo.map_or(1.0, |a| *a.get(r, c)));
                let a = px.cost(t, *other.get(r, c), scale, (&mut buf, &mut rb));
                let b = px.cost(t, *own.get(r, c), scale, (&mut buf, &mut rb));
                // an outline pixel's data count with the weight of its evidence
                let weight = if outline::on_outline_at(mask, i) {
                    px.outline_weight
                } else {
                    1.0
                };
                *v = weight * (a - b) as f32;
            }
        });
    out
}

/// A pixel's work buffers: intensities and the rim model's workspace.
type Bufs<'b> = (&'b mut [f32], &'b mut RimBuf);

/// The unit normal whose (n_x, n_y) is `(x, y)` (scaled onto the horizon when past it).
fn unit_from_u(x: f32, y: f32) -> [f32; 3] {
    let r2 = x * x + y * y;
    if r2 >= 1.0 {
        let r = r2.sqrt();
        [x / r, y / r, 0.0]
    } else {
        [x, y, (1.0 - r2).sqrt()]
    }
}

impl<'a> TablePixel<'a> {
    /// The sphere's tuple at unit normal `n` into `v`: the rim model past the table's
    /// last clean ring, else the table (clamped to its search disc).
    fn predict(&self, n: [f32; 3], v: &mut [f32], rb: &mut RimBuf) {
        match self.rim {
            Some((rim, nz_clean)) if n[2] < nz_clean => {
                v.copy_from_slice(rim.tuple(n, rb));
            }
            _ => {
                let (gx, gy) = self.table.normal_to_grid(n);
                let (gx, gy) = self.table.clamp_grid(gx, gy);
                self.table.sample(gx, gy, v, None);
            }
        }
    }

    /// The pixel's cost Σ_k min(r_k²/σ²(pred_k), `MAX_SAMPLE_COST`) at normal `n` with
    /// brightness `scale`, r_k = t_k − pred_k except for censored samples, whose
    /// residual is only the prediction's excess over their bound.
    fn cost(&self, t: &[f32], n: [f32; 3], scale: f32, (v, rb): Bufs) -> f64 {
        self.predict(n, v, rb);
        let c = &self.censor;
        let mut sum = 0.0f64;
        for (l, (&ti, &vi)) in t.iter().zip(v.iter()).enumerate() {
            let pred = self.scaled(scale, vi);
            let ti = if ti.is_finite() { ti } else { 0.0 };
            let r = if ti <= c.low[l] {
                (pred - c.low[l]).max(0.0)
            } else if ti >= c.high[l] {
                (c.high[l] - pred).max(0.0)
            } else {
                ti - pred
            };
            let var = self.noise.variance(pred).max(self.floor) as f64;
            sum += ((r as f64).powi(2) / var).min(MAX_SAMPLE_COST);
        }
        sum
    }

    /// The prediction of table sample `v` under brightness `scale`: b + scale·(v − b),
    /// exactly scale·v when the black level b is 0.
    #[inline]
    fn scaled(&self, scale: f32, v: f32) -> f32 {
        self.black + scale * (v - self.black)
    }

    fn new(
        refl: &'a Reflectance,
        noise: &'a NoiseModel,
        censor: &'a Censor,
        shadow_level: f32,
        normalized: bool,
    ) -> Self {
        let table = refl.table;
        let peak = table.peak();
        let rim = refl.rim.as_ref().map(|r| (r, r.theta_clean.cos() as f32));
        TablePixel {
            table,
            rim,
            floors: &refl.floors,
            black: if normalized { refl.black } else { 0.0 },
            noise,
            censor,
            shadow_level,
            peak,
            floor: (1e-5 * peak.max(1e-12)).powi(2),
            radius: table.circle.radius as f32,
            normalized,
            outline_weight: refl.outline_weight,
        }
    }

    /// Information JᵀWJ (A₁₁, A₁₂, A₂₂) of the pixel's cost at normal `n` with
    /// brightness `scale`, and the gradient JᵀW r; `on_outline`: the pixel is on the
    /// mask's outline (module docs). `buf` holds 6 K values.
    fn information(
        &self,
        t: &[f32],
        n: [f32; 3],
        scale: f32,
        (buf, rb): Bufs,
        on_outline: bool,
    ) -> ([f32; 3], [f32; 2]) {
        let k = t.len();
        let (v, rest) = buf.split_at_mut(k);
        let (tc, rest) = rest.split_at_mut(k);
        let (xp, rest) = rest.split_at_mut(k);
        let (xm, rest) = rest.split_at_mut(k);
        let (yp, ym) = rest.split_at_mut(k);
        self.sample_around(n, [&mut *v, xp, xm, yp, ym], rb);
        let t: &[f32] = if on_outline && self.uncovered(t, v, scale, tc) {
            tc
        } else {
            t
        };
        // ∂I/∂n_x = R ∂I/∂gx, ∂I/∂n_y = −R ∂I/∂gy
        let d = 1.0 / (2.0 / self.radius);
        let level = self.shadow_level * scale * self.peak;
        let mut acc = [0.0f64; 3];
        let mut grad = [0.0f64; 2];
        let (mut iwi, mut iwj) = (0.0f64, [0.0f64; 2]);
        let (mut chi2, mut used) = (0.0f64, 0usize);
        for i in 0..k {
            let pred = self.scaled(scale, v[i]);
            let ti = if t[i].is_finite() { t[i] } else { 0.0 };
            if lut::cast_shadowed(ti, self.floors[i], pred, level) {
                continue; // cast shadow, as the lookup would treat it
            }
            if self.censor.holds(i, ti, pred) {
                continue; // a bound that holds, not a measurement
            }
            let wgt = 1.0 / self.noise.variance(pred).max(self.floor) as f64;
            let j = [
                (scale * d * (xp[i] - xm[i])) as f64,
                (-scale * d * (yp[i] - ym[i])) as f64,
            ];
            add(&mut acc, j, wgt);
            let res = wgt * (ti - pred) as f64;
            grad[0] += res * j[0];
            grad[1] += res * j[1];
            chi2 += res * (ti - pred) as f64;
            used += 1;
            if self.normalized {
                let vi = (v[i] - self.black) as f64;
                iwi += wgt * vi * vi;
                iwj[0] += wgt * vi * j[0];
                iwj[1] += wgt * vi * j[1];
            }
        }
        if self.normalized && iwi > 0.0 {
            // the brightness c is a nuisance: project its direction out (variable projection)
            acc[0] -= iwj[0] * iwj[0] / iwi;
            acc[1] -= iwj[0] * iwj[1] / iwi;
            acc[2] -= iwj[1] * iwj[1] / iwi;
        }
        let mut f = misfit_weight(chi2, used);
        if on_outline {
            f *= self.outline_weight as f64;
        }
        (
            acc.map(|x| (f * x) as f32),
            [(f * grad[0]) as f32, (f * grad[1]) as f32],
        )
    }

    /// The table's tuple at `n` and at ±1 grid pixel in x and y (h = 1/R in normal
    /// units; central differences are smoother than the bilinear cell's slope), into
    /// `[v, xp, xm, yp, ym]`; past the table's last clean ring, the rim model's.
    fn sample_around(&self, n: [f32; 3], [v, xp, xm, yp, ym]: [&mut [f32]; 5], rb: &mut RimBuf) {
        let h = 1.0 / self.radius;
        match self.rim {
            Some((rim, nz_clean)) if n[2] < nz_clean => {
                let mut at = |dx: f32, dy: f32, out: &mut [f32]| {
                    out.copy_from_slice(rim.tuple(unit_from_u(n[0] + dx, n[1] + dy), rb));
                };
                at(0.0, 0.0, v);
                at(h, 0.0, xp);
                at(-h, 0.0, xm);
                at(0.0, -h, yp);
                at(0.0, h, ym);
            }
            _ => {
                // the grid's rows run down, so +1 row is n_y − h
                let (gx, gy) = self.table.normal_to_grid(n);
                let (gx, gy) = self.table.clamp_grid(gx, gy);
                self.table.sample(gx, gy, v, None);
                self.table.sample(gx + 1.0, gy, xp, None);
                self.table.sample(gx - 1.0, gy, xm, None);
                self.table.sample(gx, gy + 1.0, yp, None);
                self.table.sample(gx, gy - 1.0, ym, None);
            }
        }
    }

    /// Whether the outline pixel's tuple `t` is partly background (module docs): the
    /// dimmed prediction f + g·(p − f), p the prediction at brightness `scale`, fits
    /// clearly better than p. If so, `out` holds the tuple corrected for the coverage,
    /// f + (t − f)/g.
    fn uncovered(&self, t: &[f32], v: &[f32], scale: f32, out: &mut [f32]) -> bool {
        let finite = |x: f32| if x.is_finite() { x } else { 0.0 };
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for ((&ti, &vi), &f) in t.iter().zip(v).zip(self.floors) {
            let p = (self.scaled(scale, vi) - f) as f64;
            num += (finite(ti) - f) as f64 * p;
            den += p * p;
        }
        let g = num / den;
        if !g.is_finite() || g >= 1.0 {
            return false;
        }
        let g = g.max(outline::MIN_COVERAGE as f64);
        let (mut plain, mut dimmed) = (0.0f64, 0.0f64);
        for ((&ti, &vi), &f) in t.iter().zip(v).zip(self.floors) {
            let (ti, p) = (finite(ti) as f64, self.scaled(scale, vi) as f64);
            plain += (ti - p).powi(2);
            dimmed += (ti - f as f64 - g * (p - f as f64)).powi(2);
        }
        // the lookup's test (`lut::outline::RESIDUAL_RATIO` on the RMS residual), squared
        let ratio = outline::RESIDUAL_RATIO as f64;
        if ratio * ratio * dimmed >= plain {
            return false;
        }
        for ((o, &ti), &f) in out.iter_mut().zip(t).zip(self.floors) {
            *o = f + (finite(ti) - f) / g as f32;
        }
        true
    }
}

/// The factor on a pixel's evidence for its lack of fit: τ/χ²ᵣ where the reduced
/// chi-square χ²ᵣ = `chi2`/(`used` − 2) exceeds τ = [`MISFIT_LIMIT`], else 1.
fn misfit_weight(chi2: f64, used: usize) -> f64 {
    if used <= 2 {
        return 1.0;
    }
    let reduced = chi2 / (used - 2) as f64;
    if reduced > MISFIT_LIMIT {
        MISFIT_LIMIT / reduced
    } else {
        1.0
    }
}

/// Evidence of a Lambertian solve: I_k = ρ·(l_k · n) on the lights with l_k · n > 0,
/// J_k = ρ·(l_xy − l_z·u/n_z).
pub fn from_lambertian(
    stack: &ImageStack,
    mask: &Mask,
    lights: &Lights,
    normals: &NormalMap,
    albedo: &GrayImage,
    noise: &NoiseModel,
) -> Evidence {
    let (w, h) = (stack.width, stack.height);
    let mut u = vec![[0.0f32; 2]; w * h];
    let mut a = vec![[0.0f32; 3]; w * h];
    let floor = 1e-12f32;
    u.par_chunks_mut(w)
        .zip(a.par_chunks_mut(w))
        .enumerate()
        .for_each(|(r, (urow, arow))| {
            for c in 0..w {
                if !*mask.get(r, c) {
                    continue;
                }
                let n = *normals.get(r, c);
                let rho = *albedo.get(r, c) as f64;
                urow[c] = [n[0], n[1]];
                let nz = (n[2] as f64).max(0.1);
                let mut acc = [0.0f64; 3];
                for (l, li) in lights.directions.iter().zip(&lights.intensities) {
                    let s = (l[0] * n[0] + l[1] * n[1] + l[2] * n[2]) as f64;
                    if s <= 0.0 {
                        continue;
                    }
                    let gain = rho * *li as f64;
                    let pred = (gain * s) as f32;
                    let wgt = 1.0 / noise.variance(pred).max(floor) as f64;
                    let j = [
                        gain * (l[0] as f64 - l[2] as f64 * n[0] as f64 / nz),
                        gain * (l[1] as f64 - l[2] as f64 * n[1] as f64 / nz),
                    ];
                    add(&mut acc, j, wgt);
                }
                arow[c] = [acc[0] as f32, acc[1] as f32, acc[2] as f32];
            }
        });
    Evidence {
        width: w,
        height: h,
        u,
        a,
        g: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outline_weight_is_one_up_to_a_sharp_rim_then_falls_as_the_squared_blur() {
        assert_eq!(outline_weight(None), 1.0);
        assert_eq!(outline_weight(Some(0.0)), 1.0);
        assert_eq!(outline_weight(Some(SHARP_OUTLINE_PX)), 1.0);
        assert!((outline_weight(Some(0.7)) - 0.25).abs() < 1e-6);
        assert!((outline_weight(Some(1.4)) - 0.0625).abs() < 1e-6);
        assert_eq!(outline_weight(Some(f64::NAN)), 1.0);
    }

    #[test]
    fn a_blurred_outline_is_reported_only_below_full_weight() {
        let circle = crate::sphere::Circle {
            cx: 32.0,
            cy: 32.0,
            radius: 28.0,
        };
        let mut table =
            crate::lut::table::test_sphere_table(64, circle, 3, |n, i| n[i].max(0.0) + 0.1);
        for (blur, expected) in [(None, None), (Some(0.2), None), (Some(0.7), Some(0.25))] {
            table.rim_blur = blur;
            let got = blurred_outline(&table).map(|(b, w)| (b, (w * 100.0).round() / 100.0));
            assert_eq!(got, expected.map(|w| (blur.unwrap(), w)), "blur {blur:?}");
        }
    }
}
