//! Synthetic photometric-stereo scenes with exact ground truth.
//!
//! An orthographic camera looks down −z at an analytic height field z(x, y)
//! ([`Shape`], pixel units, larger = closer) lit by K directional lights
//! ([`Lights`], unit, surface → light). Each pixel centre gets its exact normal
//! ([`shape_geometry`]), and its K intensities
//!
//! I_k = e · i_k · shade(material, n, l_k, ρ(x, y)) · [not in cast shadow] + noise,
//!
//! with e the `exposure`, i_k the light intensity, ρ the optional albedo texture and
//! [`shade`] the BRDF ([`Material`]: Lambertian, Blinn–Phong, GGX/Cook–Torrance). Attached
//! shadows (n·l ≤ 0) are zero through the BRDF; cast shadows are exact tests of the ray
//! toward each light against the analytic surface ([`shadow`]: none on the convex sphere
//! and blob, closed forms for the bowl and the V-groove, a ray march with provably safe
//! steps for the vase). Pixels outside the mask get `background` in every image. Only
//! direct light is simulated (no interreflections).
//!
//! Intensity scale: a Lambertian surface of albedo 1 facing a light of intensity 1 gives
//! 1, so I = ρ·max(n·l, 0) for Lambertian. Specular highlights may exceed 1: the stack
//! is float by default. The [`Camera`] then makes the samples as a camera would
//! ([`camera`] module docs): optical blur, black level, noise, and with `bits` clipping
//! to [0, 1] and rounding to 8- or 16-bit levels — choose `exposure` to clip the
//! highlights or not: [`exposure_for_full_scale`] puts the brightest sample at a given
//! fraction of full scale (`photostereo synth` does).
//!
//! Noise: i.i.d. Gaussian N(0, σ²) added to every sample (background included) after
//! exposure, blur and black level and before quantisation; values may go negative
//! unless quantised.
//! The generator is SplitMix64 + Box–Muller seeded per row from `seed` ([`random`]), so
//! a render is deterministic whatever the number of threads.

mod brdf;
pub mod camera;
pub mod random;
mod render;
pub mod shadow;
mod shapes;

pub use brdf::{shade, Material};
pub use camera::Camera;
pub use shapes::{shape_geometry, Bump, Shape, ShapeKind};

use crate::error::{Error, Result};
use crate::image::{DepthMap, GrayImage, Image, ImageStack, Lights, Mask, NormalMap};
use crate::progress::{NoProgress, Progress};

/// Everything that defines a synthetic scene.
#[derive(Clone, Debug)]
pub struct SceneOptions {
    /// Image width (pixels, ≥ 1).
    pub width: usize,
    /// Image height (pixels, ≥ 1).
    pub height: usize,
    /// The surface (pixel units, centred in the image).
    pub shape: Shape,
    /// The reflectance.
    pub material: Material,
    /// K directional lights (unit directions toward the light; intensities multiply).
    pub lights: Lights,
    /// Ray-march cast shadows (attached shadows are always there).
    pub cast_shadows: bool,
    /// Multiply the diffuse coefficient by a smooth texture in [0.4, 1].
    pub albedo_texture: bool,
    /// Standard deviation of additive Gaussian noise, in units where the Lambertian
    /// white facing the light is 1 (0 = none).
    pub noise_sigma: f32,
    /// How the camera forms the samples: blur, black level, clipping and quantisation
    /// ([`Camera`]; default float samples, sharp, no black level).
    pub camera: Camera,
    /// Seed of the noise and of the albedo texture.
    pub seed: u64,
    /// Global scale e of every radiance (before noise); 1 keeps the physical scale.
    pub exposure: f32,
    /// Value of the pixels outside the mask in every image (0 = black).
    pub background: f32,
}

impl Default for SceneOptions {
    /// 256×256 blob, shiny plastic, 16 default lights, cast shadows, no texture, no
    /// noise, float output (ideal camera), seed 0, exposure 1, black background.
    fn default() -> Self {
        SceneOptions {
            width: 256,
            height: 256,
            shape: Shape::preset(ShapeKind::Blob, 256, 256),
            material: Material::shiny_plastic(),
            lights: default_lights(16),
            cast_shadows: true,
            albedo_texture: false,
            noise_sigma: 0.0,
            camera: Camera::default(),
            seed: 0,
            exposure: 1.0,
            background: 0.0,
        }
    }
}

/// A rendered scene with its ground truth.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The K images (pixel-major), named `001.png`, `002.png`, ...
    pub stack: ImageStack,
    /// The lights used (as in the options).
    pub lights: Lights,
    /// Pixels on the surface.
    pub mask: Mask,
    /// Exact unit normals (`[0, 0, 0]` outside the mask).
    pub normals: NormalMap,
    /// Exact depth (pixels, larger = closer, NaN outside the mask).
    pub depth: DepthMap,
    /// Diffuse albedo per pixel (diffuse coefficient × texture; 0 outside the mask).
    pub albedo: GrayImage,
    /// Number of lights whose cast shadow covers the pixel (facing the light, occluded).
    pub shadowed: Image<u16>,
}

/// K light directions between 15° and 60° from the view axis +z, evenly spread in
/// solid angle: cos θ_i runs linearly from cos 15° to cos 60° (midpoints of K bins) and
/// the azimuth advances by the golden angle (a Fibonacci spiral). Unit intensities.
pub fn default_lights(k: usize) -> Lights {
    let (c_lo, c_hi) = (15f64.to_radians().cos(), 60f64.to_radians().cos());
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let directions = (0..k)
        .map(|i| {
            let t = (i as f64 + 0.5) / k as f64;
            let cz = c_lo + (c_hi - c_lo) * t;
            let sz = (1.0 - cz * cz).sqrt();
            let phi = golden * i as f64;
            [(sz * phi.cos()) as f32, (sz * phi.sin()) as f32, cz as f32]
        })
        .collect();
    Lights::from_directions(directions)
}

/// Analytic gradients (p, q) = (−x/z, −y/z) of the sphere x² + y² + z² = radius² (pixels,
/// centred on the W × H grid, z clamped to ≥ 1 where the grid leaves the sphere): the
/// smooth, non-periodic field the integration benchmarks use (radius 0.8 W covers the
/// grid).
pub fn sphere_cap_gradients(width: usize, height: usize, radius: f64) -> (GrayImage, GrayImage) {
    let grad = |r: usize, c: usize| {
        let (x, y) = crate::image::pixel_to_xy(r, c, width, height);
        let z = (radius * radius - x * x - y * y).max(1.0).sqrt();
        ((-x / z) as f32, (-y / z) as f32)
    };
    (
        GrayImage::from_fn(width, height, |r, c| grad(r, c).0),
        GrayImage::from_fn(width, height, |r, c| grad(r, c).1),
    )
}

/// Render a scene (see the module docs for the image formation).
pub fn render(opts: &SceneOptions) -> Result<Scene> {
    render_with_progress(opts, &NoProgress)
}

/// [`render`], reporting one step per image row to `progress`.
pub fn render_with_progress(opts: &SceneOptions, progress: &dyn Progress) -> Result<Scene> {
    validate(opts)?;
    render::render_scene(opts, progress)
}

/// A calibration sphere of radius `radius` pixels with the same material, lights,
/// noise, quantisation, exposure and background as `opts` (no albedo texture), on a
/// square image of side ⌈2·radius⌉ + 4.
pub fn render_calibration_sphere(opts: &SceneOptions, radius: f64) -> Result<Scene> {
    render(&calibration_sphere_options(opts, radius)?)
}

/// [`peak_radiance`] over the target of `opts` and its calibration sphere of radius
/// `radius` pixels (as [`render_calibration_sphere`] renders it): the brightest sample
/// of both, so that one exposure keeps the highlights of both below full scale.
pub fn peak_radiance_with_sphere(opts: &SceneOptions, radius: f64) -> Result<f32> {
    let sphere = calibration_sphere_options(opts, radius)?;
    Ok(peak_radiance(opts)?.max(peak_radiance(&sphere)?))
}

/// The exposure that puts the brightest sample of the target of `opts` (and of its
/// calibration sphere of radius `sphere` pixels, if any) at the fraction `fill` of full
/// scale, black level included: e = (`fill` − black level) / peak radiance
/// ([`peak_radiance`], an upper bound: blur and cast shadows only lower it). `fill` 1 is
/// a camera "exposed for the brightest highlight"; e is 1 for a black scene.
///
/// Errors: `fill` not above the black level or above 1; the errors of [`peak_radiance`].
pub fn exposure_for_full_scale(opts: &SceneOptions, sphere: Option<f64>, fill: f32) -> Result<f32> {
    let room = fill - opts.camera.black_level;
    if !(room > 0.0 && fill <= 1.0) {
        return Err(Error::invalid(
            format!(
                "brightest sample at {fill} of full scale with a black level of {}",
                opts.camera.black_level
            ),
            "put the brightest sample above the black level and at most at full scale (1)",
        ));
    }
    let peak = match sphere {
        Some(r) => peak_radiance_with_sphere(opts, r)?,
        None => peak_radiance(opts)?,
    };
    Ok(if peak > 0.0 { room / peak } else { 1.0 })
}

/// The scene of [`render_calibration_sphere`].
fn calibration_sphere_options(opts: &SceneOptions, radius: f64) -> Result<SceneOptions> {
    if !(radius.is_finite() && radius > 0.0 && radius < 1e5) {
        return Err(Error::invalid(
            format!("calibration sphere radius {radius}"),
            "use a radius in pixels, > 0 and < 100000",
        ));
    }
    let side = (2.0 * radius).ceil() as usize + 4;
    Ok(SceneOptions {
        width: side,
        height: side,
        shape: Shape::Sphere { radius },
        albedo_texture: false,
        ..opts.clone()
    })
}

/// The largest radiance of the scene before exposure and noise, ignoring cast shadows
/// (an upper bound of the brightest sample): max over mask pixels and lights of
/// i_k·shade(n, l_k, ρ). The CLI divides by it to avoid clipping highlights in 16-bit
/// images. 0 for an empty mask.
pub fn peak_radiance(opts: &SceneOptions) -> Result<f32> {
    validate(opts)?;
    let (_, mask, normals) = shape_geometry(&opts.shape, opts.width, opts.height);
    let texture_max = 1.0; // the albedo texture never exceeds 1
    let mut peak = 0f32;
    for (n, _) in normals.data.iter().zip(&mask.data).filter(|(_, &m)| m) {
        for (l, i) in opts.lights.directions.iter().zip(&opts.lights.intensities) {
            peak = peak.max(shade(&opts.material, *n, *l, texture_max) * i);
        }
    }
    Ok(peak)
}

fn validate(opts: &SceneOptions) -> Result<()> {
    if opts.width == 0 || opts.height == 0 {
        return Err(Error::invalid(
            format!("scene size {}x{}", opts.width, opts.height),
            "width and height must be at least 1 pixel",
        ));
    }
    if opts.width.saturating_mul(opts.height) > 1 << 28 {
        return Err(Error::invalid(
            format!("scene size {}x{}", opts.width, opts.height),
            "use at most 2^28 pixels",
        ));
    }
    let lights = &opts.lights;
    if lights.is_empty() {
        return Err(Error::invalid("scene lights", "give at least one light"));
    }
    if lights.intensities.len() != lights.len() {
        return Err(Error::LightCount {
            what: "scene light intensities".into(),
            expected: lights.len(),
            found: lights.intensities.len(),
            fix: "give one intensity per light direction".into(),
        });
    }
    let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
    let bad_dir = lights
        .directions
        .iter()
        .any(|d| !finite(d) || (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - 1.0).abs() > 1e-3);
    if bad_dir || !finite(&lights.intensities) {
        return Err(Error::invalid(
            "scene lights",
            "directions must be finite unit vectors and intensities finite",
        ));
    }
    let scalars = [opts.noise_sigma, opts.exposure, opts.background];
    if !finite(&scalars) || opts.noise_sigma < 0.0 {
        return Err(Error::invalid(
            "scene noise_sigma / exposure / background",
            "must be finite, noise_sigma >= 0",
        ));
    }
    opts.shape.validate()?;
    opts.camera.validate()?;
    opts.material.validate()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_cap_gradients_are_those_of_the_sphere_and_convex() {
        let (w, h, radius) = (8usize, 6usize, 10.0f64);
        let (p, q) = sphere_cap_gradients(w, h, radius);
        for r in 0..h {
            for c in 0..w {
                let (x, y) = crate::image::pixel_to_xy(r, c, w, h);
                let z = (radius * radius - x * x - y * y).sqrt();
                // z = sqrt(R² − x² − y²): ∂z/∂x = −x/z (pointing away from the centre: convex).
                assert!((*p.get(r, c) as f64 + x / z).abs() < 1e-6);
                assert!((*q.get(r, c) as f64 + y / z).abs() < 1e-6);
            }
        }
    }
}
