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
