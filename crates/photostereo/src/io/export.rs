//! Normal maps and depth for other tools: a 16-bit tangent-space style normal map in the
//! OpenGL or DirectX convention, and float32 TIFFs of the normals and the depth.
//!
//! The crate's normals are in camera coordinates with y **up**: encoded as
//! c = (n + 1)/2 they already form an OpenGL-convention ("green up", Y+) normal map, the
//! one Blender, Maya, Unity, Godot and three.js read. DirectX-convention tools ("green
//! down", Y−: Unreal Engine, 3ds Max, CryEngine) need the green channel flipped. Pixels
//! outside the mask get the flat normal (0, 0, 1), which such tools treat as "no relief".

use std::io::Cursor;
use std::path::Path;

use tiff::encoder::{colortype, TiffEncoder};

use super::write_atomic;
use crate::error::{Error, Result};
use crate::image::{DepthMap, Mask, NormalMap};

/// Which way the green channel of a normal map points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalMapStyle {
    /// Green up (Y+): G = (n_y + 1)/2, the crate's own convention.
    OpenGl,
    /// Green down (Y−): G = (1 − n_y)/2.
    DirectX,
}

impl NormalMapStyle {
    /// `opengl` or `directx` (also `gl`, `dx`), case-insensitive.
    pub fn from_name(name: &str) -> Result<Self> {
        match name.to_ascii_lowercase().as_str() {
            "opengl" | "gl" => Ok(NormalMapStyle::OpenGl),
            "directx" | "dx" => Ok(NormalMapStyle::DirectX),
            _ => Err(Error::invalid(
                format!("normal-map convention '{name}'"),
                "use opengl (green up: Blender, Unity) or directx (green down: Unreal, 3ds Max)",
            )),
        }
    }
}

/// Write `normals` as a 16-bit RGB PNG normal map in `style`; pixels outside `mask` (or
/// without a unit normal) are the flat normal (0, 0, 1).
pub fn write_normal_map_png(
    path: &Path,
    normals: &NormalMap,
    mask: &Mask,
    style: NormalMapStyle,
) -> Result<()> {
    mask.check_size(normals.width, normals.height, "mask of the normal map")?;
    let flip = style == NormalMapStyle::DirectX;
    let mut data = Vec::with_capacity(normals.len() * 3);
    for (n, &inside) in normals.data.iter().zip(&mask.data) {
        let valid = inside && n.iter().all(|v| v.is_finite()) && *n != [0.0; 3];
        let mut v = if valid { *n } else { [0.0, 0.0, 1.0] };
        if flip {
            v[1] = -v[1];
        }
        data.extend(v.map(|x| (((x + 1.0) * 0.5).clamp(0.0, 1.0) * 65535.0).round() as u16));
    }
    super::raster::save_png::<image::Rgb<u16>>(path, normals.width, normals.height, data)
}

/// Write `normals` as a float32 RGB TIFF (n_x, n_y, n_z in the crate's camera frame, as
/// in `normals.npy`).
pub fn write_normals_tiff(path: &Path, normals: &NormalMap) -> Result<()> {
    let data: Vec<f32> = normals.data.iter().flatten().copied().collect();
    write_tiff::<colortype::RGB32Float>(path, normals.width, normals.height, &data)
}

/// Write `depth` as a float32 one-channel TIFF (NaN outside the mask, as in `depth.npy`).
pub fn write_depth_tiff(path: &Path, depth: &DepthMap) -> Result<()> {
    write_tiff::<colortype::Gray32Float>(path, depth.width, depth.height, &depth.data)
}

fn write_tiff<C: colortype::ColorType<Inner = f32>>(
    path: &Path,
    width: usize,
    height: usize,
    data: &[f32],
) -> Result<()> {
    let too_big = || {
        Error::invalid(
            format!("{}: a {width}x{height} TIFF", path.display()),
            "TIFF images are at most 2^32 - 1 pixels wide and high",
        )
    };
    let (w, h) = (
        u32::try_from(width).map_err(|_| too_big())?,
        u32::try_from(height).map_err(|_| too_big())?,
    );
    // the encoder seeks: encode in memory, then write the file atomically
    let mut bytes = Cursor::new(Vec::new());
    TiffEncoder::new(&mut bytes)
        .and_then(|mut enc| enc.write_image::<C>(w, h, data))
        .map_err(|e| {
            Error::invalid(
                format!("{}: encoding the TIFF", path.display()),
                e.to_string(),
            )
        })?;
    let bytes = bytes.into_inner();
    write_atomic(path, |out| {
        out.write_all(&bytes).map_err(|e| Error::io(path, e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    #[test]
    fn directx_flips_green_and_the_background_is_flat() {
        let n = Image::from_vec(2, 1, vec![[0.6f32, 0.8, 0.0], [0.0, 1.0, 0.0]]).unwrap();
        let mut m = Mask::full(2, 1);
        m.data[1] = false;
        let mut greens = Vec::new();
        let dir = tempfile::tempdir().unwrap();
        for style in [NormalMapStyle::OpenGl, NormalMapStyle::DirectX] {
            let p = dir.path().join(format!("{style:?}.png"));
            write_normal_map_png(&p, &n, &m, style).unwrap();
            let img = image::open(&p).unwrap().to_rgb16();
            let [r, g, b] = img.get_pixel(0, 0).0;
            assert!(r.abs_diff(52428) <= 1 && b.abs_diff(32768) <= 1, "{r} {b}");
            greens.push(g);
            assert_eq!(img.get_pixel(1, 0).0, [32768, 32768, 65535]);
        }
        // n_y = 0.8: green 0.9 of full scale up (OpenGL), 0.1 down (DirectX)
        assert!(greens[0].abs_diff(58982) <= 1, "{greens:?}");
        assert!(greens[1].abs_diff(6553) <= 1, "{greens:?}");
        assert!(NormalMapStyle::from_name("DX").is_ok());
        assert!(NormalMapStyle::from_name("vulkan").is_err());
    }

    #[test]
    fn float_tiffs_read_back_exactly() {
        let n = Image::from_fn(3, 2, |r, c| [r as f32 * 0.1, c as f32 * 0.2, 0.5]);
        let d = Image::from_vec(2, 1, vec![1.25f32, f32::NAN]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let (pn, pd) = (dir.path().join("n.tif"), dir.path().join("d.tif"));
        write_normals_tiff(&pn, &n).unwrap();
        write_depth_tiff(&pd, &d).unwrap();
        let read = |p: &Path| {
            let mut dec = tiff::decoder::Decoder::new(std::fs::File::open(p).unwrap()).unwrap();
            match dec.read_image().unwrap() {
                tiff::decoder::DecodingResult::F32(v) => (dec.dimensions().unwrap(), v),
                _ => panic!("not float32"),
            }
        };
        let (dims, v) = read(&pn);
        assert_eq!(dims, (3, 2));
        assert_eq!(v, n.data.iter().flatten().copied().collect::<Vec<_>>());
        let (dims, v) = read(&pd);
        assert_eq!(dims, (2, 1));
        assert_eq!(v[0], 1.25);
        assert!(v[1].is_nan());
    }

    #[test]
    fn empty_maps_are_errors_or_files_not_panics() {
        let n: NormalMap = Image::filled(0, 0, [0.0; 3]);
        let dir = tempfile::tempdir().unwrap();
        let _ = write_normals_tiff(&dir.path().join("e.tif"), &n);
        let _ = write_normal_map_png(
            &dir.path().join("e.png"),
            &n,
            &Mask::full(0, 0),
            NormalMapStyle::OpenGl,
        );
        assert!(write_normal_map_png(
            &dir.path().join("x.png"),
            &n,
            &Mask::full(1, 1),
            NormalMapStyle::OpenGl
        )
        .is_err());
    }
}
