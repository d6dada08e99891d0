//! Triangle meshes from depth maps, written as binary PLY or OBJ.
//!
//! One vertex per mask pixel with a finite depth, at the pixel centre in camera
//! coordinates (x = c + 0.5 − W/2, y = H/2 − r − 0.5, z = depth; all in pixel units,
//! see the crate conventions). Every 2 × 2 block of pixels gives up to two triangles,
//! and a triangle is emitted only when its three corners are vertices. Triangles wind
//! counter-clockwise seen from the camera (+z), so face normals point toward it.
//!
//! Vertex normals come from the normal map when given (where it is a finite unit
//! vector), otherwise from central differences of the depth. An albedo map becomes a
//! grey vertex colour, scaled so that the largest albedo inside the mask is 255.
//!
//! With [`MeshOptions::camera`] the depth is a distance along the optical axis and
//! each vertex is back-projected through the pinhole ([`Camera::back_project`]: the
//! same camera frame, in the depth's units). With [`MeshOptions::cuts`] (the
//! discontinuities found by bilateral integration) no triangle spans a cut edge, so
//! depth jumps stay open instead of being bridged by long thin triangles.
//!
//! **Big meshes** ([`MeshOptions::max_faces`]): a mesh over more faces than asked is
//! made on every s-th row and column of the pixels (s the least integer stride that
//! fits), so its vertices are pixels of the full-resolution mesh, at the same places;
//! a triangle of the coarse grid is left out where any of the full-resolution edges it
//! spans is cut. The mask's boundary is followed at the stride's resolution.
//!
//! Writers take any `std::io::Write`; the library opens no files.

use crate::error::{Error, Result};
use crate::image::{normalize, pixel_to_xy, DepthMap, GrayImage, Mask, NormalMap};
use crate::integrate::{Camera, Discontinuities};
use std::io::Write;

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions (x, y, z) in pixel units, camera frame.
    pub vertices: Vec<[f32; 3]>,
    /// Unit vertex normals, one per vertex.
    pub normals: Vec<[f32; 3]>,
    /// Optional RGB colour per vertex.
    pub colors: Option<Vec<[u8; 3]>>,
    /// Triangles as indices into `vertices`, counter-clockwise seen from +z.
    pub faces: Vec<[u32; 3]>,
    /// Rows and columns of pixels from one vertex to the next: 1 = every pixel, s > 1 =
    /// every s-th row and column ([`MeshOptions::max_faces`]); 0 in an empty mesh.
    pub stride: usize,
}

fn check_size(what: &str, w: usize, h: usize, depth: &DepthMap) -> Result<()> {
    if w != depth.width || h != depth.height {
        return Err(Error::SizeMismatch {
            what: what.into(),
            expected_w: depth.width,
            expected_h: depth.height,
            found_w: w,
            found_h: h,
            fix: "use maps of the same size as the depth map".into(),
        });
    }
    Ok(())
}

/// Options of [`from_depth_with`].
#[derive(Clone, Copy, Debug, Default)]
pub struct MeshOptions<'a> {
    /// Back-project the vertices through this camera (the depth is then the distance
    /// along the optical axis); `None`: orthographic, pixel units.
    pub camera: Option<&'a Camera>,
    /// Edges that no triangle may span (depth discontinuities).
    pub cuts: Option<&'a Discontinuities>,
    /// At most this many triangles: a bigger mesh is made on every s-th row and column
    /// (module docs); `None` = full resolution whatever the size.
    pub max_faces: Option<usize>,
}

/// Build a mesh from a depth map and its mask (see the module documentation).
pub fn from_depth(
    depth: &DepthMap,
    mask: &Mask,
    normals: Option<&NormalMap>,
    albedo: Option<&GrayImage>,
) -> Result<Mesh> {
    from_depth_with(depth, mask, normals, albedo, &MeshOptions::default())
}

/// [`from_depth`] with a camera and cut edges.
pub fn from_depth_with(
    depth: &DepthMap,
    mask: &Mask,
    normals: Option<&NormalMap>,
    albedo: Option<&GrayImage>,
    opts: &MeshOptions,
) -> Result<Mesh> {
    let (w, h) = (depth.width, depth.height);
    if let Some(cuts) = opts.cuts {
        check_size("mesh cuts", cuts.width, cuts.height, depth)?;
    }
    check_size("mesh mask", mask.width, mask.height, depth)?;
    if let Some(n) = normals {
        check_size("mesh normal map", n.width, n.height, depth)?;
    }
    if let Some(a) = albedo {
        check_size("mesh albedo", a.width, a.height, depth)?;
    }
    let valid = |i: usize| mask.data[i] && depth.data[i].is_finite();
    let stride = match opts.max_faces {
        Some(max) => stride_for(&valid, (w, h), opts.cuts, max),
        None => 1,
    };
    let grid = Grid { w, h, stride };
    let (ws, hs) = (grid.cols(), grid.rows());
    let mut index = vec![u32::MAX; ws * hs];
    let mut mesh = Mesh {
        stride,
        ..Mesh::default()
    };
    for (rs, r) in (0..h).step_by(stride).enumerate() {
        for (cs, c) in (0..w).step_by(stride).enumerate() {
            let i = r * w + c;
            if !valid(i) {
                continue;
            }
            if mesh.vertices.len() >= u32::MAX as usize {
                return Err(Error::invalid("mesh", "more than 4 billion vertices"));
            }
            index[rs * ws + cs] = mesh.vertices.len() as u32;
            let v = match opts.camera {
                Some(cam) => cam
                    .back_project(r, c, depth.data[i] as f64)
                    .map(|v| v as f32),
                None => {
                    let (x, y) = pixel_to_xy(r, c, w, h);
                    [x as f32, y as f32, depth.data[i]]
                }
            };
            mesh.vertices.push(v);
            mesh.normals
                .push(vertex_normal(depth, &valid, normals, r, c));
        }
    }
    if mesh.vertices.is_empty() {
        return Err(Error::EmptyMask {
            what: "mesh".into(),
            fix: "the mask selects no pixel with a finite depth".into(),
        });
    }
    if let Some(a) = albedo {
        mesh.colors = Some(colors(a, &index, &grid));
    }
    each_face(&index, &grid, opts.cuts, |t| mesh.faces.push(t));
    Ok(mesh)
}

/// The grid of the mesh's vertices: every `stride`-th row and column of a w × h image.
struct Grid {
    w: usize,
    h: usize,
    stride: usize,
}

impl Grid {
    fn cols(&self) -> usize {
        self.w.div_ceil(self.stride)
    }

    fn rows(&self) -> usize {
        self.h.div_ceil(self.stride)
    }

    /// Image index of grid pixel k.
    fn pixel(&self, k: usize) -> usize {
        let (rs, cs) = (k / self.cols(), k % self.cols());
        rs * self.stride * self.w + cs * self.stride
    }

    /// Whether a cut lies on the image row from grid pixel k to the next grid column
    /// (`east`) or on the image column down to the next grid row.
    fn cut(&self, cuts: Option<&Discontinuities>, k: usize, east: bool) -> bool {
        let Some(cuts) = cuts else { return false };
        let i = self.pixel(k);
        (0..self.stride).any(|t| {
            if east {
                cuts.east.get(i + t).copied().unwrap_or(false)
            } else {
                cuts.south.get(i + t * self.w).copied().unwrap_or(false)
            }
        })
    }
}

/// The least stride whose mesh has at most `max` faces (1 when the full one fits; the
/// stride at which at most one face is left otherwise).
fn stride_for(
    valid: &impl Fn(usize) -> bool,
    (w, h): (usize, usize),
    cuts: Option<&Discontinuities>,
    max: usize,
) -> usize {
    let count = |stride: usize| {
        let grid = Grid { w, h, stride };
        let index: Vec<u32> = (0..grid.cols() * grid.rows())
            .map(|k| if valid(grid.pixel(k)) { 0 } else { u32::MAX })
            .collect();
        let mut n = 0usize;
        each_face(&index, &grid, cuts, |_| n += 1);
        n
    };
    let full = count(1);
    if full <= max {
        return 1;
    }
    // faces fall as 1/s²: start there and step up until it fits
    let mut s = ((full as f64 / max.max(1) as f64).sqrt().floor() as usize).max(2);
    while s < w.max(h) && count(s) > max {
        s += 1;
    }
    // the mask's outline does not shrink exactly as 1/s²: the least stride that fits
    while s > 2 && count(s - 1) <= max {
        s -= 1;
    }
    s
}

/// Normal of the vertex at (r, c): from the normal map when usable, else from the depth.
fn vertex_normal(
    depth: &DepthMap,
    valid: &impl Fn(usize) -> bool,
    normals: Option<&NormalMap>,
    r: usize,
    c: usize,
) -> [f32; 3] {
    let (w, h) = (depth.width, depth.height);
    let i = r * w + c;
    if let Some(n) = normals.map(|m| m.data[i]) {
        let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        if len2.is_finite() && len2 > 0.5 {
            return normalize(n);
        }
    }
    // One-sided or central differences between valid neighbours; ∂z/∂y = −∂z/∂row.
    let d = |a: Option<usize>, b: Option<usize>| -> f32 {
        let a = a.filter(|&j| valid(j));
        let b = b.filter(|&j| valid(j));
        match (a, b) {
            (Some(a), Some(b)) => (depth.data[b] - depth.data[a]) / 2.0,
            (Some(a), None) => depth.data[i] - depth.data[a],
            (None, Some(b)) => depth.data[b] - depth.data[i],
            (None, None) => 0.0,
        }
    };
    let p = d((c > 0).then(|| i - 1), (c + 1 < w).then_some(i + 1));
    let q = -d((r > 0).then(|| i - w), (r + 1 < h).then_some(i + w));
    normalize([-p, -q, 1.0])
}

fn colors(albedo: &GrayImage, index: &[u32], grid: &Grid) -> Vec<[u8; 3]> {
    let inside = || {
        (index.iter().enumerate())
            .filter(|(_, &k)| k != u32::MAX)
            .map(|(k, _)| (&albedo.data[grid.pixel(k)], ()))
    };
    let max = inside()
        .map(|(&a, _)| a)
        .filter(|a| a.is_finite())
        .fold(0.0f32, f32::max);
    let scale = if max > 0.0 { 255.0 / max } else { 0.0 };
    inside()
        .map(|(&a, _)| {
            let v = if a.is_finite() {
                (a * scale).round().clamp(0.0, 255.0) as u8
            } else {
                0
            };
            [v; 3]
        })
        .collect()
}

/// Triangles of every 2 × 2 block of the grid: a b / c d → (a, c, b) and (b, c, d) when
/// all four are vertices, otherwise the one triangle of the three that are; a triangle
/// with a cut edge (a–b, c–d east; a–c, b–d south) is left out. `emit` gets each one.
fn each_face(
    index: &[u32],
    grid: &Grid,
    cuts: Option<&Discontinuities>,
    mut emit: impl FnMut([u32; 3]),
) {
    let (w, h) = (grid.cols(), grid.rows());
    let east = |k: usize| grid.cut(cuts, k, true);
    let south = |k: usize| grid.cut(cuts, k, false);
    for r in 0..h.saturating_sub(1) {
        for c in 0..w.saturating_sub(1) {
            let i = r * w + c;
            let (a, b, cc, d) = (index[i], index[i + 1], index[i + w], index[i + w + 1]);
            let ok = |v: u32| v != u32::MAX;
            // Open edges: a-b, c-d, a-c, b-d.
            let (ab, cd, ac, bd) = (!east(i), !east(i + w), !south(i), !south(i + 1));
            let mut push = |t: [u32; 3], open: bool| {
                if open {
                    emit(t);
                }
            };
            match (ok(a), ok(b), ok(cc), ok(d)) {
                (true, true, true, true) => {
                    push([a, cc, b], ab && ac);
                    push([b, cc, d], bd && cd);
                }
                (false, true, true, true) => push([b, cc, d], bd && cd),
                (true, false, true, true) => push([a, cc, d], ac && cd),
                (true, true, false, true) => push([a, d, b], ab && bd),
                (true, true, true, false) => push([a, cc, b], ab && ac),
                _ => {}
            }
        }
    }
}

fn io_err(e: std::io::Error) -> Error {
    Error::io("<mesh output>", e)
}

/// Write a binary little-endian PLY: float x y z nx ny nz, optional uchar red green
/// blue, and faces as `list uchar int vertex_indices`.
pub fn write_ply_binary(mesh: &Mesh, out: &mut (impl Write + ?Sized)) -> Result<()> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment photostereo mesh, pixel units, camera frame (x right, y up, z toward the camera)\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n",
        mesh.vertices.len()
    );
    if mesh.colors.is_some() {
        header.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    header.push_str(&format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.faces.len()
    ));
    // written in pieces of about 1 MiB: a whole-file buffer would double the mesh's memory
    const PIECE: usize = 1 << 20;
    let mut buf = Vec::with_capacity(PIECE + 64);
    buf.extend_from_slice(header.as_bytes());
    let mut spill = |buf: &mut Vec<u8>, force: bool| -> Result<()> {
        if force || buf.len() >= PIECE {
            out.write_all(buf).map_err(io_err)?;
            buf.clear();
        }
        Ok(())
    };
    for (k, (v, n)) in mesh.vertices.iter().zip(&mesh.normals).enumerate() {
        for x in v.iter().chain(n.iter()) {
            buf.extend_from_slice(&x.to_le_bytes());
        }
        if let Some(col) = &mesh.colors {
            buf.extend_from_slice(&col[k]);
        }
        spill(&mut buf, false)?;
    }
    for f in &mesh.faces {
        buf.push(3);
        for &i in f {
            buf.extend_from_slice(&(i as i32).to_le_bytes());
        }
        spill(&mut buf, false)?;
    }
    spill(&mut buf, true)?;
    out.flush().map_err(io_err)
}

/// Write a Wavefront OBJ: `v x y z [r g b]` (colours in 0..1, a common extension),
/// `vn`, and faces `f a//a b//b c//c` (1-based).
pub fn write_obj(mesh: &Mesh, out: &mut (impl Write + ?Sized)) -> Result<()> {
    let mut s = String::with_capacity(mesh.vertices.len() * 60 + mesh.faces.len() * 30);
    s.push_str(
        "# photostereo mesh, pixel units, camera frame (x right, y up, z toward the camera)\n",
    );
    for (k, v) in mesh.vertices.iter().enumerate() {
        s.push_str(&format!("v {} {} {}", v[0], v[1], v[2]));
        if let Some(col) = &mesh.colors {
            let c = col[k];
            s.push_str(&format!(
                " {:.4} {:.4} {:.4}",
                c[0] as f32 / 255.0,
                c[1] as f32 / 255.0,
                c[2] as f32 / 255.0
            ));
        }
        s.push('\n');
    }
    for n in &mesh.normals {
        s.push_str(&format!("vn {} {} {}\n", n[0], n[1], n[2]));
    }
    for f in &mesh.faces {
        let (a, b, c) = (f[0] + 1, f[1] + 1, f[2] + 1);
        s.push_str(&format!("f {a}//{a} {b}//{b} {c}//{c}\n"));
    }
    out.write_all(s.as_bytes()).map_err(io_err)?;
    out.flush().map_err(io_err)
}
