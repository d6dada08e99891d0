//! Calibration-based photometric stereo by lookup table (orientation consistency).
//!
//! A sphere of the same material as the target is imaged under the same K lights.
//! Each of its pixels pairs an intensity tuple I = (I_1 … I_K) with the sphere's
//! analytic normal there ([`crate::sphere::Circle::normal_at`]), so a target pixel with
//! tuple t gets the normal whose sphere tuple matches t best — with no reflectance
//! model at all (Woodham, "Gradient and curvature from the photometric-stereo method,
//! including local confidence estimation", JOSA A 11(11), 1994; Hertzmann & Seitz,
//! "Example-based photometric stereo: shape reconstruction with general, varying
//! BRDFs", IEEE PAMI 27(8), 2005).
//!
//! # Method ([`Method::Refined`], the default)
//!
//! 1. **Search, not brute force.** The sphere's tuples lie on a 2-D surface in R^K
//!    (parameterised by the normal). They are projected onto their top principal
//!    components (`pca_dims`) and put in a KD-tree ([`index`]); the `candidates`
//!    nearest entries there are re-ranked on the full K-dimensional cost, and step 2
//!    refines the best. Most pixels skip the tree (*coherence*, one table): Gauss–Newton
//!    starts from the previous pixel's solution in the row, extrapolated by its step
//!    (the solution corrected by its last Gauss–Newton step, the one below the stopping
//!    length that the refinement does not take: a better estimate of its minimum).
//!    **No wrong fit is accepted:** that fit f is kept only with a certificate that no
//!    table entry more than 4.5 px from it fits the target better. Each entry e carries
//!    an *isolation radius* ρ(e), the projected distance to the nearest entry more than
//!    3 px away on the grid (exact: a tree search skipping the nearer); with e₀ the entry
//!    at the even grid point nearest to f (whose distance to the target the refinement
//!    measures with its cell), or where that fails the entry nearest to f (which passes
//!    where the tuples change much faster one way than the other, around highlights),
//!    every such entry lies at least
//!    ρ(e₀) − ‖q − e₀‖ from the pixel's projected query q, and since the projection is
//!    orthogonal the projected distance d bounds an entry's cost from below (raw
//!    matching: cost ≥ d²; normalised: cost ≥ ‖t‖²·min(1, d²/2)). Without the
//!    certificate, a branch and bound over the tree with that lower bound looks for any
//!    entry that costs less than f (search radius from f's cost, so it visits a few
//!    leaves; an entry is costed only when d² plus the squared gap between its and the
//!    query's distances from the principal subspace, a lower bound of its full squared
//!    distance, is within the radius): f is kept when there is none. When it finds one,
//!    the refinement from the best such entry runs and the better fit is kept; when its
//!    initial search ball meets more than 48 leaves of the tree (counted first, without
//!    a cost), the pixel goes through the plain tree search: its candidates are
//!    re-ranked, f is kept only when it fits at least as well as the best candidate and that candidate
//!    lies within 1.5 px of it, otherwise Gauss–Newton from the best candidate runs and
//!    the better fit is kept. So, whatever its neighbours did, no table entry farther
//!    than 4.5 px from a pixel's fit matches it better (a far basin's refinement can
//!    gain at most the table's interpolation error over its best entry): a wrong fit
//!    cannot be carried along a row. `tests/lut_coherence.rs` checks every pixel's
//!    residual against the same pixel solved alone: none worse by more than 0.1% of its
//!    brightness on clean scenes, 1 of 3200 with 1% noise on a sharp-lobed trap (no
//!    pixel off where it is right alone).
//! 2. **Beyond the pixel grid.** The cost ‖t − c·I(x, y)‖² is minimised over the
//!    continuous sphere position (x, y) on the bilinear interpolation of the sphere
//!    images by Gauss–Newton (`fit/generic.rs`; with one table, by a fused pass over the K
//!    lights per step, `fit/fused.rs`); the normal is the sphere's analytic normal at that
//!    point: n = ((x − cx)/R, −(y − cy)/R, √(1 − n_x² − n_y²)).
//!    **Past the table's edge** (θ beyond asin((R − rim)/R)), the fit continues on a
//!    smooth model of each light's reflectance over the normal sphere fitted to the
//!    outer rings (`fit/rim.rs`), up to 90°; the rim band itself (pixels mixed with the
//!    background) is left out of the table.
//! 3. **Albedo.** With `normalize`, c = ⟨t, I⟩/⟨I, I⟩ is fitted (equivalent to matching
//!    t/‖t‖ against I/‖I‖); c, the albedo of the target relative to the sphere, is
//!    returned in [`Output::albedo`]. Without it c = 1 (same albedo as the sphere).
//! 4. **Cast shadows.** A light is dropped when the target is dark there
//!    (t_i − f_i < `shadow_level` · c · peak, peak = the table's brightest sample, f_i
//!    the light's floor: the camera's black level, [`Table::floors`]) while the
//!    match is clearly lit (p_i > t_i + that level); the match is then redone on the
//!    remaining lights (up to 3 rounds): a pattern descent and Gauss–Newton from the
//!    current match, kept when it passes the coherence test above, else an exhaustive
//!    coarse-grid search, a pattern descent and Gauss–Newton. Shadows are coherent too:
//!    next to a pixel with dropped lights, Gauss–Newton starts from its solution with
//!    the same lights dropped, the dropped set is re-derived at the new match and the
//!    fit repeated until the set is stable (up to 3 fits); kept when it passes the
//!    coherence test and the global check on the lights kept (the tree's best
//!    candidate fits no better, and when it lies in another basin its refinement fits
//!    no better either, as in step 1), else the full procedure runs. The number of dropped lights is
//!    returned.
//! 5. **Confidence** = L / (1 + (ρ/ρ₀)²), ρ = RMS residual / RMS target over the lights
//!    used, ρ₀ = `residual_scale`; L = 1 when at least `min_lit_lights` lights are above
//!    the dark level, else ≤ 0.25 (too few lit lights: the normal is a guess).
//!
//! **Shiny targets of varying albedo** ([`Options::split_specular`]): normalising scales
//! the whole tuple, but only the diffuse part of a plastic scales with its albedo. The
//! table is split into its Lambertian part D (a robust fit of max(0, n·g_k) per light)
//! and the remainder S (highlight), and each pixel is fitted as t ≈ a·D(n) + b·S(n), the
//! two-material mixture below with one sphere (`fit/split.rs`; both parts are extended
//! past the table's edge to 90° with the rim model, so grazing normals are fitted).
//!
//! **Several materials** (Hertzmann & Seitz): with two tables the model is
//! t ≈ a·I_A(n) + b·I_B(n), a, b ≥ 0, found by a 2-variable non-negative least-squares
//! fit for each candidate normal, searched on a coarse grid of normals (every grid point
//! scored, vectorised) and refined as above, with variable projection (the Jacobian's
//! part that the weights absorb is projected out) and a fine pattern search against the
//! bilinear creases. As with one table, most pixels start from the previous pixel's fit
//! and keep it only under a global check: it must fit at least as well as the best grid
//! point of the whole table and lie in that point's basin, and the other best grid points
//! outside it are searched too (`search/mixture.rs`); so the split runs at 3–4× and two
//! tables at 1.6–6× the single table's CPU time on 256² renders (22–55× with the
//! exhaustive search at every pixel).
//! (a, b) are returned in [`Output::weights`]. Both tables are extended past their
//! last clean ring to about 89° with their rim models (`fit/split.rs`), so grazing
//! normals are fitted, not clamped to a table's edge. A light counts as cast-shadowed below
//! `shadow_level` × the pixel's brightest predicted sample. The weights' standard error
//! σ_w = max(σ_a, σ_b) from the Gauss–Newton covariance σ²(JᵀJ)⁻¹ of (gx, gy, a, b),
//! σ² = cost/(lights − 4), is returned in [`Output::weight_sigma`] and multiplies the
//! confidence by 1 / (1 + (σ_w / `weight_scale`)²): the weights are unidentifiable
//! where the materials trade off against the normal (grazing normals lit by few lights,
//! no highlight) or where the normal lies beyond the table's rim.
//!
//! **Speed** (`photostereo bench --only lookup`: 1024² shiny vase, 606k mask pixels,
//! K = 16, table of a radius-150 sphere, 2 cores): about 9 Mpx/s before the
//! certificate and the rim model, which cost about 1.6× the CPU time. Of the vase's
//! pixels ≈ 94.6% are certified, ≈ 4.5% kept by the branch and bound and ≈ 0.7% go
//! through the tree; Gauss–Newton takes ≈ 1.6 evaluations per pixel (8 lanes with AVX,
//! with fused multiply-adds where the processor has them, 4 with SSE2, chosen at run
//! time; 57% of the warm fits take one). Everything that depends only on the tables
//! (index, the isolation radii of the even entries, rim model, coarse grid) is built once
//! by [`Lookup::new`], as a KD-tree library builds its tree before the queries (the few
//! other radii the certificate asks for are computed when first needed and kept for the
//! next target); [`solve`] builds it inside the call and computes only the isolation
//! radii it needs.
//! Side by side with scikit-learn's `KDTree` (nearest entry only, its tree built
//! beforehand; `benches/sklearn_lookup.py`, idle machine, 2026-12-02 09:01, 6 runs)
//! the prepared lookup is 19–24× faster in wall time (median 21.6×; 20.5× in CPU time)
//! and one [`solve`] call 13–21× (median 17.1×); issue 10 asks for 18× (README,
//! "Benchmarks"). The workers write the output images row by row (`output.rs`).
//!
//! The table itself (building, file format) is in [`table`] and [`format`](mod@format).

pub(crate) mod fit;
mod options;
pub mod outline;
mod output;
mod search;
pub mod table;

pub use options::{Method, Options};
pub use output::{OutlineCheck, Output, Stats};
pub use search::index;
pub use table::denoise::{self, Denoise};
pub use table::format;
pub use table::{BuildOptions, Entries, OutlineSample, Table, Window};

use crate::error::{Error, Result};
use crate::image::{ImageStack, Mask};
use crate::progress::Progress;
use fit::generic::Model;
use fit::split;
use output::Planes;
use rayon::prelude::*;
use search::{Solver, Work};

/// Share of a table's light that is not Lambertian, in [0, 1]: Σ|I − D| / Σ|I| over
/// its entries and lights, with D the Lambertian part of the diffuse/specular split
/// ([`Options::split_specular`]). About 0 for a matte sphere; a shiny one's highlight
/// raises it. Measured 2026-12-03 (`photostereo calibrate` prints it): the shared
/// Mitsuba diffuse sphere 0.000, its rough plastic 0.084, DiLiGenT's ball 0.051;
/// `synth --shape sphere` at 128 px: Lambertian 0.004 with 1% noise, 0.009 with 3%,
/// 0.002 in 8 bits; plastic 0.027, phong 0.049, metal 0.81. Above [`SPECULAR_SHARE`],
/// brightness-normalised matching
/// ([`Options::normalize`]) is the wrong model for a target whose albedo varies: only
/// the diffuse part scales with the albedo, and the split fits that.
pub fn specular_share(table: &Table) -> f64 {
    split::specular_share(table)
}

/// [`specular_share`] above which a table counts as specular (see there): between the
/// noisiest matte sphere measured (0.009) and the least shiny plastic (0.027).
pub const SPECULAR_SHARE: f64 = 0.02;

/// The options a lookup of `tables` runs with: `opts`, with
/// [`Options::split_if_specular`] resolved (`split_specular` set when it applies).
pub fn options_for(tables: &[Table], opts: &Options) -> Options {
    let mut o = opts.clone();
    o.split_specular |= o.split_if_specular
        && o.normalize
        && o.method == Method::Refined
        && tables.len() == 1
        && specular_share(&tables[0]) > SPECULAR_SHARE;
    o
}

/// Estimate the normals of the `mask` pixels of `stack` from one table (or two for a
/// mixture of materials).
///
/// One call of [`Lookup::new`] and [`Lookup::solve`], except that the isolation radii
/// are computed only for the entries this target needs. To look up several targets
/// with the same tables, build the [`Lookup`] once.
///
/// Errors: no table or more than two; a table whose K or image names differ from the
/// target's ([`Error::TableMismatch`]); K < 3; a mask of another size or empty.
pub fn solve(
    stack: &ImageStack,
    mask: &Mask,
    tables: &[Table],
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Output> {
    let opts = &options_for(tables, opts);
    check_tables(tables, opts)?;
    check_target(stack, mask, tables)?;
    Ok(Lookup::prepare(tables.into(), opts).run(stack, mask, progress))
}

/// A lookup prepared for one set of tables and options: the search index over the
/// table's entries (principal axes and KD-tree), the entries' isolation radii (the
/// certificate of step 1), the rim model past the table's edge and the coarse grid of
/// the exhaustive searches (and, for `split_specular`, the split table). None of it
/// depends on the target, so a batch of targets — many scans, or the chunks of one
/// large image — pays for it once, as a KD-tree library's tree is built once and then
/// queried. Immutable after [`Lookup::new`]; [`Lookup::solve`] may run from several
/// threads at once.
///
/// ```
/// # use photostereo::{lut, synth, sphere::Circle, progress::NoProgress};
/// let opts = synth::SceneOptions { width: 64, height: 64, ..Default::default() };
/// let sphere = synth::render_calibration_sphere(&opts, 24.0)?;
/// let (w, h) = (sphere.stack.width as f64, sphere.stack.height as f64);
/// let circle = Circle { cx: w / 2.0, cy: h / 2.0, radius: 24.0 };
/// let tables = [lut::Table::build(&sphere.stack, &circle, &lut::BuildOptions::default())?];
/// let lookup = lut::Lookup::new(&tables[..], &lut::Options::default())?;
/// for _scan in 0..2 {
///     let scene = synth::render(&opts)?;
///     let out = lookup.solve(&scene.stack, &scene.mask, &NoProgress)?;
///     assert_eq!(out.stats.pixels, scene.mask.count());
/// }
/// # Ok::<(), photostereo::Error>(())
/// ```
pub struct Lookup<'t> {
    /// The caller's tables (for the checks against each target), borrowed or owned.
    given: std::borrow::Cow<'t, [Table]>,
    /// The tables searched when they differ from the given ones (the split table, or
    /// two tables extended to 90°, or tables above their black level).
    derived: Option<Vec<Table>>,
    /// Each light's black level, taken off the tables and every target tuple where a
    /// brightness is fitted ([`black_level`]); `None`: matched as they are.
    black: Option<Vec<f32>>,
    opts: Options,
    prep: search::Prep,
    /// The brightness-free match of the mask's outline ([`Options::outline_coverage`]):
    /// its options (`normalize` on) and prepared search; `None` also where the check on
    /// the sphere's own outline found that it does not help ([`Lookup::outline_check`]).
    outline: Option<(Options, search::Prep)>,
    /// That check, where it ran.
    outline_check: Option<OutlineCheck>,
}

impl<'t> Lookup<'t> {
    /// Prepare the lookup of targets against `tables` (one, or two for a mixture of
    /// materials; borrowed, `&[Table]`, or owned, `Vec<Table>`) with `opts`, including
    /// the isolation radius of every entry at an even grid point (in parallel; the
    /// others are computed when first needed and kept).
    ///
    /// Errors: no table or more than two; K < 3; two tables under different numbers
    /// of lights; options that do not fit the tables (as [`solve`]).
    pub fn new(tables: impl Into<std::borrow::Cow<'t, [Table]>>, opts: &Options) -> Result<Self> {
        let tables = tables.into();
        let opts = &options_for(&tables, opts);
        check_tables(&tables, opts)?;
        let lookup = Self::prepare(tables, opts);
        lookup.prep.fill_isolation(lookup.model(), &lookup.opts);
        Ok(lookup)
    }

    /// As [`Lookup::new`] on checked tables and options, the isolation radii left to be
    /// computed when first needed.
    fn prepare(tables: std::borrow::Cow<'t, [Table]>, opts: &Options) -> Self {
        let black = black_level(&tables, opts);
        let above: Option<Vec<Table>> =
            (black.as_ref()).map(|f| tables.iter().map(|t| t.above(f)).collect());
        let base = above.as_deref().unwrap_or(&tables);
        let derived = if opts.split_specular {
            Some(split::split(&base[0]).to_vec())
        } else if base.len() == 2 {
            // the mixture reaches 90° on both tables' rim models
            Some(vec![split::extend(&base[0]), split::extend(&base[1])])
        } else {
            above
        };
        let searched = derived.as_deref().unwrap_or(&tables);
        let prep = search::Prep::new(&Model::new(searched, opts.normalize), opts);
        let outline = outline_applies(searched, opts).then(|| {
            let o = Options {
                normalize: true,
                ..opts.clone()
            };
            let p = search::Prep::new(&Model::new(searched, true), &o);
            (o, p)
        });
        let mut lookup = Lookup {
            given: tables,
            derived,
            black,
            opts: opts.clone(),
            prep,
            outline,
            outline_check: None,
        };
        lookup.outline_check = lookup.check_outline();
        if lookup.outline_check.is_some_and(|c| !c.helps()) {
            lookup.outline = None;
        }
        lookup
    }

    /// The check of the outline's coverage correction on the sphere's own outline
    /// ([`OutlineCheck`]); `None` where the correction does not apply
    /// ([`Options::outline_coverage`]) or the table has no outline sample (read from a
    /// file written before it was kept: the correction is then applied as it was).
    pub fn outline_check(&self) -> Option<OutlineCheck> {
        self.outline_check
    }

    /// [`Lookup::outline_check`], measured: each pixel of the sphere's outline sample
    /// solved as a target's outline pixel is in [`Lookup::run`], plain and corrected.
    fn check_outline(&self) -> Option<OutlineCheck> {
        let sample = self.given.first()?.outline.as_ref()?;
        let (solver, os) = self.solvers();
        let os = os?;
        let k = self.given[0].k;
        let (mut wk, mut wo) = (Work::new(k), Work::new(k));
        let (mut plain, mut corrected) = (0.0, 0.0);
        for (t, n) in sample.tuples.chunks_exact(k).zip(&sample.normals) {
            self.load(t, &mut wk);
            wk.warm = None;
            let px = solver.pixel(&mut wk);
            plain += crate::eval::angle_deg(&px.normal, n);
            let fixed = coverage_refit(&solver, &os, (&mut wk, &mut wo), px);
            corrected += crate::eval::angle_deg(&fixed.normal, n);
        }
        let pixels = sample.normals.len();
        Some(OutlineCheck {
            pixels,
            plain_deg: plain / pixels.max(1) as f64,
            corrected_deg: corrected / pixels.max(1) as f64,
        })
    }

    /// The pixel solver and, where the outline's correction applies, the outline's
    /// brightness-free solver: what [`Lookup::run`] and [`Lookup::check_outline`] solve
    /// with.
    fn solvers(&self) -> (Solver<'_>, Option<Solver<'_>>) {
        let solver = Solver::with(self.model(), &self.opts, &self.prep);
        let outline = self.outline.as_ref().map(|(o, prep)| {
            let searched = self.derived.as_deref().unwrap_or(&self.given);
            Solver::with(Model::new(searched, true), o, prep)
        });
        (solver, outline)
    }

    /// A target's tuple `t` into `wk.t`, as matched: non-finite samples as 0, the black
    /// level taken off where a brightness is fitted.
    fn load(&self, t: &[f32], wk: &mut Work) {
        for (dst, &v) in wk.t.iter_mut().zip(t) {
            *dst = if v.is_finite() { v } else { 0.0 };
        }
        if let Some(black) = &self.black {
            wk.t.iter_mut().zip(black).for_each(|(v, f)| *v -= f);
        }
    }

    /// The tables the lookup was prepared for, as given.
    pub fn tables(&self) -> &[Table] {
        &self.given
    }

    /// The options the lookup was prepared with ([`Options::split_if_specular`]
    /// resolved by [`options_for`]).
    pub fn options(&self) -> &Options {
        &self.opts
    }

    fn model(&self) -> Model<'_> {
        let searched = self.derived.as_deref().unwrap_or(&self.given);
        Model::new(searched, self.opts.normalize)
    }

    /// Estimate the normals of the `mask` pixels of `stack` (see [`solve`]).
    ///
    /// Errors: a target whose K or image names differ from the tables'
    /// ([`Error::TableMismatch`]); a mask of another size or empty.
    pub fn solve(
        &self,
        stack: &ImageStack,
        mask: &Mask,
        progress: &dyn Progress,
    ) -> Result<Output> {
        check_target(stack, mask, &self.given)?;
        Ok(self.run(stack, mask, progress))
    }

    /// [`Lookup::solve`] on a checked target.
    fn run(&self, stack: &ImageStack, mask: &Mask, progress: &dyn Progress) -> Output {
        let (solver, outline) = self.solvers();
        let n_tables = self.derived.as_ref().map_or(self.given.len(), Vec::len);
        let (w, h, k) = (stack.width, stack.height, stack.k);
        let mut planes = Planes::new(w, h, n_tables, self.opts.normalize);
        planes.albedo_from_weight = self.opts.split_specular;
        progress.start("lookup", h as u64);
        let stats = planes
            .rows()
            .into_par_iter()
            .enumerate()
            .map(|(r, mut row)| {
                let mut wk = Work::new(k);
                let mut wo = outline.as_ref().map(|_| Work::new(k));
                for c in 0..w {
                    if !*mask.get(r, c) {
                        wk.warm = None;
                        continue;
                    }
                    self.load(stack.pixel(r, c), &mut wk);
                    let mut px = solver.pixel(&mut wk);
                    if let (Some(os), Some(wo)) = (&outline, wo.as_mut()) {
                        if outline::on_outline(mask, r, c) {
                            px = coverage_refit(&solver, os, (&mut wk, wo), px);
                        }
                    }
                    row.set(c, &px);
                }
                progress.advance(1);
                row.stats
            })
            .reduce(Stats::default, output::add_stats);
        progress.finish();
        let stats = Stats {
            outline_check: self.outline_check,
            ..stats
        };
        planes.into_output(stats)
    }
}

/// The cast-shadow test of a light (module docs, step 4), shared by the lookup and the
/// spatial stage's evidence: the target's sample `t` is within `level` of the light's
/// `floor` (its black level, [`Table::floors`]) while the prediction `pred` is lit above
/// it. (`fit::fused::Single::any_dark_lit` is its lane-wise form on the fast path.)
#[inline]
pub(crate) fn cast_shadowed(t: f32, floor: f32, pred: f32, level: f32) -> bool {
    t - floor < level && pred > t + level
}

/// The black level to take off tables and targets before matching, where the match
/// fits a brightness (normalised matching, the diffuse/specular split, a mixture of two
/// tables): the smaller of the tables' [`Table::black_level`], for every light, when it
/// is above 0; else `None`. A brightness scales only the light above the black level:
/// with a 3% black level the textured plastic of `tests/camera_mitsuba.rs` went from
/// 0.237° (split, no black level) to 2.48°. Where the brightness is 1 (plain matching)
/// the offset cancels and nothing is taken off.
fn black_level(tables: &[Table], opts: &Options) -> Option<Vec<f32>> {
    let fits_brightness = opts.normalize || opts.split_specular || tables.len() == 2;
    if !fits_brightness {
        return None;
    }
    let k = tables.first()?.k;
    let level = (tables.iter().map(Table::black_level)).fold(f32::INFINITY, f32::min);
    (level > 0.0 && level.is_finite()).then(|| vec![level; k])
}

/// Whether the outline's brightness-free match applies ([`Options::outline_coverage`]):
/// one table searched, the refined method, no brightness fitted at every pixel already.
fn outline_applies(searched: &[Table], opts: &Options) -> bool {
    opts.outline_coverage
        && searched.len() == 1
        && opts.method == Method::Refined
        && !opts.normalize
        && !opts.split_specular
}

/// The outline pixel whose plain match is `plain` (tuple in `wk.t`), matched again on its
/// tuple's light above each light's floor (the black level, which the background shows
/// instead of 0) divided by the coverage its brightness-free match stands for
/// (`outline.rs`), where that match fits clearly better: RMS residual below the plain
/// one's by the factor [`outline::RESIDUAL_RATIO`] (a free brightness alone, on noise,
/// lowers it by about 1/(2K)). `wo` holds the outline solver's own buffers (no warm
/// start).
fn coverage_refit(
    solver: &Solver,
    os: &Solver,
    (wk, wo): (&mut Work, &mut Work),
    plain: output::PixelOut,
) -> output::PixelOut {
    let k = solver.model.k;
    wo.t[..k].copy_from_slice(&wk.t[..k]);
    wo.warm = None;
    let free = os.pixel(wo);
    let g = outline::coverage(free.coef[0]);

    let clearly_better = outline::RESIDUAL_RATIO * free.residual < plain.residual;
    if g >= 1.0 || !clearly_better {
        return plain;
    }
    (wk.t[..k].iter_mut().zip(solver.floors)).for_each(|(v, &f)| *v = f + (*v - f) / g);
    solver.pixel(wk)
}

/// The target's checks: lights, mask size, a non-empty mask, the same lights as the
/// tables'.
fn check_target(stack: &ImageStack, mask: &Mask, tables: &[Table]) -> Result<()> {
    table::check_lights(stack.k, "target images")?;
    mask.check_size(stack.width, stack.height, "target mask")?;
    mask.check_not_empty("target mask")?;
    for (i, t) in tables.iter().enumerate() {
        let what = format!("#{} ('{}')", i + 1, t.material);
        t.check_target(stack.k, &stack.names, &what)?;
    }
    Ok(())
}

/// The tables' and options' checks (the target's are in [`Lookup::solve`]).
fn check_tables(tables: &[Table], opts: &Options) -> Result<()> {
    if tables.is_empty() || tables.len() > 2 {
        return Err(Error::invalid(
            format!("{} lookup tables", tables.len()),
            "give one table, or two for a mixture of two materials",
        ));
    }
    for t in tables {
        table::check_lights(t.k, &format!("table '{}'", t.material))?;
    }
    if let [a, b] = tables {
        if a.k != b.k {
            return Err(Error::TableMismatch {
                what: format!("#2 ('{}')", b.material),
                reason: format!(
                    "table #1 has {} lights, table #2 {}; calibrate both spheres under the same lights",
                    a.k, b.k
                ),
            });
        }
    }
    if opts.split_specular && tables.len() != 1 {
        return Err(Error::invalid(
            format!("split_specular with {} tables", tables.len()),
            "the diffuse/specular split takes one table; give one, or turn the split off",
        ));
    }
    if (tables.len() == 2 || opts.split_specular) && opts.method != Method::Refined {
        let what = if opts.split_specular {
            "the diffuse/specular split"
        } else {
            "two tables"
        };
        return Err(Error::invalid(
            format!("method {:?} with {what}", opts.method),
            "a two-part mixture (two materials, or diffuse + specular) needs Method::Refined",
        ));
    }
    if let Method::InverseDistance { neighbours } = opts.method {
        if neighbours == 0 || neighbours > index::MAX_CANDIDATES {
            return Err(Error::invalid(
                format!("{neighbours} neighbours"),
                format!("use 1 to {} neighbours", index::MAX_CANDIDATES),
            ));
        }
    }
    if opts.candidates == 0 || opts.candidates > index::MAX_CANDIDATES {
        return Err(Error::invalid(
            format!("{} candidates", opts.candidates),
            format!("use 1 to {} candidates", index::MAX_CANDIDATES),
        ));
    }
    Ok(())
}
