//! The per-pixel render loop, parallel over image rows (rayon).

use super::random::albedo_texture;
use super::shadow::Occluder;
use super::{shade, shape_geometry, Scene, SceneOptions};
use crate::error::Result;
use crate::image::{pixel_to_xy, GrayImage, Image, ImageStack};
use crate::progress::Progress;
use rayon::prelude::*;

/// Render `opts` (already validated).
pub(super) fn render_scene(opts: &SceneOptions, progress: &dyn Progress) -> Result<Scene> {
    let (w, h, k) = (opts.width, opts.height, opts.lights.len());
    let (depth, mask, normals) = shape_geometry(&opts.shape, w, h);
    let texture = GrayImage::from_fn(w, h, |r, c| {
        if !*mask.get(r, c) {
            0.0
        } else if opts.albedo_texture {
            let (x, y) = pixel_to_xy(r, c, w, h);
            albedo_texture(x, y, w.max(h) as f64, opts.seed) as f32
        } else {
            1.0
        }
    });
    let diffuse = opts.material.diffuse();
    let albedo = texture.map(|t| t * diffuse);
    let field = Occluder::new(&opts.shape, w, h);
    let mut stack = ImageStack::zeros(w, h, k);
    stack.names = (1..=k).map(|i| format!("{i:03}.png")).collect();
    let mut shadowed = Image::filled(w, h, 0u16);
    progress.start("rendering", h as u64);
    stack
        .data
        .par_chunks_mut(w * k)
        .zip(shadowed.data.par_chunks_mut(w))
        .enumerate()
        .for_each(|(r, (row, shadow_row))| {
            for c in 0..w {
                let px = &mut row[c * k..(c + 1) * k];
                shadow_row[c] = shade_pixel(opts, &field, (r, c), &normals, &texture, px);
            }
            progress.advance(1);
        });
    progress.finish();
    super::camera::develop(&mut stack, &opts.camera, opts.noise_sigma, opts.seed);
    Ok(Scene {
        stack,
        lights: opts.lights.clone(),
        mask,
        normals,
        depth,
        albedo,
        shadowed,
    })
}

/// Fill the K radiances of one pixel; returns how many lights are cast-shadowed.
fn shade_pixel(
    opts: &SceneOptions,
    field: &Occluder,
    (r, c): (usize, usize),
    normals: &crate::image::NormalMap,
    texture: &GrayImage,
    px: &mut [f32],
) -> u16 {
    let n = *normals.get(r, c);
    if n == [0.0; 3] {
        px.fill(opts.background);
        return 0;
    }
    let (material, tex) = (&opts.material, *texture.get(r, c));
    let cast = opts.cast_shadows && !opts.shape.casts_no_shadow();
    let mut count = 0u16;
    for (i, v) in px.iter_mut().enumerate() {
        let l = opts.lights.directions[i];
        let radiance = shade(material, n, l, tex);
        *v = if radiance > 0.0 && cast && field.in_shadow(r, c, l) {
            count = count.saturating_add(1);
            0.0
        } else {
            radiance * opts.lights.intensities[i] * opts.exposure
        };
    }
    count
}
