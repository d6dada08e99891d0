//! A picture for a person to check the detected circle at a glance.

use super::Circle;
use crate::image::{GrayImage, Image};
use crate::picture::{png_bytes, Deflate};

/// The maximum image (contrast-stretched: v ↦ ln(1 + 200 v/w)/ln(201) with w its
/// 99.5th percentile, so that dim rims of dark spheres stay visible) as RGB, with the circle
/// drawn in red and a green cross at its centre.
pub fn overlay(max_image: &GrayImage, circle: &Circle) -> Image<[u8; 3]> {
    let white = percentile(&max_image.data, 0.995).max(f32::MIN_POSITIVE);
    let mut out = max_image.map(|&v| {
        let g = (1.0 + 200.0 * (v / white).clamp(0.0, 1.0)).ln() / 201f32.ln();
        let g = if g.is_finite() {
            (g * 255.0).round() as u8
        } else {
            0
        };
        [g, g, g]
    });
    let steps = (circle.radius * std::f64::consts::TAU * 3.0)
        .ceil()
        .max(16.0) as usize;
    for i in 0..steps {
        let t = i as f64 / steps as f64 * std::f64::consts::TAU;
        put(
            &mut out,
            circle.cx + circle.radius * t.cos(),
            circle.cy + circle.radius * t.sin(),
            [255, 0, 0],
        );
    }
    let arm = (circle.radius / 10.0).clamp(3.0, 20.0);
    let n = (arm * 4.0) as usize;
    for i in 0..=n {
        let s = -arm + 2.0 * arm * i as f64 / n as f64;
        put(&mut out, circle.cx + s, circle.cy, [0, 255, 0]);
        put(&mut out, circle.cx, circle.cy + s, [0, 255, 0]);
    }
    out
}

fn put(img: &mut Image<[u8; 3]>, x: f64, y: f64, rgb: [u8; 3]) {
    if x >= 0.0 && y >= 0.0 && (x as usize) < img.width && (y as usize) < img.height {
        *img.get_mut(y as usize, x as usize) = rgb;
    }
}

fn percentile(values: &[f32], p: f64) -> f32 {
    let mut v: Vec<f32> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 1.0;
    }
    let k = ((v.len() - 1) as f64 * p).round() as usize;
    let (_, kth, _) = v.select_nth_unstable_by(k, f32::total_cmp);
    *kth
}

/// Encode an RGB picture (such as an [`overlay`]) as PNG bytes, for
/// `io::write_bytes` (the library itself writes no files outside `io`).
pub fn encode_png(img: &Image<[u8; 3]>) -> crate::Result<Vec<u8>> {
    let raw: Vec<u8> = img.data.iter().flatten().copied().collect();
    png_bytes::<image::Rgb<u8>>(img.width, img.height, raw, Deflate::Default).map_err(|e| {
        crate::Error::invalid(format!("overlay picture {}x{}", img.width, img.height), e)
    })
}
