//! # photostereo
//!
//! Recover the 3-D shape of real, shiny objects from images taken under several
//! lights: calibration-based photometric stereo (orientation consistency, a lookup
//! table built from a reference sphere of the same material), classic Lambertian
//! photometric stereo, integration of the normal field into depth, and removal of
//! interreflections on concave shapes.
//!
//! Data flows one way: images → normals → depth → mesh / report. Only [`io`] touches
//! the file system; every other module works on the in-memory types of [`image`].
//!
//! # Conventions
//!
//! * **Camera frame**: x right, y **up**, z toward the camera; orthographic projection.
//! * **Pixels**: row r (downward), column c. The centre of pixel (r, c) sits at
//!   x = c + 0.5 − W/2, y = H/2 − r − 0.5 ([`image::pixel_to_xy`]). One pixel = one unit.
//! * **Normals**: unit vectors in the camera frame, n_z > 0 on visible surfaces.
//!   Stored as float32 `.npy` of shape (H, W, 3); PNG export encodes c = (n + 1)/2.
//! * **Depth**: z(x, y) in pixel units, larger = closer to the camera, NaN outside the mask.
//! * **Gradient**: p = ∂z/∂x = −n_x/n_z and q = ∂z/∂y = −n_y/n_z, i.e. n ∝ (−p, −q, 1)
//!   ([`image::normal_to_gradient`]). Because rows grow downward, ∂z/∂row = −q.
//! * **Lights**: unit directions from the surface toward the light, camera frame.
//!
//! A sphere cap therefore has p = −x/z, q = −y/z and integrates to a **convex** bump
//! (depth largest at its centre); every integrator is tested for exactly that.
//!
//! ```
//! use photostereo::image::{gradient_to_normal, normal_to_gradient};
//! // The top-right part of a convex sphere faces up and right ...
//! let n = [0.3_f32, 0.4, (1.0_f32 - 0.25).sqrt()];
//! // ... so the surface falls toward the right and the top: p < 0, q < 0.
//! let (p, q) = normal_to_gradient(n, 0.0).unwrap();
//! assert!(p < 0.0 && q < 0.0);
//! let back = gradient_to_normal(p, q);
//! assert!((back[0] - n[0]).abs() < 1e-6);
//! ```

// No panics on user data: `unwrap`/`expect` are denied in the library's own code (tests
// may use them); a value that cannot be absent is written without them, or allowed
// where it is used, with the reason.
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

mod cpu;
pub mod curvature;
pub mod error;
pub mod eval;
pub mod image;
pub mod integrate;
pub mod interreflect;
pub mod io;
pub mod lambertian;
pub mod lightcal;
pub mod limits;
pub mod lut;
pub mod mesh;
pub mod normals;
pub mod picture;
pub mod pipeline;
pub mod plan;
pub mod progress;
#[cfg(feature = "report")]
pub mod report;
pub mod spatial;
pub mod sphere;
mod stats;
pub mod synth;
pub mod warning;

pub use error::{Error, Result, Setting};
pub use image::{DepthMap, GrayImage, Image, ImageStack, Lights, Mask, NormalMap};
pub use warning::{Warning, WarningCode};

/// The README's Rust code, compiled and run by `cargo test --doc` so that it stays true.
#[doc = include_str!("../../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
