//! The fit at one target pixel: the cost ‖t − Σ_j c_j·I_j(gx, gy)‖² over a continuous
//! position on the table's window grid (steps 2 and 3 of the method in [`crate::lut`]).
//!
//! * `generic.rs`: the fit for one or two tables, raw, normalised or as a mixture, by
//!   Gauss–Newton with variable projection ([`generic::Model`]);
//! * `fused.rs`: the same fit for one table in one fused pass over the K lights per
//!   step, vectorised (`fused/lanes.rs`, AVX or SSE2 chosen at run time);
//! * `rim.rs`: a smooth model of each light's reflectance past the table's edge, up to
//!   90°, and the fit on it (`ring.rs`: the least-squares fit of its coefficients;
//!   `lobe.rs`: a parametric microfacet lobe per light, its other candidate);
//! * `split.rs`: a table split into its Lambertian part and the rest, and a table
//!   extended to 90° with its rim model.
//!
//! This layer knows the tables ([`crate::lut::table`]) and nothing of the search.

pub(crate) mod fused;
pub(crate) mod generic;
pub(crate) mod lobe;
pub(crate) mod rim;
pub(crate) mod ring;
pub(crate) mod split;
