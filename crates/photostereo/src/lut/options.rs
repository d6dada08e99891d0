//! The options of a lookup ([`super::solve`], [`super::Lookup`]).

/// How a target tuple is turned into a normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Tree candidates re-ranked in full K, then n = argmin over the continuous sphere
    /// position of ‖t − c·I(x, y)‖² (bilinear I, Gauss–Newton), with cast-shadow
    /// handling (see the module docs).
    Refined,
    /// The normal of the single best table entry (re-ranked tree candidates): accuracy
    /// limited by the sphere's pixel spacing. No shadow handling.
    Nearest,
    /// Baseline: the `neighbours` nearest entries in full K (exact KD-tree search),
    /// n ∝ Σ n_j / d_j with d_j the Euclidean tuple distance. No shadow handling.
    InverseDistance {
        /// Number of neighbours averaged (6 in the classic baseline).
        neighbours: usize,
    },
}

/// Options of [`super::solve`].
#[derive(Clone, Debug)]
pub struct Options {
    /// How tuples become normals. Default [`Method::Refined`].
    pub method: Method,
    /// Match brightness-normalised tuples (targets whose albedo differs from the
    /// sphere's); the albedo ratio is returned. Default false.
    pub normalize: bool,
    /// Dark level as a fraction of the match's brightness (c × the table's brightest
    /// sample): target samples less than this above the light's floor (the black
    /// level, `Table::floors`) count as unlit / shadowed. Default 0.03.
    pub shadow_level: f32,
    /// Fewer lit lights than this gives a confidence ≤ 0.25. Default 3.
    pub min_lit_lights: usize,
    /// Tree candidates re-ranked in full K (1..=16). Default 4.
    pub candidates: usize,
    /// Principal components the tree searches in (1..=8). Default 6.
    pub pca_dims: usize,
    /// Gauss–Newton iterations of the sub-pixel refinement. Default 8.
    pub max_iterations: usize,
    /// Relative RMS residual at which the confidence drops to 1/2. Default 0.05.
    pub residual_scale: f32,
    /// Two tables: standard error of the mixture weights at which the confidence is
    /// halved again (weights are fractions of each reference's brightness). Default 0.025.
    pub weight_scale: f32,
    /// One table, for targets whose albedo varies on a shiny material: split the table
    /// into its Lambertian part D and the remainder S (highlight) and fit
    /// t ≈ a·D(n) + b·S(n), a, b ≥ 0 (`fit/split.rs`; the two-material mixture with one
    /// sphere). a, the diffuse albedo relative to the sphere's, is returned in
    /// [`super::Output::albedo`], (a, b) in [`super::Output::weights`]. About 3–4× the CPU time of
    /// `normalize` (the mixture's search, `search/mixture.rs`). Default false.
    pub split_specular: bool,
    /// With `normalize` and one specular table (its [`super::specular_share`] above
    /// [`super::SPECULAR_SHARE`]) and [`Method::Refined`]: fit the diffuse/specular split
    /// (`split_specular`) instead of brightness-normalised tuples, the model of a shiny
    /// target whose albedo varies (only its diffuse part scales with the albedo). A
    /// matte table keeps normalised matching. Resolved by [`super::options_for`].
    /// Default false.
    pub split_if_specular: bool,
    /// Match each pixel of the mask's outline (next to background) with a free brightness
    /// first and correct its tuple for the share of its footprint that sees the object
    /// (`outline.rs`: silhouette pixels are area averages partly over the background).
    /// Applies to one table, [`Method::Refined`], without `normalize` or the split (those
    /// fit a brightness at every pixel already), and only where the same correction
    /// brings the calibration sphere's own outline closer to its known normals
    /// ([`super::Lookup::outline_check`]; tables read from files written before the
    /// sphere's outline was kept are corrected unchecked). Default true.
    pub outline_coverage: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            method: Method::Refined,
            normalize: false,
            shadow_level: 0.03,
            min_lit_lights: 3,
            candidates: 4,
            pca_dims: 6,
            max_iterations: 8,
            residual_scale: 0.05,
            weight_scale: 0.025,
            split_specular: false,
            split_if_specular: false,
            outline_coverage: true,
        }
    }
}
