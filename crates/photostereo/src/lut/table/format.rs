//! The lookup-table file format (version 2): a checked frame around the table's content.
//!
//! ```text
//! frame (this file's `frame` / `unframe`; independent of what a table stores)
//! bytes 0..8    magic "PSLUT\0\r\n"
//! bytes 8..12   format version, u32 little-endian (2)
//! bytes 12..20  content length N, u64 little-endian
//! bytes 20..24  CRC-32 (IEEE, `crc32fast`) of the N content bytes, u32 little-endian
//! bytes 24..24+N  content; nothing may follow
//!
//! content (`encode_content` / `decode_content`)
//! bytes 0..4    header length H, u32 little-endian
//! bytes 4..4+H  UTF-8 JSON header: version, k, names (image names in light order),
//!               circle {cx, cy, radius} (pixels, pixel (r, c) centre at (c+.5, r+.5)),
//!               material, rim, smooth (blur applied, px), rim_blur (the images'
//!               blur measured on the rim, px; optional),
//!               window {col0, row0, width, height}, sample_format,
//!               outline {tuples, normals} (the sphere's own outline as photographed,
//!               `super::OutlineSample`; optional, absent in files written before it
//!               was kept, and ignored by the readers of those days)
//! then          width × height × k samples, f32 little-endian, pixel-major
//!               (the sphere images on the window around the circle)
//! ```
//!
//! Reading checks, in order: the magic, the version (a newer one is refused with its
//! number; version 1, which had no checksum, is refused with the advice to re-run
//! `photostereo calibrate`), the content length against the file's length, the
//! checksum (a mismatch: "damaged or not a photostereo table"), then the content
//! itself (sizes against the samples present, finite samples, a sound circle).
//!
//! The entries (tuples, normals, pixels) are derived from the window on loading, so a
//! file cannot hold entries that disagree with its images.

use super::{OutlineSample, Table, Window};
use crate::error::{Error, Result};
use crate::image::ImageStack;
use crate::sphere::Circle;
use serde::{Deserialize, Serialize};

/// File signature.
pub const MAGIC: &[u8; 8] = b"PSLUT\0\r\n";
/// The version this code writes (and the only one it reads).
pub const VERSION: u32 = 2;
/// Length of the frame before the content: magic, version, length, checksum.
pub const FRAME_LEN: usize = 24;

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
    /// Absent in files written before it was kept (read as not measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rim_blur: Option<f64>,
    window: WindowJson,
    sample_format: String,
    /// Absent in files written before it was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    outline: Option<OutlineJson>,
}

#[derive(Serialize, Deserialize)]
struct OutlineJson {
    tuples: Vec<f32>,
    normals: Vec<[f32; 3]>,
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

/// Wrap `content` in the frame: magic, version, length and checksum.
pub fn frame(content: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(FRAME_LEN + content.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(content.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(content).to_le_bytes());
    out.extend_from_slice(content);
    out
}

/// The content of a framed file, after checking magic, version, length and checksum.
pub fn unframe(bytes: &[u8]) -> Result<&[u8]> {
    let damaged = |why: String| bad(format!("damaged or not a photostereo table ({why})"));
    if bytes.len() < 12 || &bytes[..8] != MAGIC {
        return Err(damaged("no table signature".into()));
    }
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if version == 1 {
        return Err(Error::invalid(
            "lookup table data: format version 1, which has no checksum",
            "re-run `photostereo calibrate` to write the table again (format version 2)",
        ));
    }
    if version != VERSION {
        return Err(Error::invalid(
            format!("lookup table data: format version {version}"),
            format!("this program reads version {VERSION}; update photostereo"),
        ));
    }
    let word = |at: usize, n: usize| bytes.get(at..at + n);
    let (Some(len), Some(crc)) = (word(12, 8), word(20, 4)) else {
        return Err(damaged(format!("{} bytes, truncated frame", bytes.len())));
    };
    let len = u64::from_le_bytes(len.try_into().unwrap_or_default());
    let crc = u32::from_le_bytes(crc.try_into().unwrap_or_default());
    let held = (bytes.len() - FRAME_LEN) as u64;
    if len != held {
        return Err(damaged(format!(
            "the frame claims {len} bytes of content, the file holds {held}"
        )));
    }
    let content = &bytes[FRAME_LEN..];
    let actual = crc32fast::hash(content);
    if actual != crc {
        return Err(damaged(format!(
            "checksum {actual:08x}, the file says {crc:08x}"
        )));
    }
    Ok(content)
}

impl Table {
    /// Serialise the table (see the module docs for the layout).
    pub fn to_bytes(&self) -> Vec<u8> {
        frame(&encode_content(self))
    }

    /// Read a table written by [`Table::to_bytes`]; errors name what is wrong.
    pub fn from_bytes(bytes: &[u8]) -> Result<Table> {
        decode_content(unframe(bytes)?)
    }
}

/// The table's content: JSON header length, header, samples.
pub fn encode_content(table: &Table) -> Vec<u8> {
    let ws = &table.window.stack;
    let header = Header {
        version: VERSION,
        k: table.k,
        names: table.names.clone(),
        circle: CircleJson {
            cx: table.circle.cx,
            cy: table.circle.cy,
            radius: table.circle.radius,
        },
        material: table.material.clone(),
        rim: table.rim,
        smooth: table.smooth,
        rim_blur: table.rim_blur.filter(|b| b.is_finite()),
        window: WindowJson {
            col0: table.window.col0,
            row0: table.window.row0,
            width: ws.width,
            height: ws.height,
        },
        sample_format: "f32le".into(),
        outline: table.outline.as_ref().map(|o| OutlineJson {
            tuples: o.tuples.clone(),
            normals: o.normals.clone(),
        }),
    };
    let json = serde_json::to_vec(&header).unwrap_or_default();
    let mut out = Vec::with_capacity(4 + json.len() + ws.data.len() * 4);
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&json);
    for v in &ws.data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Read the content written by [`encode_content`], checking every size against the
/// bytes present before allocating.
pub fn decode_content(bytes: &[u8]) -> Result<Table> {
    let hlen = bytes
        .get(..4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
        .ok_or_else(|| bad("truncated header"))?;
    let body = 4usize
        .checked_add(hlen)
        .and_then(|end| bytes.get(4..end))
        .ok_or_else(|| bad(format!("the header claims {hlen} bytes, past the end")))?;
    let h: Header = serde_json::from_slice(body).map_err(|e| bad(format!("bad header: {e}")))?;
    if h.sample_format != "f32le" {
        return Err(bad(format!("unknown sample format '{}'", h.sample_format)));
    }
    if h.k < super::MIN_LIGHTS || (!h.names.is_empty() && h.names.len() != h.k) {
        return Err(bad(format!("{} lights with {} names", h.k, h.names.len())));
    }
    let (w, hh) = (h.window.width, h.window.height);
    if w < 2 || hh < 2 {
        return Err(bad(format!("window of {w}x{hh} pixels")));
    }
    let side = crate::limits::MAX_SIDE as usize;
    let (col0, row0) = (h.window.col0, h.window.row0);
    if col0.saturating_add(w) > side || row0.saturating_add(hh) > side {
        return Err(bad(format!(
            "window of {w}x{hh} pixels at ({col0}, {row0}), beyond {side} pixels"
        )));
    }
    let bytes_claimed = w
        .checked_mul(hh)
        .and_then(|n| n.checked_mul(h.k))
        .and_then(|n| n.checked_mul(4));
    let data = &bytes[4 + hlen..];
    if bytes_claimed != Some(data.len()) {
        return Err(bad(format!(
            "{} bytes of samples, the header claims {w}x{hh}x{} f32 samples",
            data.len(),
            h.k
        )));
    }
    let samples: Vec<f32> = data
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    if samples.iter().any(|v| !v.is_finite()) {
        return Err(bad("a sample is not a finite number"));
    }
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
    let outline = h.outline.map(|o| outline_sample(o, h.k)).transpose()?;
    let mut table = Table::from_parts(h.names, circle, h.material, h.rim, window)?;
    table.smooth = h.smooth;
    table.rim_blur = h.rim_blur.filter(|b| b.is_finite() && *b >= 0.0);
    table.outline = outline;
    Ok(table)
}

/// The header's outline sample, checked: K samples per normal, all finite, at most
/// [`super::MAX_OUTLINE_SAMPLE`] pixels.
fn outline_sample(o: OutlineJson, k: usize) -> Result<OutlineSample> {
    let n = o.normals.len();
    if n > super::MAX_OUTLINE_SAMPLE || o.tuples.len() != n * k {
        return Err(bad(format!(
            "outline sample of {} values for {n} pixels under {k} lights",
            o.tuples.len()
        )));
    }
    let mut values = o.tuples.iter().chain(o.normals.iter().flatten());
    if values.any(|v| !v.is_finite()) {
        return Err(bad("an outline sample is not a finite number"));
    }
    Ok(OutlineSample {
        tuples: o.tuples,
        normals: o.normals,
    })
}
