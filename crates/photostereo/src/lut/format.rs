//! The lookup-table file format (version 1).
//!
//! ```text
//! bytes 0..8    magic "PSLUT\0\r\n"
//! bytes 8..12   format version, u32 little-endian (1)
//! bytes 12..16  header length H, u32 little-endian
//! bytes 16..16+H  UTF-8 JSON header: version, k, names (image names in light order),
//!               circle {cx, cy, radius} (pixels, pixel (r, c) centre at (c+.5, r+.5)),
//!               material, rim, smooth (blur applied, px),
//!               window {col0, row0, width, height}, sample_format
//! then          width × height × k samples, f32 little-endian, pixel-major
//!               (the sphere images on the window around the circle)
//! ```
//!
//! The entries (tuples, normals, pixels) are derived from the window on loading, so a
//! file cannot hold entries that disagree with its images.

use super::table::{Table, Window};
use crate::error::{Error, Result};
use crate::image::ImageStack;
use crate::sphere::Circle;
use serde::{Deserialize, Serialize};

/// File signature.
pub const MAGIC: &[u8; 8] = b"PSLUT\0\r\n";
/// The version this code writes (and the newest it reads).
pub const VERSION: u32 = 1;

#[derive(Serialize, Deserialize)]
struct Header {
    version: u32,
    k: usize,
    names: Vec<String>,
    circle: CircleJson,
    material: String,
    rim: f64,
    #[serde(default)]
    smooth: f64,
    window: WindowJson,
    sample_format: String,
}

#[derive(Serialize, Deserialize)]
struct CircleJson {
    cx: f64,
    cy: f64,
    radius: f64,
}

#[derive(Serialize, Deserialize)]
struct WindowJson {
    col0: usize,
    row0: usize,
    width: usize,
    height: usize,
}

fn bad(message: impl Into<String>) -> Error {
    Error::invalid(
        format!("lookup table data: {}", message.into()),
        "give a table written by `photostereo calibrate` (rebuild it if it is damaged)",
    )
}

impl Table {
    /// Serialise the table (see the module docs for the layout).
    pub fn to_bytes(&self) -> Vec<u8> {
        let ws = &self.window.stack;
        let header = Header {
            version: VERSION,
            k: self.k,
            names: self.names.clone(),
            circle: CircleJson {
                cx: self.circle.cx,
                cy: self.circle.cy,
                radius: self.circle.radius,
            },
            material: self.material.clone(),
            rim: self.rim,
            smooth: self.smooth,
            window: WindowJson {
                col0: self.window.col0,
                row0: self.window.row0,
                width: ws.width,
                height: ws.height,
            },
            sample_format: "f32le".into(),
        };
        let json = serde_json::to_vec(&header).unwrap_or_default();
        let mut out = Vec::with_capacity(16 + json.len() + ws.data.len() * 4);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(&json);
        for v in &ws.data {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// Read a table written by [`Table::to_bytes`]; errors name what is wrong.
    pub fn from_bytes(bytes: &[u8]) -> Result<Table> {
        if bytes.len() < 16 || &bytes[..8] != MAGIC {
            return Err(bad("not a photostereo lookup table (bad signature)"));
        }
        let word = |at: usize| {
            u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
        };
        let version = word(8);
        if version == 0 || version > VERSION {
            return Err(bad(format!(
                "format version {version}, this program reads up to {VERSION}; update photostereo"
            )));
        }
        let hlen = word(12) as usize;
        let body = bytes
            .get(16..16 + hlen)
            .ok_or_else(|| bad("truncated header"))?;
        let h: Header =
            serde_json::from_slice(body).map_err(|e| bad(format!("bad header: {e}")))?;
        if h.sample_format != "f32le" {
            return Err(bad(format!("unknown sample format '{}'", h.sample_format)));
        }
        if h.k < super::table::MIN_LIGHTS || (!h.names.is_empty() && h.names.len() != h.k) {
            return Err(bad(format!("{} lights with {} names", h.k, h.names.len())));
        }
        let (w, hh) = (h.window.width, h.window.height);
        if w < 2 || hh < 2 {
            return Err(bad(format!("window of {w}x{hh} pixels")));
        }
        let count = w
            .checked_mul(hh)
            .and_then(|n| n.checked_mul(h.k))
            .ok_or_else(|| bad("window too large"))?;
        let data = &bytes[16 + hlen..];
        if data.len() != count * 4 {
            return Err(bad(format!(
                "{} bytes of samples, expected {} ({w}x{hh}x{})",
                data.len(),
                count * 4,
                h.k
            )));
        }
        let samples: Vec<f32> = data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let stack = ImageStack {
            width: w,
            height: hh,
            k: h.k,
            data: samples,
            names: Vec::new(),
        };
        let circle = Circle {
            cx: h.circle.cx,
            cy: h.circle.cy,
            radius: h.circle.radius,
        };
        let window = Window {
            col0: h.window.col0,
            row0: h.window.row0,
            stack,
        };
        let mut table = Table::from_parts(h.names, circle, h.material, h.rim, window)?;
        table.smooth = h.smooth;
        Ok(table)
    }
}
