//! Small owned row-major raster types shared by every stage.
//!
//! * [`Image<T>`]: one value per pixel, row-major, row 0 at the **top**.
//!   Aliases name its uses: [`Mask`], [`NormalMap`], [`DepthMap`], [`GrayImage`].
//! * [`ImageStack`]: K float images of one size, stored **pixel-major** so that the
//!   K samples of one pixel are contiguous (`data[(row * width + col) * k + light]`),
//!   which is what every per-pixel solver wants.
//! * [`Lights`]: K directions (unit, surface → light, camera frame) and K intensities.
//!
//! Pixel (row r, column c) sits at camera coordinates
//! x = c + 0.5 − W/2, y = H/2 − r − 0.5 (see [`pixel_to_xy`]).

use crate::error::{Error, Result};

/// A row-major raster with one `T` per pixel. Row 0 is the top of the picture.
#[derive(Clone, Debug, PartialEq)]
pub struct Image<T> {
    /// Number of columns.
    pub width: usize,
    /// Number of rows.
    pub height: usize,
    /// `width * height` values, row by row from the top.
    pub data: Vec<T>,
}

/// Which pixels belong to the object (`true` = inside).
pub type Mask = Image<bool>;
/// Unit normals (x right, y up, z toward the camera); `[0,0,0]` or NaN where unknown.
pub type NormalMap = Image<[f32; 3]>;
/// Depth in pixel units, larger = closer to the camera, NaN outside the mask.
pub type DepthMap = Image<f32>;
/// One float channel (an intensity image, an albedo map, a confidence map, ...).
pub type GrayImage = Image<f32>;

impl<T: Clone> Image<T> {
    /// An image filled with `value`.
    pub fn filled(width: usize, height: usize, value: T) -> Self {
        Image {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// Wrap a buffer, checking its length.
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Result<Self> {
        if data.len() != width * height {
            return Err(Error::invalid(
                format!(
                    "image buffer of {} values for a {width}x{height} image",
                    data.len()
                ),
                "the buffer must hold width*height values",
            ));
        }
        Ok(Image {
            width,
            height,
            data,
        })
    }

    /// Build an image by evaluating `f(row, col)` at every pixel.
    pub fn from_fn(width: usize, height: usize, mut f: impl FnMut(usize, usize) -> T) -> Self {
        let mut data = Vec::with_capacity(width * height);
        for r in 0..height {
            for c in 0..width {
                data.push(f(r, c));
            }
        }
        Image {
            width,
            height,
            data,
        }
    }

    /// Value at (row, col). Panics when out of range, like slice indexing.
    #[inline]
    pub fn get(&self, row: usize, col: usize) -> &T {
        &self.data[row * self.width + col]
    }

    /// Mutable value at (row, col).
    #[inline]
    pub fn get_mut(&mut self, row: usize, col: usize) -> &mut T {
        &mut self.data[row * self.width + col]
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True when the image has no pixel.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Same width and height as `other`.
    pub fn same_size<U>(&self, other: &Image<U>) -> bool {
        self.width == other.width && self.height == other.height
    }

    /// Apply `f` to every value.
    pub fn map<U>(&self, f: impl FnMut(&T) -> U) -> Image<U> {
        Image {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(f).collect(),
        }
    }
}

impl Mask {
    /// A mask with every pixel inside.
    pub fn full(width: usize, height: usize) -> Self {
        Image::filled(width, height, true)
    }

    /// Number of pixels inside.
    pub fn count(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }

    /// Error unless `self` has the size of `width` x `height`.
    pub fn check_size(&self, width: usize, height: usize, what: &str) -> Result<()> {
        if self.width != width || self.height != height {
            return Err(Error::SizeMismatch {
                what: what.to_string(),
                expected_w: width,
                expected_h: height,
                found_w: self.width,
                found_h: self.height,
                fix: "use a mask of the same size as the images".into(),
            });
        }
        Ok(())
    }

    /// Error when the mask selects no pixel.
    pub fn check_not_empty(&self, what: &str) -> Result<()> {
        if self.count() == 0 {
            return Err(Error::EmptyMask {
                what: what.to_string(),
                fix: "use a mask with non-zero pixels over the object".into(),
            });
        }
        Ok(())
    }
}

/// K float images of one size, pixel-major (one pixel's K samples contiguous).
#[derive(Clone, Debug, PartialEq)]
pub struct ImageStack {
    /// Number of columns.
    pub width: usize,
    /// Number of rows.
    pub height: usize,
    /// Number of images (lights).
    pub k: usize,
    /// `width * height * k` samples: `data[(row * width + col) * k + light]`.
    pub data: Vec<f32>,
    /// Names of the source images in light order (for tables and reports); may be empty.
    pub names: Vec<String>,
}

impl ImageStack {
    /// A stack of zeros.
    pub fn zeros(width: usize, height: usize, k: usize) -> Self {
        ImageStack {
            width,
            height,
            k,
            data: vec![0.0; width * height * k],
            names: Vec::new(),
        }
    }

    /// Interleave K separate images (all of the same size) into a stack.
    pub fn from_images(images: &[GrayImage]) -> Result<Self> {
        let Some(first) = images.first() else {
            return Err(Error::invalid(
                "image stack",
                "at least one image is needed",
            ));
        };
        let (w, h, k) = (first.width, first.height, images.len());
        let mut stack = ImageStack::zeros(w, h, k);
        for (i, img) in images.iter().enumerate() {
            if !img.same_size(first) {
                return Err(Error::SizeMismatch {
                    what: format!("image {i} of the stack"),
                    expected_w: w,
                    expected_h: h,
                    found_w: img.width,
                    found_h: img.height,
                    fix: "all images of a stack must have the same size".into(),
                });
            }
            for (p, v) in img.data.iter().enumerate() {
                stack.data[p * k + i] = *v;
            }
        }
        Ok(stack)
    }

    /// The K samples of pixel (row, col).
    #[inline]
    pub fn pixel(&self, row: usize, col: usize) -> &[f32] {
        let start = (row * self.width + col) * self.k;
        &self.data[start..start + self.k]
    }

    /// The K samples of the pixel with flat index `index = row * width + col`.
    #[inline]
    pub fn pixel_flat(&self, index: usize) -> &[f32] {
        &self.data[index * self.k..(index + 1) * self.k]
    }

    /// Mutable samples of the pixel with flat index `index`.
    #[inline]
    pub fn pixel_flat_mut(&mut self, index: usize) -> &mut [f32] {
        &mut self.data[index * self.k..(index + 1) * self.k]
    }

    /// Copy out image `light` as its own raster.
    pub fn image(&self, light: usize) -> GrayImage {
        Image {
            width: self.width,
            height: self.height,
            data: self
                .data
                .iter()
                .skip(light)
                .step_by(self.k)
                .copied()
                .collect(),
        }
    }

    /// The per-pixel maximum over the K images.
    pub fn max_image(&self) -> GrayImage {
        Image {
            width: self.width,
            height: self.height,
            data: self
                .data
                .chunks_exact(self.k.max(1))
                .map(|px| px.iter().copied().fold(f32::NEG_INFINITY, f32::max))
                .collect(),
        }
    }

    /// Number of pixels per image.
    pub fn pixels(&self) -> usize {
        self.width * self.height
    }
}

/// Light sources: directions (unit vectors from the surface toward the light, camera
/// frame) and relative intensities (one per light, already folded to luminance).
#[derive(Clone, Debug, PartialEq)]
pub struct Lights {
    /// Unit directions, surface → light.
    pub directions: Vec<[f32; 3]>,
    /// Intensity of each light (1.0 when unknown).
    pub intensities: Vec<f32>,
}

impl Lights {
    /// Lights of unit intensity; directions are normalised.
    pub fn from_directions(directions: Vec<[f32; 3]>) -> Self {
        let n = directions.len();
        Lights {
            directions: directions.into_iter().map(normalize).collect(),
            intensities: vec![1.0; n],
        }
    }

    /// Number of lights.
    pub fn len(&self) -> usize {
        self.directions.len()
    }

    /// True when there is no light.
    pub fn is_empty(&self) -> bool {
        self.directions.is_empty()
    }
}

/// Camera coordinates (x right, y up) of the centre of pixel (row, col), in pixels,
/// origin at the image centre.
#[inline]
pub fn pixel_to_xy(row: usize, col: usize, width: usize, height: usize) -> (f64, f64) {
    (
        col as f64 + 0.5 - width as f64 / 2.0,
        height as f64 / 2.0 - row as f64 - 0.5,
    )
}

/// Surface gradient (p, q) = (∂z/∂x, ∂z/∂y) of a unit normal, with n ∝ (−p, −q, 1).
/// Returns `None` when n_z ≤ `min_nz`.
#[inline]
pub fn normal_to_gradient(n: [f32; 3], min_nz: f32) -> Option<(f32, f32)> {
    if n[2].is_nan() || n[2] <= min_nz {
        return None;
    }
    Some((-n[0] / n[2], -n[1] / n[2]))
}

/// Unit normal n = (−p, −q, 1)/‖·‖ of a surface with gradient (p, q) = (∂z/∂x, ∂z/∂y).
#[inline]
pub fn gradient_to_normal(p: f32, q: f32) -> [f32; 3] {
    normalize([-p, -q, 1.0])
}

/// Normalise a 3-vector; zero stays zero.
#[inline]
pub fn normalize(v: [f32; 3]) -> [f32; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if n > 0.0 {
        [v[0] / n, v[1] / n, v[2] / n]
    } else {
        v
    }
}

/// Dot product of two 3-vectors.
#[inline]
pub fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_is_pixel_major_and_round_trips() {
        let a = Image::from_fn(3, 2, |r, c| (r * 3 + c) as f32);
        let b = a.map(|v| v * 10.0);
        let s = ImageStack::from_images(&[a.clone(), b.clone()]).unwrap();
        assert_eq!(s.pixel(1, 2), &[5.0, 50.0]);
        assert_eq!(s.image(0), a);
        assert_eq!(s.image(1), b);
        assert_eq!(s.max_image(), b);
    }

    #[test]
    fn stack_rejects_mixed_sizes() {
        let a = GrayImage::filled(3, 2, 0.0);
        let b = GrayImage::filled(2, 3, 0.0);
        assert!(matches!(
            ImageStack::from_images(&[a, b]),
            Err(Error::SizeMismatch { .. })
        ));
    }

    #[test]
    fn pixel_centres_follow_the_convention() {
        // 4x2 image: top-left pixel centre at (-1.5, 0.5), bottom-right at (1.5, -0.5).
        assert_eq!(pixel_to_xy(0, 0, 4, 2), (-1.5, 0.5));
        assert_eq!(pixel_to_xy(1, 3, 4, 2), (1.5, -0.5));
    }

    #[test]
    fn gradient_sign_convention() {
        // A surface rising to the right (z = 0.5 x) tilts its normal to the left (-x).
        let n = gradient_to_normal(0.5, 0.0);
        assert!(n[0] < 0.0 && n[2] > 0.0);
        let (p, q) = normal_to_gradient(n, 0.0).unwrap();
        assert!((p - 0.5).abs() < 1e-6 && q.abs() < 1e-6);
        assert!(normal_to_gradient([1.0, 0.0, 0.0], 0.0).is_none());
    }
}
