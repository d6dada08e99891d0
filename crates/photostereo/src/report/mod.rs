//! A self-contained HTML report of one reconstruction.
//!
//! [`Report`] collects the products of a run — input images, normal map, albedo,
//! confidence, depth, error maps against ground truth, interreflection plots, a table of
//! figures and the reconstructed surface — and [`Report::to_html`] turns them into **one
//! HTML string** with everything inlined: pictures as base64 PNG `data:` URIs (encoded in
//! memory with the `image` crate), the 3-D viewer (three.js r160, vendored under
//! `assets/`, MIT) as `data:` module URLs behind an import map, the mesh as base64 typed
//! arrays. The page loads nothing from anywhere (its Content-Security-Policy forbids it),
//! so it can be mailed or archived as is. Writing it to disk is the caller's business
//! (`io::write_atomic`).
//!
//! The page tells a browser-driving test how it went: `<html data-viewer="ready">` once
//! the first frame of the 3-D view is drawn (`failed` otherwise), and
//! `data-errors="N"` with the messages in `#ps-errors` when scripts reported errors.
//!
//! ```
//! use photostereo::image::Image;
//! use photostereo::report::Report;
//! let depth = Image::from_fn(32, 32, |r, c| (r as f32 - 16.0).hypot(c as f32 - 16.0).min(12.0));
//! let mut report = Report::new("bowl");
//! report.depth(&depth).figure("depth range", "12 px").surface(&depth, None).unwrap();
//! let html = report.to_html().unwrap();
//! assert!(html.starts_with("<!DOCTYPE html>") && !html.contains("http://"));
//! ```

mod html;
mod polar;
pub mod relight;
pub use crate::picture as raster;
pub mod viewer;

use crate::error::{Error, Result};
use crate::image::{DepthMap, GrayImage, ImageStack, Mask, NormalMap};
use crate::picture::{ColorMap, Rgb};
pub use viewer::{MeshParts, ViewerMesh, MAX_TRIANGLES};

/// Largest side, in pixels, of a map embedded in the report (larger maps are box-averaged).
pub const MAX_MAP_SIDE: usize = 1024;
/// Largest side of an input thumbnail.
pub const THUMB_SIDE: usize = 128;

/// Where a picture goes in the page.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// Normal map, albedo, confidence, depth.
    Maps,
    /// Error maps against ground truth.
    Errors,
    /// Interreflection removal: convergence plot, profiles.
    Interreflections,
    /// Light calibration: the lights' directions, the sphere's circle.
    Lights,
}

/// A legend under a colour-mapped picture: the colour bar and the values at its ends.
#[derive(Clone, Debug, PartialEq)]
struct Legend {
    cmap: ColorMap,
    lo: String,
    hi: String,
}

/// One picture with its caption.
#[derive(Clone, Debug, PartialEq)]
enum Picture {
    Raster(Rgb),
    Png(Vec<u8>),
    /// Inline SVG markup made by this module.
    Svg(String),
}

#[derive(Clone, Debug, PartialEq)]
struct Figure {
    section: Section,
    caption: String,
    picture: Picture,
    legend: Option<Legend>,
}

/// Builder of one HTML report (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct Report {
    title: String,
    subtitle: String,
    inputs: Vec<(String, Rgb)>,
    figures: Vec<Figure>,
    table: Vec<(String, String)>,
    warnings: Vec<String>,
    mesh: Option<ViewerMesh>,
    relight: Option<relight::RelightMaps>,
}

impl Report {
    /// An empty report with a title (e.g. the dataset's name).
    pub fn new(title: impl Into<String>) -> Self {
        Report {
            title: title.into(),
            ..Report::default()
        }
    }

    /// A line under the title (method, date, command ...).
    pub fn subtitle(&mut self, text: impl Into<String>) -> &mut Self {
        self.subtitle = text.into();
        self
    }

    /// The K input images as a strip of thumbnails, on one brightness scale, named after
    /// `stack.names` (or numbered).
    pub fn inputs(&mut self, stack: &ImageStack) -> &mut Self {
        let thumbs = raster::stack_thumbnails(stack, THUMB_SIDE);
        self.inputs = thumbs
            .into_iter()
            .enumerate()
            .map(|(i, t)| {
                let name = stack
                    .names
                    .get(i)
                    .cloned()
                    .unwrap_or_else(|| format!("image {i}"));
                (name, t)
            })
            .collect();
        self
    }

    /// The normal map, coloured c = (n + 1)/2.
    pub fn normals(&mut self, normals: &NormalMap, mask: Option<&Mask>) -> Result<&mut Self> {
        check_mask(
            mask,
            normals.width,
            normals.height,
            "mask of the normal map",
        )?;
        let rgb = raster::normals_rgb(normals, mask);
        self.push(Section::Maps, "normals, colour = (n + 1)/2", rgb, None);
        Ok(self)
    }

    /// A scalar map (albedo, confidence, ...) coloured between its 1st and 99th percentile.
    pub fn scalar(
        &mut self,
        caption: &str,
        img: &GrayImage,
        mask: Option<&Mask>,
        cmap: ColorMap,
    ) -> Result<&mut Self> {
        check_mask(mask, img.width, img.height, caption)?;
        let (lo, hi) = raster::robust_range(img, mask);
        let rgb = raster::scalar_rgb(img, mask, lo, hi, cmap);
        let legend = (cmap != ColorMap::Gray).then(|| Legend {
            cmap,
            lo: format!("{lo:.3}"),
            hi: format!("{hi:.3}"),
        });
        self.push(Section::Maps, caption, rgb, legend);
        Ok(self)
    }

    /// The albedo in grey (black = 0, white = its 99th percentile: [`raster::albedo_picture`]).
    pub fn albedo(&mut self, albedo: &GrayImage, mask: Option<&Mask>) -> Result<&mut Self> {
        check_mask(mask, albedo.width, albedo.height, "mask of the albedo")?;
        let (rgb, hi) = raster::albedo_picture(albedo, mask);
        self.push(
            Section::Maps,
            &format!("albedo (white = {hi:.3})"),
            rgb,
            None,
        );
        Ok(self)
    }

    /// A signed map (curvature) in cool–warm, symmetric: −`limit` blue → 0 grey →
    /// +`limit` red ([`raster::signed_picture`]).
    pub fn signed(
        &mut self,
        caption: &str,
        img: &GrayImage,
        mask: Option<&Mask>,
        limit: f32,
        unit: &str,
    ) -> Result<&mut Self> {
        check_mask(mask, img.width, img.height, caption)?;
        let rgb = raster::signed_picture(img, mask, limit);
        let legend = Legend {
            cmap: ColorMap::CoolWarm,
            lo: format!("≤ −{limit:.3} {unit}"),
            hi: format!("≥ +{limit:.3} {unit}"),
        };
        self.push(Section::Maps, caption, rgb, Some(legend));
        Ok(self)
    }

    /// Depth in false colour (viridis, far → near: [`raster::depth_picture`]), NaN outside
    /// the mask.
    pub fn depth(&mut self, depth: &DepthMap) -> &mut Self {
        let (rgb, (lo, hi)) = raster::depth_picture(depth, None);
        let legend = Legend {
            cmap: ColorMap::Viridis,
            lo: format!("{lo:.1} px (far)"),
            hi: format!("{hi:.1} px (near)"),
        };
        self.push(Section::Maps, "depth", rgb, Some(legend));
        self
    }

    /// An error map against ground truth (e.g. angular error in degrees), 0 → black,
    /// `max` → white-yellow (inferno), values above `max` saturate.
    pub fn error_map(
        &mut self,
        caption: &str,
        err: &GrayImage,
        mask: Option<&Mask>,
        max: f32,
        unit: &str,
    ) -> Result<&mut Self> {
        check_mask(mask, err.width, err.height, caption)?;
        let rgb = raster::scalar_rgb(err, mask, 0.0, max, ColorMap::Inferno);
        let legend = Legend {
            cmap: ColorMap::Inferno,
            lo: format!("0 {unit}"),
            hi: format!("≥ {max} {unit}"),
        };
        self.push(Section::Errors, caption, rgb, Some(legend));
        Ok(self)
    }

    /// A picture made by the caller (a plot), as PNG bytes.
    pub fn png(&mut self, section: Section, caption: &str, png: Vec<u8>) -> Result<&mut Self> {
        if !png.starts_with(b"\x89PNG\r\n\x1a\n") {
            return Err(Error::invalid(
                format!("picture '{caption}' for the report"),
                "give PNG bytes (they start with the PNG signature)",
            ));
        }
        self.figures.push(Figure {
            section,
            caption: caption.into(),
            picture: Picture::Png(png),
            legend: None,
        });
        Ok(self)
    }

    /// A warning shown in a box at the top of the page (how far to trust the result, and why).
    pub fn warning(&mut self, text: impl Into<String>) -> &mut Self {
        self.warnings.push(text.into());
        self
    }

    /// The warnings given so far.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The light directions as a polar plot seen from the camera: angle from the view axis
    /// outward (rings at 30°, 60°, 90°), azimuth around (x right, y up); one numbered dot per
    /// light, in image order.
    pub fn lights(&mut self, caption: &str, lights: &crate::image::Lights) -> &mut Self {
        self.figures.push(Figure {
            section: Section::Lights,
            caption: caption.into(),
            picture: Picture::Svg(polar::lights_svg(&lights.directions)),
            legend: None,
        });
        self
    }

    /// One row of the table of figures.
    pub fn figure(&mut self, key: impl Into<String>, value: impl Into<String>) -> &mut Self {
        self.table.push((key.into(), value.into()));
        self
    }

    /// The 3-D view of a depth map (NaN = outside), meshed with a stride that keeps it under
    /// [`MAX_TRIANGLES`]; `albedo` colours the vertices.
    pub fn surface(&mut self, depth: &DepthMap, albedo: Option<&GrayImage>) -> Result<&mut Self> {
        let mesh = ViewerMesh::from_depth(depth, albedo, MAX_TRIANGLES)?;
        self.mesh = Some(mesh);
        Ok(self)
    }

    /// The 3-D view of a mesh made by the caller (at most [`MAX_TRIANGLES`] triangles).
    pub fn mesh(&mut self, parts: MeshParts<'_>) -> Result<&mut Self> {
        self.mesh = Some(ViewerMesh::from_parts(parts)?);
        Ok(self)
    }

    /// The relighting view of `normals` and `albedo` inside `mask` (see [`relight`]).
    pub fn relight(
        &mut self,
        normals: &NormalMap,
        albedo: Option<&GrayImage>,
        mask: Option<&Mask>,
    ) -> Result<&mut Self> {
        self.relight = Some(relight::RelightMaps::new(normals, albedo, mask)?);
        Ok(self)
    }

    /// The mesh of the 3-D view, if any.
    pub fn viewer_mesh(&self) -> Option<&ViewerMesh> {
        self.mesh.as_ref()
    }

    /// The whole page.
    pub fn to_html(&self) -> Result<String> {
        html::page(self)
    }

    fn push(&mut self, section: Section, caption: &str, rgb: Rgb, legend: Option<Legend>) {
        let picture = raster::shrink(&rgb, MAX_MAP_SIDE);
        // a big capture's map is shown smaller than it is: the caption says so
        let caption = if picture.width < rgb.width {
            format!(
                "{caption} (shown at {}×{}, box averages of the {}×{} map)",
                picture.width, picture.height, rgb.width, rgb.height
            )
        } else {
            caption.to_string()
        };
        self.figures.push(Figure {
            section,
            caption,
            picture: Picture::Raster(picture),
            legend,
        });
    }
}

fn check_mask(mask: Option<&Mask>, width: usize, height: usize, what: &str) -> Result<()> {
    match mask {
        Some(m) => m.check_size(width, height, what),
        None => Ok(()),
    }
}
