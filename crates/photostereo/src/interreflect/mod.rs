//! Interreflections on concave Lambertian shapes: a radiosity forward model and its removal
//! by the iteration of Nayar, Ikeuchi & Kanade ("Shape from interreflections", IJCV 6(3),
//! 173–195, 1991).
//!
//! # Forward model
//! The shape (depth map + normals + mask) becomes Lambertian facets ([`facets::Facets`]),
//! one per `block`×`block` pixel cell. Between facets i ≠ j, with r = x_j − x_i,
//!
//! K_ij = (n_i·r)(n_j·(−r)) / (π|r|⁴) · V_ij · A_j,
//!
//! A_j the true facet area (Σ 1/n_z over its pixels) and V_ij the visibility of j from i over
//! the height field ([`Visibility`]). With albedo ρ and direct irradiance E the radiosity obeys
//! B = ρ∘(E + K·B), solved by bounce iteration ([`radiosity::Model::render`]); images are
//! proportional to B. Bounced light is computed per facet and spread back to the pixels
//! bilinearly, so a coarse grid (block 2–4) costs little accuracy: bounced light is smooth.
//!
//! # Removal
//! Because ρE = B − ρ∘(K·B), the direct images are I_raw − ρ∘(K·I_raw) once the shape and
//! albedo are right. Shape and albedo come from photometric stereo on images that still hold
//! interreflections, so the iteration alternates: shape → K → compensated images →
//! photometric stereo + integration → shape, until the depth stops changing.

pub mod facets;
pub mod kernel;
pub mod nik;
#[cfg(feature = "report")]
pub mod plot;
pub mod radiosity;
pub mod scene;

pub use facets::auto_block;
pub use kernel::{Kernel, KernelOptions};
pub use nik::{iterate, solve, Convergence, Iterate, NikOptions, NikOutput, Reconstruction};
#[cfg(feature = "report")]
pub use plot::{convergence_plot_png, profile_plot_png};
pub use radiosity::{Model, Rendered};
pub use scene::{render_with_interreflections, render_with_interreflections_report, BounceReport};

/// How the visibility V_ij of facet j from facet i is decided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Visibility {
    /// V_ij = 1 for every facing pair (exact for a surface with no self-occlusion, e.g. a
    /// bowl or a V-groove seen from inside). O(n²).
    None,
    /// Horizon marching: from each facet, march one grid cell at a time along `azimuths`
    /// directions keeping the running maximum elevation slope (h − z_i)/distance; j is
    /// visible when its slope (z_j − z_i)/|Δ| is above the horizon at its distance,
    /// interpolated between the two nearest azimuths. O(n·D·L + n²) for D azimuths, L steps.
    Horizon {
        /// Number of azimuths D (≥ 4; 64 is typical).
        azimuths: usize,
    },
    /// Reference: sample the image line between every pair every half cell and compare the
    /// height field with the segment. O(n²·L).
    BruteForce,
}

impl Default for Visibility {
    fn default() -> Self {
        Visibility::Horizon { azimuths: 64 }
    }
}

/// Options of the radiosity forward model.
#[derive(Clone, Copy, Debug)]
pub struct RadiosityOptions {
    /// Facet size in pixels (1 = one facet per pixel; 2–4 is much faster and still accurate
    /// because bounced light is smooth). 0 (the default) = automatic: the smallest block ≥ 2
    /// whose grid has at most `auto_facets` cells inside the mask ([`auto_block`]).
    pub block: usize,
    /// Cell budget of the automatic block (`block` = 0): 4096 cells make a 64 MiB kernel.
    pub auto_facets: usize,
    /// Visibility test between facets.
    pub visibility: Visibility,
    /// Height tolerance in pixels before a sample of the height field counts as occluding.
    pub vis_eps: f32,
    /// Largest number of facets (the dense kernel takes 4·n² bytes); more is an error.
    pub max_facets: usize,
    /// Most bounces when rendering.
    pub max_bounces: usize,
    /// Rendering stops when a bounce changes no pixel by more than `tol` × the brightest
    /// direct pixel (relative, unitless).
    pub tol: f32,
}

impl RadiosityOptions {
    /// The facet block used on `mask`: `block` when set, else [`auto_block`] with
    /// `auto_facets` cells.
    pub fn block_for(&self, mask: &crate::image::Mask) -> usize {
        if self.block > 0 {
            self.block
        } else {
            auto_block(mask, self.auto_facets)
        }
    }
}

impl Default for RadiosityOptions {
    fn default() -> Self {
        RadiosityOptions {
            block: 0,
            auto_facets: 4096,
            visibility: Visibility::default(),
            vis_eps: 0.05,
            max_facets: 16_384,
            max_bounces: 100,
            tol: 1e-5,
        }
    }
}
