//! The interactive 3-D view: a triangle mesh embedded in the page and drawn by three.js.
//!
//! three.js (r160, MIT) and its `OrbitControls` are vendored under `assets/` and compiled in
//! with `include_str!`. The page maps the bare specifiers `three` and
//! `three/addons/controls/OrbitControls.js` to `data:` URLs with an import map, so the
//! report needs no network (its Content-Security-Policy forbids any).
//!
//! The mesh travels as base64 little-endian typed arrays (`Float32Array` positions and
//! normals, `Uint8Array` colours, `Uint32Array` indices) in a JSON block. A depth map is
//! meshed on a grid whose stride keeps the triangle count under [`MAX_TRIANGLES`]
//! (decimation by striding): vertex (r, c) sits at x = c + 0.5 − W/2, y = H/2 − r − 0.5,
//! z = depth, the project's camera frame, which is also three.js's (y up, z toward the viewer).

use base64::Engine as _;

use crate::error::{Error, Result};
use crate::image::{DepthMap, GrayImage};
use crate::picture::quantile;

/// Most triangles a report embeds; larger surfaces are meshed with a coarser stride.
pub const MAX_TRIANGLES: usize = 250_000;

/// The vendored three.js module build.
const THREE_JS: &str = include_str!("../../assets/three.module.min.js");
/// The vendored, minified OrbitControls module (imports from `three`).
const ORBIT_CONTROLS_JS: &str = include_str!("../../assets/OrbitControls.min.js");

/// A triangle mesh given by the caller, e.g. the fields of `mesh::Mesh`.
#[derive(Clone, Copy, Debug)]
pub struct MeshParts<'a> {
    /// Vertex positions (camera frame, pixel units).
    pub vertices: &'a [[f32; 3]],
    /// Unit vertex normals, one per vertex (or empty: computed from the faces).
    pub normals: &'a [[f32; 3]],
    /// Vertex colours (e.g. albedo), one per vertex, or `None` for a neutral grey.
    pub colors: Option<&'a [[u8; 3]]>,
    /// Triangles, counter-clockwise seen from the camera (+z).
    pub faces: &'a [[u32; 3]],
}

impl<'a> From<&'a crate::mesh::Mesh> for MeshParts<'a> {
    fn from(m: &'a crate::mesh::Mesh) -> Self {
        MeshParts {
            vertices: &m.vertices,
            normals: &m.normals,
            colors: m.colors.as_deref(),
            faces: &m.faces,
        }
    }
}

/// The mesh as embedded in a report.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewerMesh {
    pub(crate) positions: Vec<[f32; 3]>,
    pub(crate) normals: Vec<[f32; 3]>,
    pub(crate) colors: Option<Vec<[u8; 3]>>,
    pub(crate) faces: Vec<[u32; 3]>,
    /// Grid stride used when meshed from a depth map (1 = every pixel).
    pub(crate) stride: usize,
}

impl ViewerMesh {
    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.faces.len()
    }

    /// Check a caller's mesh and copy it; computes normals when none are given.
    pub fn from_parts(parts: MeshParts<'_>) -> Result<Self> {
        let n = parts.vertices.len();
        if parts.faces.is_empty() || n == 0 {
            return Err(Error::invalid(
                "report mesh with no triangle",
                "give a mesh with at least one face (is the mask empty?)",
            ));
        }
        if parts.faces.len() > MAX_TRIANGLES {
            return Err(Error::invalid(
                format!("report mesh of {} triangles", parts.faces.len()),
                format!("decimate it to at most {MAX_TRIANGLES}, or use Report::surface with the depth map"),
            ));
        }
        if let Some(f) = parts.faces.iter().flatten().find(|&&i| i as usize >= n) {
            return Err(Error::invalid(
                format!("report mesh face index {f} with {n} vertices"),
                "every face index must name a vertex",
            ));
        }
        let colors = match parts.colors {
            Some(c) if c.len() != n => {
                return Err(Error::invalid(
                    format!("report mesh with {} colours for {n} vertices", c.len()),
                    "give one colour per vertex or none",
                ))
            }
            c => c.map(<[_]>::to_vec),
        };
        let normals = if parts.normals.len() == n {
            parts.normals.to_vec()
        } else if parts.normals.is_empty() {
            vertex_normals(parts.vertices, parts.faces)
        } else {
            return Err(Error::invalid(
                format!(
                    "report mesh with {} normals for {n} vertices",
                    parts.normals.len()
                ),
                "give one normal per vertex or none",
            ));
        };
        Ok(ViewerMesh {
            positions: parts.vertices.to_vec(),
            normals,
            colors,
            faces: parts.faces.to_vec(),
            stride: 1,
        })
    }

    /// Mesh a depth map (NaN = outside) on a grid of stride ≥ 1 chosen so that there are at
    /// most `max_triangles` triangles; `albedo` (same size) colours the vertices in grey,
    /// white at its 99th percentile.
    pub fn from_depth(
        depth: &DepthMap,
        albedo: Option<&GrayImage>,
        max_triangles: usize,
    ) -> Result<Self> {
        if let Some(a) = albedo.filter(|a| !a.same_size(depth)) {
            return Err(size_error("albedo for the 3-D view", depth, a));
        }
        let valid = depth.data.iter().filter(|v| v.is_finite()).count();
        if valid == 0 {
            return Err(Error::EmptyMask {
                what: "depth map for the 3-D view".into(),
                fix: "the depth map has no finite value; check the mask".into(),
            });
        }
        let ratio = 2.0 * valid as f64 / max_triangles.max(1) as f64;
        let stride = (ratio.sqrt().ceil() as usize).max(1);
        let mut mesh = grid_mesh(depth, albedo, stride);
        if mesh.faces.is_empty() {
            return Err(Error::invalid(
                "depth map for the 3-D view",
                "no 2x2 block of valid pixels: the mask is too thin to make a surface",
            ));
        }
        mesh.normals = vertex_normals(&mesh.positions, &mesh.faces);
        Ok(mesh)
    }

    /// The JSON block read by the viewer script.
    pub(crate) fn payload_json(&self) -> String {
        let b64 = |bytes: Vec<u8>| base64::engine::general_purpose::STANDARD.encode(bytes);
        let f32s = |v: &[[f32; 3]]| b64(v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect());
        let idx = b64(self
            .faces
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect());
        let colors = match &self.colors {
            Some(c) => format!("\"{}\"", b64(c.iter().flatten().copied().collect())),
            None => "null".into(),
        };
        let (center, radius) = bounding_sphere(&self.positions);
        format!(
            "{{\"positions\":\"{}\",\"normals\":\"{}\",\"colors\":{},\"indices\":\"{}\",\
             \"center\":[{},{},{}],\"radius\":{}}}",
            f32s(&self.positions),
            f32s(&self.normals),
            colors,
            idx,
            center[0],
            center[1],
            center[2],
            radius
        )
    }
}

fn size_error(what: &str, depth: &DepthMap, other: &GrayImage) -> Error {
    Error::SizeMismatch {
        what: what.into(),
        expected_w: depth.width,
        expected_h: depth.height,
        found_w: other.width,
        found_h: other.height,
        fix: "give maps of the same size as the depth map".into(),
    }
}

/// Grid mesh of stride `s`: quads with four valid corners give two triangles, quads with
/// three give one (clean silhouettes).
fn grid_mesh(depth: &DepthMap, albedo: Option<&GrayImage>, s: usize) -> ViewerMesh {
    let (w, h) = (depth.width, depth.height);
    let (gw, gh) = (w.div_ceil(s), h.div_ceil(s));
    let white = albedo
        .and_then(|a| quantile(a.data.iter().copied(), 0.99))
        .filter(|x| *x > 0.0)
        .unwrap_or(1.0);
    let mut index = vec![u32::MAX; gw * gh];
    let mut positions = Vec::new();
    let mut colors = Vec::new();
    for gr in 0..gh {
        for gc in 0..gw {
            let (r, c) = (gr * s, gc * s);
            let z = *depth.get(r, c);
            if !z.is_finite() {
                continue;
            }
            index[gr * gw + gc] = positions.len() as u32;
            let x = c as f32 + 0.5 - w as f32 / 2.0;
            let y = h as f32 / 2.0 - r as f32 - 0.5;
            positions.push([x, y, z]);
            if let Some(a) = albedo {
                let g = (a.get(r, c) / white).clamp(0.0, 1.0);
                let g = if g.is_finite() {
                    (g * 255.0).round() as u8
                } else {
                    0
                };
                colors.push([g, g, g]);
            }
        }
    }
    let mut faces = Vec::new();
    for gr in 0..gh.saturating_sub(1) {
        for gc in 0..gw.saturating_sub(1) {
            let a = index[gr * gw + gc];
            let b = index[gr * gw + gc + 1];
            let c = index[(gr + 1) * gw + gc];
            let d = index[(gr + 1) * gw + gc + 1];
            push_quad(&mut faces, a, b, c, d);
        }
    }
    ViewerMesh {
        positions,
        normals: Vec::new(),
        colors: albedo.map(|_| colors),
        faces,
        stride: s,
    }
}

/// a = top-left, b = top-right, c = bottom-left, d = bottom-right; CCW seen from +z.
fn push_quad(faces: &mut Vec<[u32; 3]>, a: u32, b: u32, c: u32, d: u32) {
    let ok = |i: u32| i != u32::MAX;
    match (ok(a), ok(b), ok(c), ok(d)) {
        (true, true, true, true) => {
            faces.push([a, c, d]);
            faces.push([a, d, b]);
        }
        (true, true, true, false) => faces.push([a, c, b]),
        (true, true, false, true) => faces.push([a, d, b]),
        (true, false, true, true) => faces.push([a, c, d]),
        (false, true, true, true) => faces.push([b, c, d]),
        _ => {}
    }
}

/// Area-weighted vertex normals; isolated vertices get +z.
pub(crate) fn vertex_normals(vertices: &[[f32; 3]], faces: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut acc = vec![[0.0f64; 3]; vertices.len()];
    for f in faces {
        let [p, q, r] = f.map(|i| vertices[i as usize].map(f64::from));
        let u = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
        let v = [r[0] - p[0], r[1] - p[1], r[2] - p[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        for &i in f {
            for k in 0..3 {
                acc[i as usize][k] += n[k];
            }
        }
    }
    acc.iter()
        .map(|n| {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len > 0.0 && len.is_finite() {
                n.map(|x| (x / len) as f32)
            } else {
                [0.0, 0.0, 1.0]
            }
        })
        .collect()
}

/// Centre of the bounding box and the radius of the sphere around it holding every vertex.
fn bounding_sphere(p: &[[f32; 3]]) -> ([f32; 3], f32) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for v in p.iter().filter(|v| v.iter().all(|x| x.is_finite())) {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    if lo[0] > hi[0] {
        return ([0.0; 3], 1.0);
    }
    let c = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let r = p
        .iter()
        .map(|v| ((v[0] - c[0]).powi(2) + (v[1] - c[1]).powi(2) + (v[2] - c[2]).powi(2)).sqrt())
        .filter(|x| x.is_finite())
        .fold(0.0f32, f32::max);
    (c, r.max(1e-3))
}

/// The import map that resolves `three` and its controls to inlined `data:` URLs.
pub(crate) fn import_map() -> String {
    let url = |src: &str| {
        format!(
            "data:text/javascript;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(src)
        )
    };
    format!(
        "{{\"imports\":{{\"three\":\"{}\",\"three/addons/controls/OrbitControls.js\":\"{}\"}}}}",
        url(THREE_JS),
        url(ORBIT_CONTROLS_JS)
    )
}

/// The module script that builds the scene from the `#ps-mesh` JSON block.
pub(crate) const VIEWER_JS: &str = include_str!("viewer.js");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    #[test]
    fn a_disk_is_meshed_with_outward_normals_and_few_enough_triangles() {
        let (w, h) = (80, 60);
        let depth = Image::from_fn(w, h, |r, c| {
            let (x, y) = crate::image::pixel_to_xy(r, c, w, h);
            let rho2 = (x * x + y * y) / 25.0f64.powi(2);
            if rho2 < 1.0 {
                (25.0 * (1.0 - rho2).sqrt()) as f32
            } else {
                f32::NAN
            }
        });
        let full = ViewerMesh::from_depth(&depth, None, usize::MAX).unwrap();
        assert_eq!(full.stride, 1);
        // every normal of a convex cap seen from the camera points toward it
        assert!(full.normals.iter().all(|n| n[2] > 0.0));
        let small = ViewerMesh::from_depth(&depth, None, 500).unwrap();
        assert!(small.triangles() <= 500, "{} triangles", small.triangles());
        assert!(small.stride > 1);
    }

    #[test]
    fn bad_meshes_are_refused() {
        let v = [[0.0f32; 3]; 3];
        let parts = MeshParts {
            vertices: &v,
            normals: &[],
            colors: None,
            faces: &[[0, 1, 3]],
        };
        assert!(ViewerMesh::from_parts(parts).is_err());
        let nan = Image::filled(4, 4, f32::NAN);
        assert!(ViewerMesh::from_depth(&nan, None, 100).is_err());
    }
}
