//! Synthetic scenes with all bounces: the direct render of [`crate::synth`] (cast shadows
//! included), then B = (I − ρK)⁻¹ρE per light by bounce iteration on the exact shape, then
//! the scene's noise and 16-bit quantisation.

use super::radiosity::Model;
use super::RadiosityOptions;
use crate::error::{Error, Result};
use crate::progress::{NoProgress, Progress};
use crate::synth::{self, Material, Scene, SceneOptions};

/// Diagnostics of [`render_with_interreflections`].
#[derive(Clone, Debug)]
pub struct BounceReport {
    /// Bounces computed.
    pub bounces: usize,
    /// Relative change of the last bounce.
    pub last_change: f32,
    /// Number of facets of the model.
    pub facets: usize,
    /// Mean over the mask and the lights of (with bounces − direct) / with bounces.
    pub indirect_fraction: f32,
}

/// Render `opts` with interreflections (see the module docs). Only Lambertian materials are
/// accepted: the radiosity model assumes diffuse reflection.
pub fn render_with_interreflections(
    opts: &SceneOptions,
    radiosity: &RadiosityOptions,
) -> Result<Scene> {
    render_with_interreflections_report(opts, radiosity, &NoProgress).map(|(s, _)| s)
}

/// [`render_with_interreflections`] with progress and a [`BounceReport`].
pub fn render_with_interreflections_report(
    opts: &SceneOptions,
    radiosity: &RadiosityOptions,
    progress: &dyn Progress,
) -> Result<(Scene, BounceReport)> {
    if !matches!(opts.material, Material::Lambertian { .. }) {
        return Err(Error::invalid(
            "interreflections with a non-Lambertian material",
            "use a Lambertian material (the radiosity model is diffuse only)",
        ));
    }
    let clean = SceneOptions {
        noise_sigma: 0.0,
        camera: synth::Camera::default(),
        ..opts.clone()
    };
    let mut scene = synth::render_with_progress(&clean, progress)?;
    let model = Model::new(
        &scene.depth,
        &scene.normals,
        &scene.mask,
        radiosity,
        progress,
    )?;
    let out = model.render(
        &scene.stack,
        &scene.albedo,
        radiosity.max_bounces,
        radiosity.tol,
    )?;
    let indirect_fraction = indirect_fraction(&scene, &out.stack);
    scene.stack.data = out.stack.data;
    add_noise(opts, &mut scene);
    let report = BounceReport {
        bounces: out.bounces,
        last_change: out.last_change,
        facets: model.facets.len(),
        indirect_fraction,
    };
    Ok((scene, report))
}

fn indirect_fraction(direct: &Scene, with: &crate::image::ImageStack) -> f32 {
    let (mut s, mut n) = (0.0f64, 0usize);
    for (p, &m) in direct.mask.data.iter().enumerate() {
        if !m {
            continue;
        }
        for (d, b) in direct.stack.pixel_flat(p).iter().zip(with.pixel_flat(p)) {
            if *b > 0.0 {
                s += ((b - d) / b) as f64;
                n += 1;
            }
        }
    }
    if n == 0 {
        0.0
    } else {
        (s / n as f64) as f32
    }
}

/// The camera of `opts` (blur, black level, noise, quantisation) as in [`crate::synth`],
/// on the stack with interreflections (its own noise stream).
fn add_noise(opts: &SceneOptions, scene: &mut Scene) {
    synth::camera::develop(
        &mut scene.stack,
        &opts.camera,
        opts.noise_sigma,
        opts.seed ^ 0x1_4EF1,
    );
}
