//! Radiosity on the facet model: adding interreflections to direct images, and removing them.
//!
//! Per light, with ρ the albedo and E the direct irradiance (so that the direct image is ρE):
//!
//! B = ρ∘(E + K·B)  ⇒  B = (I − ρK)⁻¹ ρE,
//!
//! solved by the fixed-point iteration B ← ρE + ρ∘(K·B) (one bounce per step; it converges
//! since ρ < 1 and every row sum of K is at most 1). Images are proportional to B.
//! The direct part of an image is ρE = B − ρ∘(K·B), which needs no knowledge of E:
//! this is the compensation I_direct = I_raw − ρ∘(K·I_raw) of Nayar, Ikeuchi & Kanade,
//! "Shape from interreflections", IJCV 6(3), 1991.

use super::facets::Facets;
use super::kernel::{Kernel, KernelOptions};
use super::RadiosityOptions;
use crate::error::{Error, Result};
use crate::image::{DepthMap, GrayImage, ImageStack, Mask, NormalMap};
use crate::progress::Progress;

/// Facets and their kernel for one shape: everything needed to add or remove bounced light.
#[derive(Clone, Debug)]
pub struct Model {
    /// The facets of the shape.
    pub facets: Facets,
    /// The interreflection kernel between them.
    pub kernel: Kernel,
}

/// Images with all bounces, from [`Model::render`].
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The images with interreflections (same layout as the direct stack).
    pub stack: ImageStack,
    /// Bounces computed.
    pub bounces: usize,
    /// Relative change of the last bounce (max |ΔI| / max I); below the tolerance when converged.
    pub last_change: f32,
    /// True when the last change fell below the tolerance.
    pub converged: bool,
}

impl Model {
    /// Facets and kernel of the shape given by depth, unit normals and mask (facet block
    /// from [`RadiosityOptions::block_for`]).
    pub fn new(
        depth: &DepthMap,
        normals: &NormalMap,
        mask: &Mask,
        opts: &RadiosityOptions,
        progress: &dyn Progress,
    ) -> Result<Self> {
        let facets = Facets::build(depth, normals, mask, opts.block_for(mask))?;
        let kopts = KernelOptions {
            visibility: opts.visibility,
            vis_eps: opts.vis_eps,
            max_facets: opts.max_facets,
        };
        let kernel = Kernel::build(&facets, &kopts, progress)?;
        Ok(Model { facets, kernel })
    }

    /// Light bounced once: ρ∘(K·I), computed on the facets and spread back to the pixels.
    pub fn bounce(&self, stack: &ImageStack, albedo: &GrayImage) -> Result<ImageStack> {
        self.check(stack, albedo)?;
        let k = stack.k;
        let pooled = self.facets.pool(stack);
        let g = self.kernel.apply(&pooled, k);
        let mut out = self.facets.spread(&g, k);
        for (p, &rho) in albedo.data.iter().enumerate() {
            let rho = if rho.is_finite() { rho.max(0.0) } else { 0.0 };
            out.pixel_flat_mut(p).iter_mut().for_each(|v| *v *= rho);
        }
        Ok(out)
    }

    /// Add all bounces to direct images ρE: iterate I ← ρE + ρ∘(K·I) until the relative
    /// change is below `tol` or `max_bounces` bounces are done.
    pub fn render(
        &self,
        direct: &ImageStack,
        albedo: &GrayImage,
        max_bounces: usize,
        tol: f32,
    ) -> Result<Rendered> {
        let mut cur = direct.clone();
        let scale = direct
            .data
            .iter()
            .fold(0.0f32, |a, v| a.max(v.abs()))
            .max(1e-12);
        let (mut bounces, mut last_change, mut converged) = (0, f32::INFINITY, false);
        while bounces < max_bounces {
            let b = self.bounce(&cur, albedo)?;
            let mut change = 0.0f32;
            for ((c, d), bb) in cur.data.iter_mut().zip(&direct.data).zip(&b.data) {
                let next = d + bb;
                change = change.max((next - *c).abs());
                *c = next;
            }
            bounces += 1;
            last_change = change / scale;
            if last_change < tol {
                converged = true;
                break;
            }
        }
        Ok(Rendered {
            stack: cur,
            bounces,
            last_change,
            converged,
        })
    }

    /// Remove the interreflections: I_direct = I_raw − ρ∘(K·I_raw), clamped at 0.
    pub fn compensate(&self, raw: &ImageStack, albedo: &GrayImage) -> Result<ImageStack> {
        let b = self.bounce(raw, albedo)?;
        let mut out = raw.clone();
        for (o, bb) in out.data.iter_mut().zip(&b.data) {
            *o = (*o - bb).max(0.0);
        }
        Ok(out)
    }

    fn check(&self, stack: &ImageStack, albedo: &GrayImage) -> Result<()> {
        let f = &self.facets;
        for (what, w, h) in [
            ("image stack", stack.width, stack.height),
            ("albedo map", albedo.width, albedo.height),
        ] {
            if w != f.width || h != f.height {
                return Err(Error::SizeMismatch {
                    what: format!("{what} for the interreflection model"),
                    expected_w: f.width,
                    expected_h: f.height,
                    found_w: w,
                    found_h: h,
                    fix: "use images, albedo and shape of the same size".into(),
                });
            }
        }
        if stack.k == 0 {
            return Err(Error::LightCount {
                what: "image stack for the interreflection model".into(),
                expected: 1,
                found: 0,
                fix: "give at least one image".into(),
            });
        }
        Ok(())
    }
}
