//! The table past its last clean ring: normals from the table's edge to 90°.
//!
//! The table's entries stop `rim` pixels inside the occluding circle (θ_c =
//! asin((R − rim)/R), 78.5° for R = 100 and a 2 px rim): the pixels of that band are
//! left out explicitly, because they mix the sphere with the background and their
//! footprint spans normals up to 90°. A target normal beyond θ_c would be clamped to the
//! table's edge. Instead, each light's reflectance is extended past θ_c by a smooth
//! model over the normal sphere fitted to the outer rings of clean entries:
//!
//! I_k(n) = max(0, β_k(φ) · n) · m(n_z),  m(u) = 1 / (u + √(a² + (1 − a²) u²)),
//!
//! a local linear function of the unit normal n (exact for a Lambertian surface, lit or
//! not, and a first-order model of any smooth reflectance) times, optionally, Smith's
//! masking of the view over n·v, G₁(v)/(n·v) of a microfacet surface of width a: the
//! rise of a rough metal's radiance towards grazing view, which no linear model
//! follows (GGX α 0.2: ×2.4 from 78.5° to 90° at fixed microfacet term). The
//! coefficients β_k are fitted by least squares, per sector of azimuth φ, to the entries
//! with polar angle θ in [θ_c − w, θ_c] and lit by light k (above 0.1% of the table's
//! brightest sample); a light dark in the whole sector stays dark beyond it (n·l only
//! decreases towards the rim where the light is behind the meridian). β_k is
//! interpolated linearly in φ between sector centres (sectors of about 8 px of arc,
//! each fitted on twice its width).
//!
//! The ring's width w (12, 8, 6 or 4°) and the masking width a (none, 0.1 … 0.5) are
//! chosen per table: each pair is fitted on [θ_c − 3° − w, θ_c − 3°] and scored by how
//! well it predicts the table's outermost 3° (all lights, squared error); the widest
//! ring is taken unless a narrower one halves that error, and the pair chosen is refitted
//! on [θ_c − w, θ_c]. The GGX metal of `synth` (α 0.2, R = 100) gets w = 4°, a = 0.1: a
//! narrow ring, because the model is local; the Mitsuba Lambertian sphere at R = 50
//! (area-averaged pixels) keeps 12° (4° would take its lookup from 0.072° to 0.084°).
//!
//! A second candidate, where the linear model's held-out error is above 0.3% of the
//! band's (relative RMS): the parametric microfacet lobe per light of `lobe.rs`
//! (directions and width from the whole table, coefficients from the 12° ring), kept
//! when it predicts the held-out band better. It is global, so it extrapolates where the
//! local model cannot: a small sphere's θ_c is 73.7° at R = 50, 16° short of 90°, and
//! the linear model matched `synth`'s metal there 23° off in the 85–90° band (1.1° with
//! the lobe). `synth`'s Lambertian and plastic spheres (0.01%) never try it.
//!
//! A target pixel whose table fit ends beyond θ_c − 24° ([`Rim::tried_below`]) is
//! refitted on this model over (θ, φ), θ ∈ [θ_c − 12°, 90°]: a scan of 13 values of θ at
//! the table fit's azimuth, then Gauss–Newton (analytic Jacobian; a step shorter than
//! 1e-5 rad ends it, untaken) from the best, with the same lights and scale as the
//! table fit; the rim fit replaces the table fit only when its residual is lower. (Only
//! fits that end within 1 px of the table's edge were refitted before: a rough metal's
//! grazing normals, dim, matched dim entries near 60° instead.) Inside the edge, a fit
//! whose relative residual is already within the lookup's coherence floor (0.3%) is
//! not refitted: that keeps the lookup's speed on plastics.

use super::generic::Fit;
use super::lobe::Lobe;
use super::ring::{fit_beta, masking, masking_dlog};
use crate::cpu::Avx;
use crate::lut::table::Table;

/// Polar-angle width (radians) of the band below the clean ring where the scan starts.
const RING: f64 = 12.0 * std::f64::consts::PI / 180.0;
/// Table fits this far (radians) inside the clean ring or beyond are refitted on the
/// model ([`Rim::tried_below`]).
const TRIED: f64 = 2.0 * RING;
/// Candidate widths (radians) of the ring of entries the model is fitted to.
const RINGS: &[f64] = &[0.2094, 0.1396, 0.1047, 0.0698];
/// A narrower ring is chosen only when its held-out error is below this fraction of the
/// wider one's.
const NARROWER: f64 = 0.5;
/// Candidate masking widths a (0: no masking factor).
const WIDTHS: &[f64] = &[0.0, 0.1, 0.15, 0.2, 0.3, 0.5];
/// Relative RMS held-out error of the linear model below which the lobe is not tried
/// (the lookup's coherence floor; `synth`'s GGX metal: 3%).
const LOBE_FROM: f64 = 0.003;
/// Polar-angle width (radians) of the table's outermost band held out to choose them.
const HOLD: f64 = 0.0524;
/// Arc length (pixels) of one azimuth sector.
const SECTOR_PX: f64 = 8.0;
/// Samples below this fraction of the table's peak count as unlit (a rough metal's
/// rim holds about 0.5% of the peak: 1% left most of its lights out of the fit).
pub(crate) const DARK: f32 = 0.001;
/// Gauss–Newton iterations of a rim fit.
const ITERATIONS: usize = 8;
/// Steps of the scan of θ that starts a rim fit.
const SCAN: usize = 12;
/// Gauss–Newton stops when its step (θ, φ, radians) is shorter than this.
const STOP: f64 = 1e-5;
/// Width of the per-light loops (the tuples are padded with zeros to a multiple of it).
const LANES: usize = 8;

/// The fitted extension of one table (see the module docs).
pub(crate) struct Rim {
    k: usize,
    /// K padded to a multiple of [`LANES`].
    kp: usize,
    sectors: usize,
    /// β of each sector by component and light, `beta[(s * 3 + j) * kp + light]` (one
    /// contiguous run per component, zeros beyond K, so that the per-light loops
    /// vectorise).
    beta: Vec<f32>,
    /// Polar angle of the table's last clean ring (radians).
    pub theta_clean: f64,
    /// The scan's values of θ with their sine and cosine (the same for every pixel).
    scan: Vec<(f64, f64, f64)>,
    /// The processor has AVX: the fit runs on 8-lane vectors (same arithmetic).
    avx: Option<Avx>,
    /// Width a of the masking factor m(n_z) (None: m = 1).
    mask_a: Option<f64>,
    /// The parametric lobe, where it predicts the held-out band better than β.
    lobe: Option<Lobe>,
}

/// Workspace of one rim fit (every vector padded with zeros to `kp` values).
pub(crate) struct RimBuf {
    /// The target and its weights.
    t: Vec<f32>,
    w: Vec<f32>,
    /// The model's tuple at the current point, and its derivatives in θ and φ.
    p: Vec<f32>,
    px: Vec<f32>,
    py: Vec<f32>,
    /// β interpolated at the current azimuth and its derivative in φ, by component
    /// (`[j * kp + light]`).
    beta: Vec<f32>,
    dbeta: Vec<f32>,
    /// sin θ, cos θ, sin φ, cos φ at the current point.
    trig: [f64; 4],
    /// β_x cos φ + β_y sin φ at the scan's azimuth.
    a: Vec<f32>,
}

impl RimBuf {
    pub fn new(k: usize) -> Self {
        let kp = padded(k);
        RimBuf {
            t: vec![0.0; kp],
            w: vec![0.0; kp],
            p: vec![0.0; kp],
            px: vec![0.0; kp],
            py: vec![0.0; kp],
            beta: vec![0.0; 3 * kp],
            dbeta: vec![0.0; 3 * kp],
            trig: [0.0; 4],
            a: vec![0.0; kp],
        }
    }
}

/// K rounded up to a multiple of [`LANES`].
fn padded(k: usize) -> usize {
    k.div_ceil(LANES) * LANES
}

/// Sum of the lanes of a partial sum (pairwise).
fn lanes_sum(a: [f32; LANES]) -> f32 {
    ((a[0] + a[4]) + (a[2] + a[6])) + ((a[1] + a[5]) + (a[3] + a[7]))
}

/// Unit normal at polar angle θ and azimuth φ (x right, y up, z to the camera).
fn normal(theta: f64, phi: f64) -> [f64; 3] {
    let s = theta.sin();
    [s * phi.cos(), s * phi.sin(), theta.cos()]
}

impl Rim {
    /// Fit the model to the outer rings of `table`'s entries; `None` when the table is too
    /// small to hold a ring. The ring's width and the masking width are chosen among
    /// [`RINGS`] × [`WIDTHS`] by how well a fit on the ring moved [`HOLD`] inwards
    /// predicts the table's outermost [`HOLD`] (module docs).
    pub fn fit(table: &Table) -> Option<Rim> {
        let r = table.circle.radius;
        let rs = table.search_radius();
        let theta_clean = (rs / r).clamp(0.0, 1.0).asin();
        let widest = RINGS.iter().copied().fold(RING, f64::max);
        if theta_clean - widest - HOLD <= 0.0 {
            return None;
        }
        let sectors = ((std::f64::consts::TAU * rs / SECTOR_PX).round() as usize).clamp(12, 360);
        let mut rim = Rim {
            k: table.k,
            kp: padded(table.k),
            sectors,
            beta: Vec::new(),
            theta_clean,
            scan: scan_thetas(theta_clean - RING),
            avx: Avx::detect(),
            mask_a: None,
            lobe: None,
        };
        let dark = DARK * table.peak();
        let mut best = (f64::INFINITY, RINGS[0], None);
        // widest ring first: a narrower one must predict clearly better (it follows the
        // reflectance's curvature, but its slope is noisier)
        for &ring in RINGS {
            let needed = if ring < best.1 { NARROWER } else { 1.0 };
            let mut this = (f64::INFINITY, ring, None);
            for &a in WIDTHS {
                let a = (a > 0.0).then_some(a);
                let hi = theta_clean - HOLD;
                rim.mask_a = a;
                rim.beta = fit_beta(table, sectors, rim.kp, (hi - ring, hi), a, dark);
                let err = rim.held_out_error(table, hi);
                if err < this.0 {
                    this = (err, ring, a);
                }
            }
            if this.0 < needed * best.0 {
                best = this;
            }
        }
        let (err, ring, a) = best;
        rim.lobe = Self::lobe(table, theta_clean, err);
        rim.mask_a = a;
        rim.beta = fit_beta(
            table,
            sectors,
            rim.kp,
            (theta_clean - ring, theta_clean),
            a,
            dark,
        );
        Some(rim)
    }

    /// The parametric lobe fitted on the widest ring, when its held-out error is below
    /// the linear model's `linear`; not tried where that is already within
    /// [`LOBE_FROM`] (Lambertian and plastic spheres: 0.01% relative), which keeps their
    /// choice and the lobe's fit (40–250 ms) off their tables.
    fn lobe(table: &Table, theta_clean: f64, linear: f64) -> Option<Lobe> {
        let hi = theta_clean - HOLD;
        let e = &table.entries;
        let energy: f64 = e
            .normals
            .iter()
            .enumerate()
            .filter(|(_, n)| f64::from(n[2]).clamp(-1.0, 1.0).acos() >= hi)
            .flat_map(|(i, _)| &e.tuples[i * table.k..(i + 1) * table.k])
            .map(|&v| f64::from(v).powi(2))
            .sum();
        if linear <= LOBE_FROM * LOBE_FROM * energy {
            return None;
        }
        let (l, alpha) = Lobe::geometry(table)?;
        let (err, alpha) = Lobe::choose(table, &l, alpha, hi - RING, hi);
        (err < linear).then(|| Lobe::on_band(table, &l, alpha, (theta_clean - RING, theta_clean)))
    }

    /// n_z below which a table fit is refitted on the model: θ ≥ θ_c − 2 × 12°. A
    /// grazing normal of a rough metal is dim, and its table fit often lands on a dim
    /// region of the table 20° inside the rim (GGX α 0.2: θ 57–62° for normals at
    /// 85–90°), not at the table's edge.
    pub fn tried_below(&self) -> f64 {
        (self.theta_clean - TRIED).max(0.0).cos()
    }

    /// Sum of squared differences between the model and the table's entries with polar
    /// angle above `from`, over every light.
    fn held_out_error(&self, table: &Table, from: f64) -> f64 {
        let k = self.k;
        let mut b = RimBuf::new(k);
        let e = &table.entries;
        let mut err = 0.0f64;
        for (i, n) in e.normals.iter().enumerate() {
            if (n[2] as f64).clamp(-1.0, 1.0).acos() < from {
                continue;
            }
            let p = self.tuple(*n, &mut b);
            let tuple = &e.tuples[i * k..(i + 1) * k];
            err += p
                .iter()
                .zip(tuple)
                .map(|(p, v)| f64::from(p - v).powi(2))
                .sum::<f64>();
        }
        err
    }

    /// The model's tuple at unit normal `n` (θ = acos n_z, φ = atan2(n_y, n_x)).
    pub fn tuple<'b>(&self, n: [f32; 3], b: &'b mut RimBuf) -> &'b [f32] {
        let theta = (n[2] as f64).clamp(-1.0, 1.0).acos();
        let phi = (n[1] as f64).atan2(n[0] as f64);
        self.value(theta, phi, b);
        &b.p[..self.k]
    }

    /// The model's tuple at (θ, φ) into `b.p` (β and the trigonometry kept in `b` for
    /// [`Rim::grad`]).
    #[inline(always)]
    fn value(&self, theta: f64, phi: f64, b: &mut RimBuf) {
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        b.trig = [st, ct, sp, cp];
        if let Some(lobe) = &self.lobe {
            lobe.value([st * cp, st * sp, ct], &mut b.p);
            return;
        }
        self.interpolate(phi, b);
        Self::at(
            [(st * cp) as f32, (st * sp) as f32, ct as f32],
            masking(self.mask_a, ct) as f32,
            b,
        );
    }

    /// The derivatives of the tuple with respect to θ and φ at the point of the last
    /// [`Rim::value`] into `b.px`, `b.py` (0 where the model is clamped at 0).
    #[inline(always)]
    fn grad(&self, b: &mut RimBuf) {
        let [st, ct, sp, cp] = b.trig;
        if let Some(lobe) = &self.lobe {
            let tangents = ([ct * cp, ct * sp, -st], [-st * sp, st * cp, 0.0]);
            let n = [st * cp, st * sp, ct];
            lobe.grad(n, tangents, &mut b.p, &mut b.px, &mut b.py);
            return;
        }
        let n = [(st * cp) as f32, (st * sp) as f32, ct as f32];
        let nt = [(ct * cp) as f32, (ct * sp) as f32, -st as f32];
        let np = [(-st * sp) as f32, (st * cp) as f32];
        let kp = self.kp;
        let (bx, by, bz) = (&b.beta[..kp], &b.beta[kp..2 * kp], &b.beta[2 * kp..]);
        let (dx, dy, dz) = (&b.dbeta[..kp], &b.dbeta[kp..2 * kp], &b.dbeta[2 * kp..]);
        let (p, px, py) = (&b.p[..kp], &mut b.px[..kp], &mut b.py[..kp]);
        let m = masking(self.mask_a, ct) as f32;
        // d(ln m)/dθ
        let dl = (masking_dlog(self.mask_a, ct) * -st) as f32;
        for i in 0..kp {
            let lit = p[i] > 0.0;
            let gt = bx[i] * nt[0] + by[i] * nt[1] + bz[i] * nt[2];
            let gp = (bx[i] * np[0] + by[i] * np[1]) + (dx[i] * n[0] + dy[i] * n[1] + dz[i] * n[2]);
            px[i] = if lit { m * gt + p[i] * dl } else { 0.0 };
            py[i] = if lit { m * gp } else { 0.0 };
        }
    }

    /// β interpolated linearly between the sector centres at azimuth φ into `b.beta`,
    /// and its derivative in φ into `b.dbeta`.
    #[inline(always)]
    fn interpolate(&self, phi: f64, b: &mut RimBuf) {
        let k3 = 3 * self.kp;
        let width = std::f64::consts::TAU / self.sectors as f64;
        let u = phi.rem_euclid(std::f64::consts::TAU) / width;
        // u ≥ 0: the truncation is the floor
        let whole = u as usize;
        let s0 = whole % self.sectors;
        let s1 = (s0 + 1) % self.sectors;
        let f = (u - whole as f64) as f32;
        let inv_width = (1.0 / width) as f32;
        let (b0, b1) = (
            &self.beta[s0 * k3..(s0 + 1) * k3],
            &self.beta[s1 * k3..(s1 + 1) * k3],
        );
        let (beta, dbeta) = (&mut b.beta[..k3], &mut b.dbeta[..k3]);
        for i in 0..k3 {
            beta[i] = (1.0 - f) * b0[i] + f * b1[i];
            dbeta[i] = (b1[i] - b0[i]) * inv_width;
        }
    }

    /// The model's tuple max(0, β·n) at unit normal `n` into `b.p`, with β the
    /// interpolated coefficients in `b.beta`.
    #[inline(always)]
    fn at(n: [f32; 3], m: f32, b: &mut RimBuf) {
        let kp = b.p.len();
        let (bx, by, bz) = (&b.beta[..kp], &b.beta[kp..2 * kp], &b.beta[2 * kp..]);
        for (i, p) in b.p.iter_mut().enumerate() {
            *p = (bx[i] * n[0] + by[i] * n[1] + bz[i] * n[2]).max(0.0) * m;
        }
    }

    /// Scale (1, or fitted and ≥ 0 when `scale`) and weighted cost of `b.p` against
    /// `b.t` ([`LANES`] partial sums).
    #[inline(always)]
    fn cost(b: &RimBuf, scale: bool) -> (f32, f32) {
        let (t, w, p) = (&b.t[..], &b.w[..], &b.p[..]);
        let chunks = || {
            t.chunks_exact(LANES)
                .zip(w.chunks_exact(LANES))
                .zip(p.chunks_exact(LANES))
        };
        let c = if scale {
            let (mut tp, mut pp) = ([0.0f32; LANES], [0.0f32; LANES]);
            for ((t, w), p) in chunks() {
                for j in 0..LANES {
                    tp[j] += w[j] * t[j] * p[j];
                    pp[j] += w[j] * p[j] * p[j];
                }
            }
            let (tp, pp) = (lanes_sum(tp), lanes_sum(pp));
            if pp > 0.0 {
                (tp / pp).max(0.0)
            } else {
                0.0
            }
        } else {
            1.0
        };
        let mut acc = [0.0f32; LANES];
        for ((t, w), p) in chunks() {
            for j in 0..LANES {
                acc[j] += w[j] * (t[j] - c * p[j]).powi(2);
            }
        }
        (c, lanes_sum(acc))
    }

    /// Fit (θ, φ) to the target `t` with weights `w` (K values each) from the table
    /// fit's normal `n0`: a scan of θ at the table fit's azimuth, then Gauss–Newton from
    /// the best point; returns (θ, φ, scale, cost).
    pub fn solve(
        &self,
        t: &[f32],
        w: &[f32],
        n0: [f32; 3],
        scale: bool,
        b: &mut RimBuf,
    ) -> (f64, f64, f32, f32) {
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = self.avx {
            // SAFETY: the token `cpu` exists only where the processor has AVX
            return unsafe { self.solve_avx(cpu, t, w, n0, scale, b) };
        }
        self.solve_any(t, w, n0, scale, b)
    }

    /// [`Rim::solve`] compiled with AVX (8-lane loops; no fused multiply-add, so the
    /// same results as the generic build); `_cpu` proves the processor has AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn solve_avx(
        &self,
        _cpu: Avx,
        t: &[f32],
        w: &[f32],
        n0: [f32; 3],
        scale: bool,
        b: &mut RimBuf,
    ) -> (f64, f64, f32, f32) {
        self.solve_any(t, w, n0, scale, b)
    }

    /// [`Rim::solve`] for any instruction set (inlined into each build).
    #[inline(always)]
    fn solve_any(
        &self,
        t: &[f32],
        w: &[f32],
        n0: [f32; 3],
        scale: bool,
        b: &mut RimBuf,
    ) -> (f64, f64, f32, f32) {
        b.t[..self.k].copy_from_slice(&t[..self.k]);
        b.w[..self.k].copy_from_slice(&w[..self.k]);
        let phi = (n0[1] as f64).atan2(n0[0] as f64);
        let theta = self.scan(phi, scale, b);
        self.gauss_newton(theta, phi, scale, b)
    }

    /// The scan's θ of least cost at azimuth φ on the target in `b`. At fixed φ the
    /// model is max(0, sin θ·a + cos θ·β_z), a = β_x cos φ + β_y sin φ.
    #[inline(always)]
    fn scan(&self, phi: f64, scale: bool, b: &mut RimBuf) -> f64 {
        if self.lobe.is_some() {
            let mut best = (self.theta_clean - RING, f32::INFINITY);
            for &(theta, _, _) in &self.scan {
                self.value(theta, phi, b);
                let cost = Self::cost(b, scale).1;
                if cost < best.1 {
                    best = (theta, cost);
                }
            }
            return best.0;
        }
        let kp = self.kp;
        let (sp, cp) = phi.sin_cos();
        self.interpolate(phi, b);
        let (sp, cp) = (sp as f32, cp as f32);
        let (bx, by, bz) = (&b.beta[..kp], &b.beta[kp..2 * kp], &b.beta[2 * kp..3 * kp]);
        for ((a, &x), &y) in b.a.iter_mut().zip(bx).zip(by) {
            *a = x * cp + y * sp;
        }
        let mut best = (self.theta_clean - RING, f32::INFINITY);
        for &(theta, st, ct) in &self.scan {
            let m = masking(self.mask_a, ct) as f32;
            let (st, ct) = (st as f32, ct as f32);
            let cost = if scale {
                for ((p, &a), &z) in b.p.iter_mut().zip(&b.a).zip(bz) {
                    *p = (st * a + ct * z).max(0.0) * m;
                }
                Self::cost(b, true).1
            } else {
                let mut acc = [0.0f32; LANES];
                let model = b.a.chunks_exact(LANES).zip(bz.chunks_exact(LANES));
                let target = b.t.chunks_exact(LANES).zip(b.w.chunks_exact(LANES));
                for ((a, z), (t, w)) in model.zip(target) {
                    for j in 0..LANES {
                        let p = (st * a[j] + ct * z[j]).max(0.0) * m;
                        acc[j] += w[j] * (t[j] - p).powi(2);
                    }
                }
                lanes_sum(acc)
            };
            if cost < best.1 {
                best = (theta, cost);
            }
        }
        best.0
    }

    /// Gauss–Newton over (θ, φ) on the target in `b` (variable projection for the
    /// scale: the Jacobian of c·I is taken at fixed c, which is exact at a converged c),
    /// θ kept in [θ_c − 12°, 90°], step halving; a step shorter than [`STOP`] ends it
    /// untaken.
    #[inline(always)]
    fn gauss_newton(
        &self,
        mut theta: f64,
        mut phi: f64,
        scale: bool,
        b: &mut RimBuf,
    ) -> (f64, f64, f32, f32) {
        let (lo, hi) = (self.theta_clean - RING, std::f64::consts::FRAC_PI_2);
        self.value(theta, phi, b);
        self.grad(b);
        let (mut c, mut cost) = Self::cost(b, scale);
        for it in 0..ITERATIONS {
            let Some((mut dt, mut dp)) = Self::step(b, c, scale) else {
                break;
            };
            let first = (theta + dt).clamp(lo, hi) - theta;
            if first * first + dp * dp < STOP * STOP {
                break;
            }
            let mut moved = false;
            for _ in 0..4 {
                let (nt, np) = ((theta + dt).clamp(lo, hi), phi + dp);
                self.value(nt, np, b);
                let (nc, ncost) = Self::cost(b, scale);
                if ncost <= cost {
                    (dt, dp) = (nt - theta, np - phi);
                    (theta, phi, c, cost) = (nt, np, nc, ncost);
                    moved = true;
                    break;
                }
                dt *= 0.5;
                dp *= 0.5;
            }
            if !moved || dt * dt + dp * dp < STOP * STOP || it + 1 == ITERATIONS {
                break;
            }
            self.grad(b);
        }
        (theta, phi, c, cost)
    }

    /// The damped Gauss–Newton step (Δθ, Δφ) from the tuple and derivatives in `b` at
    /// scale `c`; `None` when the normal equations are singular. With a free scale
    /// (`scaled`), the part of each derivative that c absorbs is projected out
    /// (variable projection in Kaufman's form, as the table refinement does:
    /// JᵀJ = c²(∂ᵀ∂ − ⟨p, ∂⟩⟨p, ∂⟩ᵀ/⟨p, p⟩), weighted inner products); without it the
    /// iteration zig-zags along the valley between θ and c and stops short.
    #[inline(always)]
    fn step(b: &RimBuf, c: f32, scaled: bool) -> Option<(f64, f64)> {
        // four f64 partial sums of each of h11, h12, h22, g1, g2, ⟨p,p⟩, ⟨p,∂x⟩, ⟨p,∂y⟩
        let mut acc = [[0.0f64; 4]; 8];
        let quads = b.t.chunks_exact(4).zip(b.w.chunks_exact(4));
        let derivs =
            b.p.chunks_exact(4)
                .zip(b.px.chunks_exact(4).zip(b.py.chunks_exact(4)));
        for ((t, w), (p, (px, py))) in quads.zip(derivs) {
            for j in 0..4 {
                let jx = (c * px[j]) as f64;
                let jy = (c * py[j]) as f64;
                let r = (t[j] - c * p[j]) as f64;
                let wi = w[j] as f64;
                acc[0][j] += wi * jx * jx;
                acc[1][j] += wi * jx * jy;
                acc[2][j] += wi * jy * jy;
                acc[3][j] += wi * jx * r;
                acc[4][j] += wi * jy * r;
                let pj = (c * p[j]) as f64;
                acc[5][j] += wi * pj * pj;
                acc[6][j] += wi * pj * jx;
                acc[7][j] += wi * pj * jy;
            }
        }
        let [mut h11, mut h12, mut h22, g1, g2, pp, px, py] =
            acc.map(|a| (a[0] + a[2]) + (a[1] + a[3]));
        if scaled && pp > 0.0 {
            // the residual is orthogonal to p at the fitted c, so the gradient is unchanged
            h11 -= px * px / pp;
            h12 -= px * py / pp;
            h22 -= py * py / pp;
        }
        let damp = 1e-6 * (h11 + h22) + 1e-18;
        let (a, d) = (h11 + damp, h22 + damp);
        let det = a * d - h12 * h12;
        if det.is_nan() || det <= 0.0 {
            return None;
        }
        Some(((d * g1 - h12 * g2) / det, (a * g2 - h12 * g1) / det))
    }

    /// The rim fit as a table fit: the grid point whose sphere normal is that of (θ, φ).
    pub fn to_fit(table: &Table, theta: f64, phi: f64, c: f32, cost: f32) -> Fit {
        let n = normal(theta, phi);
        let circle = &table.circle;
        let (gx, gy) = table.to_grid(
            circle.cx + circle.radius * n[0],
            circle.cy - circle.radius * n[1],
        );
        Fit {
            gx,
            gy,
            coef: [c, 0.0],
            cost,
        }
    }
}

/// The scan's values of θ from `lo` to 90° with their sine and cosine.
fn scan_thetas(lo: f64) -> Vec<(f64, f64, f64)> {
    let hi = std::f64::consts::FRAC_PI_2;
    (0..=SCAN)
        .map(|j| {
            let theta = lo + (hi - lo) * j as f64 / SCAN as f64;
            (theta, theta.sin(), theta.cos())
        })
        .collect()
}

#[cfg(test)]
mod tests;
