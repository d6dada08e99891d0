//! Meshes from depth: vertex/face counts on a known mask, a binary PLY read back by a
//! small reader, OBJ counts, and orientation toward the camera.

use photostereo::integrate::{solve, Options};
use photostereo::mesh::{from_depth, write_obj, write_ply_binary, Mesh};
use photostereo::{DepthMap, GrayImage, Image, Mask};

/// Minimal binary-PLY reader for the layout the library writes.
fn read_ply(bytes: &[u8]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>, bool) {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    assert!(header.starts_with("ply\nformat binary_little_endian 1.0\n"));
    let count = |name: &str| -> usize {
        let line = header
            .lines()
            .find(|l| l.starts_with(&format!("element {name} ")))
            .unwrap();
        line.split(' ').nth(2).unwrap().parse().unwrap()
    };
    let (nv, nf) = (count("vertex"), count("face"));
    let colors = header.contains("property uchar red");
    let stride = 24 + if colors { 3 } else { 0 };
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let mut at = end;
    let mut verts = Vec::new();
    for _ in 0..nv {
        verts.push([f32_at(at), f32_at(at + 4), f32_at(at + 8)]);
        at += stride;
    }
    let mut faces = Vec::new();
    for _ in 0..nf {
        assert_eq!(bytes[at], 3);
        let i = |k: usize| {
            i32::from_le_bytes(bytes[at + 1 + 4 * k..at + 5 + 4 * k].try_into().unwrap()) as u32
        };
        faces.push([i(0), i(1), i(2)]);
        at += 13;
    }
    assert_eq!(at, bytes.len(), "trailing bytes");
    (verts, faces, colors)
}

fn face_normal_z(m: &Mesh, f: [u32; 3]) -> f32 {
    let [a, b, c] = f.map(|i| m.vertices[i as usize]);
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

#[test]
fn full_grid_counts_and_ply_read_back() {
    let (w, h) = (7, 5);
    let depth = DepthMap::from_fn(w, h, |r, c| (r + c) as f32 * 0.1);
    let mask = Mask::full(w, h);
    let albedo = GrayImage::filled(w, h, 0.5);
    let mesh = from_depth(&depth, &mask, None, Some(&albedo)).unwrap();
    assert_eq!(mesh.vertices.len(), 35);
    assert_eq!(mesh.faces.len(), 2 * 6 * 4);
    let mut buf = Vec::new();
    write_ply_binary(&mesh, &mut buf).unwrap();
    let (verts, faces, colors) = read_ply(&buf);
    assert!(colors);
    assert_eq!(verts.len(), 35);
    assert_eq!(faces.len(), 48);
    assert_eq!(verts, mesh.vertices);
    assert_eq!(faces, mesh.faces);
    // Pixel (0,0) centre: x = 0.5 − 3.5 = −3, y = 2.5 − 0.5 = 2.
    assert_eq!(verts[0], [-3.0, 2.0, 0.0]);
    assert!(
        mesh.faces.iter().all(|&f| face_normal_z(&mesh, f) > 0.0),
        "faces must face +z"
    );
}

#[test]
fn masked_sphere_mesh_has_only_triangles_inside_the_mask() {
    let (w, h) = (30, 30);
    let mask = Mask::from_fn(w, h, |r, c| (r as f32 - 14.5).hypot(c as f32 - 14.5) < 12.0);
    let normals = Image::from_fn(w, h, |r, c| {
        let (x, y) = (c as f32 - 14.5, 14.5 - r as f32);
        let z = (400.0 - x * x - y * y).sqrt();
        [x / 20.0, y / 20.0, z / 20.0]
    });
    let out = solve(&normals, &mask, &Options::default()).unwrap();
    let mesh = from_depth(&out.depth, &mask, Some(&normals), None).unwrap();
    assert_eq!(mesh.vertices.len(), mask.count());
    // Expected faces: one per 2x2 block with 3 corners in, two with 4.
    let mut expected = 0;
    for r in 0..h - 1 {
        for c in 0..w - 1 {
            let n = [(r, c), (r, c + 1), (r + 1, c), (r + 1, c + 1)]
                .iter()
                .filter(|&&(a, b)| *mask.get(a, b))
                .count();
            expected += match n {
                4 => 2,
                3 => 1,
                _ => 0,
            };
        }
    }
    assert_eq!(mesh.faces.len(), expected);
    assert!(mesh.colors.is_none());
    let mut buf = Vec::new();
    write_ply_binary(&mesh, &mut buf).unwrap();
    let (verts, faces, _) = read_ply(&buf);
    assert_eq!((verts.len(), faces.len()), (mask.count(), expected));
    let mut obj = Vec::new();
    write_obj(&mesh, &mut obj).unwrap();
    let text = String::from_utf8(obj).unwrap();
    assert_eq!(
        text.lines().filter(|l| l.starts_with("v ")).count(),
        mask.count()
    );
    assert_eq!(
        text.lines().filter(|l| l.starts_with("vn ")).count(),
        mask.count()
    );
    assert_eq!(
        text.lines().filter(|l| l.starts_with("f ")).count(),
        expected
    );
}

#[test]
fn mesh_size_mismatch_and_empty_are_errors() {
    let depth = DepthMap::filled(4, 4, 0.0);
    assert!(from_depth(&depth, &Mask::full(5, 4), None, None).is_err());
    assert!(from_depth(&depth, &Mask::filled(4, 4, false), None, None).is_err());
}

/// A sphere cap of radius 90 px on a 200 × 160 image: depth and normals.
fn sphere_cap() -> (DepthMap, Mask, photostereo::NormalMap) {
    let (w, h) = (200, 160);
    let xy = |r: usize, c: usize| (c as f32 + 0.5 - 100.0, 80.0 - r as f32 - 0.5);
    let mask = Mask::from_fn(w, h, |r, c| {
        let (x, y) = xy(r, c);
        x.hypot(y) < 75.0
    });
    let depth = DepthMap::from_fn(w, h, |r, c| {
        let (x, y) = xy(r, c);
        (8100.0 - x * x - y * y).max(0.0).sqrt()
    });
    let normals = Image::from_fn(w, h, |r, c| {
        let (x, y) = xy(r, c);
        let z = (8100.0 - x * x - y * y).max(0.0).sqrt();
        [x / 90.0, y / 90.0, z / 90.0]
    });
    (depth, mask, normals)
}

#[test]
fn a_capped_mesh_has_at_most_the_faces_asked_and_its_vertices_on_the_full_depth() {
    use photostereo::mesh::{from_depth_with, MeshOptions};
    let (depth, mask, normals) = sphere_cap();
    let full = from_depth(&depth, &mask, Some(&normals), None).unwrap();
    assert_eq!(full.vertices.len(), mask.count());
    let nf = full.faces.len();
    // a cap the full mesh meets: the same mesh
    let opts = |max: usize| MeshOptions {
        max_faces: Some(max),
        ..Default::default()
    };
    let same = from_depth_with(&depth, &mask, Some(&normals), None, &opts(nf)).unwrap();
    assert_eq!(same, full);
    // the full vertices by position, to find each capped vertex among them
    let key = |v: [f32; 3]| v.map(f32::to_bits);
    let by_pos: std::collections::HashMap<[u32; 3], usize> = (full.vertices.iter())
        .enumerate()
        .map(|(k, v)| (key(*v), k))
        .collect();
    for max in [nf - 1, nf / 4, nf / 10, 1000] {
        let m = from_depth_with(&depth, &mask, Some(&normals), None, &opts(max)).unwrap();
        assert!(m.faces.len() <= max, "{} > {max}", m.faces.len());
        // the stride: the least whose grid has at most `max` faces, counted here by
        // 2 × 2 blocks (4 corners in: 2 faces, 3: 1) on every s-th row and column
        let faces_at = |s: usize| {
            let (ws, hs) = (200usize.div_ceil(s), 160usize.div_ceil(s));
            let inside = |r: usize, c: usize| *mask.get(r * s, c * s);
            let mut n = 0;
            for r in 0..hs - 1 {
                for c in 0..ws - 1 {
                    let k = [(r, c), (r, c + 1), (r + 1, c), (r + 1, c + 1)]
                        .iter()
                        .filter(|&&(a, b)| inside(a, b))
                        .count();
                    n += [0, 0, 0, 1, 2][k];
                }
            }
            n
        };
        let s = (1..).find(|&s| faces_at(s) <= max).unwrap();
        assert!(s > 1);
        assert_eq!(m.faces.len(), faces_at(s), "stride {s}");
        // its vertices are every s-th pixel of the mask
        let sub = |r: usize, c: usize| r % s == 0 && c % s == 0 && *mask.get(r, c);
        let expected = (0..160 * 200).filter(|&i| sub(i / 200, i % 200)).count();
        assert_eq!(m.vertices.len(), expected);
        for (v, n) in m.vertices.iter().zip(&m.normals) {
            let k = by_pos[&key(*v)]; // a vertex of the full mesh, same x, y, z
            assert_eq!(*n, full.normals[k]);
        }
        assert!(m.faces.iter().all(|&f| face_normal_z(&m, f) > 0.0));
    }
}

#[test]
fn a_capped_mesh_keeps_the_cuts_open() {
    use photostereo::integrate::Discontinuities;
    use photostereo::mesh::{from_depth_with, MeshOptions};
    // a step at column 100: cut the east edges of column 99 in every row
    let (w, h) = (200, 160);
    let depth = DepthMap::from_fn(w, h, |_, c| if c < 100 { 0.0 } else { 50.0 });
    let mask = Mask::full(w, h);
    let mut cuts = Discontinuities {
        width: w,
        height: h,
        east: vec![false; w * h],
        south: vec![false; w * h],
    };
    for r in 0..h {
        cuts.east[r * w + 99] = true;
    }
    for max in [usize::MAX, 10_000, 2_000] {
        let opts = MeshOptions {
            cuts: Some(&cuts),
            max_faces: Some(max),
            ..Default::default()
        };
        let m = from_depth_with(&depth, &mask, None, None, &opts).unwrap();
        assert!(m.faces.len() <= max);
        // no triangle joins the two levels
        for f in &m.faces {
            let z = f.map(|i| m.vertices[i as usize][2]);
            assert!(z.iter().all(|&v| v == z[0]), "{z:?}");
        }
    }
}
