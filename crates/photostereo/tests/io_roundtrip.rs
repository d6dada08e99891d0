//! Exact round trips through the writers and readers of `io`, and the luminance rule
//! on a tiny real 8-bit RGB dataset.

mod common;
use photostereo::image::{normalize, Image, ImageStack, Lights, Mask};
use photostereo::io::{self, LoadOptions};
use std::path::{Path, PathBuf};

fn tmp_dir(name: &str) -> PathBuf {
    common::temp_dir("io-roundtrip", name)
}

fn data_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// A 5x4 stack of K = 3 images whose values are exact multiples of 1/full.
fn quantized_stack(full: u32) -> ImageStack {
    let images: Vec<_> = (0..3)
        .map(|i| {
            Image::from_fn(5, 4, |r, c| {
                let k = (r * 37 + c * 101 + i * 53) as u32 * 977 % (full + 1);
                k as f32 / full as f32
            })
        })
        .collect();
    ImageStack::from_images(&images).unwrap()
}

fn lights3() -> Lights {
    Lights::from_directions(vec![[0.3, 0.1, 0.9], [-0.2, 0.4, 0.8], [0.0, -0.5, 0.7]])
}

fn round_trip(bit_depth: u8, full: u32) {
    let dir = tmp_dir(&format!("dataset{bit_depth}"));
    let mut stack = quantized_stack(full);
    // One clipped sample inside the mask, one outside: only the first counts.
    stack.data[(5 + 1) * 3] = 1.0; // pixel (1, 1), image 0
    stack.data[2] = 1.0; // pixel (0, 0), image 2
    let mask = Image::from_fn(5, 4, |r, c| !(r == 0 && c == 0));
    // Exactly one more saturated value may come from the formula: count them all.
    let expected_sat = (0..20)
        .filter(|&p| mask.data[p])
        .map(|p| stack.pixel_flat(p).iter().filter(|&&v| v == 1.0).count())
        .sum::<usize>();
    let lights = lights3();
    io::write_dataset(&dir, &stack, &lights, Some(&mask), bit_depth).unwrap();
    let ds = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(ds.bit_depth, bit_depth);
    assert_eq!(
        ds.stack.data, stack.data,
        "{bit_depth}-bit PNG round trip not exact"
    );
    assert_eq!(ds.stack.names, ["001.png", "002.png", "003.png"]);
    assert_eq!(ds.mask.as_ref(), Some(&mask));
    assert_eq!(ds.saturated, expected_sat);
    assert!(expected_sat >= 1);
    let got = ds.lights.unwrap();
    for (a, b) in got.directions.iter().zip(&lights.directions) {
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() < 1e-7, "{a:?} vs {b:?}");
        }
    }
    assert_eq!(got.intensities, vec![1.0; 3]);
}

#[test]
fn png_16_bit_dataset_round_trip_is_exact() {
    round_trip(16, 65535);
}

#[test]
fn png_8_bit_dataset_round_trip_is_exact() {
    round_trip(8, 255);
}

#[test]
fn tiff_16_bit_gray_loads_exactly() {
    let dir = tmp_dir("tiff16");
    for i in 0..2u16 {
        let img = image::ImageBuffer::<image::Luma<u16>, _>::from_fn(3, 2, |x, y| {
            image::Luma([(x as u16 * 20000 + y as u16 * 7 + i * 3) % 65535 + i])
        });
        img.save(dir.join(format!("{:02}.tif", i + 1))).unwrap();
    }
    let ds = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(ds.bit_depth, 16);
    assert_eq!((ds.stack.width, ds.stack.height, ds.stack.k), (3, 2, 2));
    // Pixel (row 1, col 2) of image 2: (2*20000 + 7 + 3) % 65535 + 1 = 40011.
    assert_eq!(ds.stack.pixel(1, 2)[1], 40011.0 / 65535.0);
    assert!(ds.lights.is_none() && ds.mask.is_none());
}

#[test]
fn npy_round_trips_are_exact() {
    let dir = tmp_dir("npy");
    let normals = Image::from_fn(7, 3, |r, c| {
        if r == 1 && c == 2 {
            [f32::NAN; 3]
        } else {
            normalize([c as f32 - 3.0, 1.0 - r as f32, 4.0])
        }
    });
    io::write_normals(&dir.join("n.npy"), &normals).unwrap();
    let back = io::read_normals_npy(&dir.join("n.npy")).unwrap();
    assert_eq!((back.width, back.height), (7, 3));
    let bits = |m: &Image<[f32; 3]>| {
        m.data
            .iter()
            .flatten()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&back), bits(&normals));

    let depth = Image::from_fn(4, 6, |r, c| {
        if c == 0 {
            f32::NAN
        } else {
            (r * c) as f32 * 0.1 - 1.0
        }
    });
    io::write_gray_npy(&dir.join("d.npy"), &depth).unwrap();
    let back = io::read_gray_npy(&dir.join("d.npy")).unwrap();
    let gbits = |m: &Image<f32>| m.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(gbits(&back), gbits(&depth));
    assert_eq!((back.width, back.height), (4, 6));

    let mask = Image::from_fn(5, 2, |r, c| (r + c) % 3 == 0);
    io::write_mask_npy(&dir.join("m.npy"), &mask).unwrap();
    assert_eq!(io::read_mask_any(&dir.join("m.npy")).unwrap(), mask);
    io::write_mask_png(&dir.join("m.png"), &mask).unwrap();
    assert_eq!(io::read_mask_any(&dir.join("m.png")).unwrap(), mask);
}

#[test]
fn normal_png_round_trip_within_quantisation() {
    let dir = tmp_dir("npng");
    let normals = Image::from_fn(9, 5, |r, c| {
        normalize([c as f32 - 4.0, 2.0 - r as f32, 3.0])
    });
    let mask = Image::from_fn(9, 5, |r, _| r != 0);
    let path = dir.join("n.png");
    io::write_normals_png(&path, &normals, Some(&mask)).unwrap();
    let back = io::read_normals_png(&path).unwrap();
    let mut worst = 0.0f32;
    for i in 0..normals.len() {
        if mask.data[i] {
            for k in 0..3 {
                worst = worst.max((back.data[i][k] - normals.data[i][k]).abs());
            }
        } else {
            assert_eq!(back.data[i], [0.0; 3]);
        }
    }
    // One 16-bit step of c = (n+1)/2 is 2/65535 in n; renormalising adds at most that.
    assert!(worst < 4.0 / 65535.0, "worst component error {worst}");
}

#[test]
fn gray_png_range_round_trip_is_exact() {
    let dir = tmp_dir("gray");
    let img = Image::from_fn(6, 3, |r, c| ((r * 6 + c) * 3000) as f32 / 65535.0);
    io::write_gray_png_range(&dir.join("g.png"), &img, 0.0, 1.0).unwrap();
    let (back, depth) = io::read_gray_image(&dir.join("g.png"), None).unwrap();
    assert_eq!(depth, 16);
    assert_eq!(back, img);
    // Auto scale: the largest value maps to full scale.
    io::write_gray_png(&dir.join("a.png"), &img.map(|v| v * 4.0)).unwrap();
    let (auto, _) = io::read_gray_image(&dir.join("a.png"), None).unwrap();
    assert_eq!(auto.data[17], 1.0);
    assert_eq!(auto.data[0], 0.0);
}

#[test]
fn depth_png_uses_the_colour_map_and_black_for_nan() {
    let dir = tmp_dir("depthpng");
    let depth = Image::from_vec(4, 1, vec![f32::NAN, 2.0, 4.0, 3.0]).unwrap();
    let mask = Image::from_vec(4, 1, vec![true, true, true, false]).unwrap();
    let path = dir.join("d.png");
    io::write_depth_png(&path, &depth, Some(&mask)).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
    assert_eq!(img.get_pixel(1, 0).0, io::raster::turbo(0.0));
    assert_eq!(img.get_pixel(2, 0).0, io::raster::turbo(1.0));
    assert_eq!(img.get_pixel(3, 0).0, [0, 0, 0]);
    assert_ne!(io::raster::turbo(0.0), io::raster::turbo(1.0));
}

/// Expected luminance of pixel (x, y) of `file` with per-channel intensity `s`.
fn expected_y(file: &Path, x: u32, y: u32, s: [f32; 3]) -> f32 {
    let p = image::open(file).unwrap().to_rgb8().get_pixel(x, y).0;
    let w = [0.2126f32, 0.7152, 0.0722];
    (0..3).map(|i| w[i] * p[i] as f32 / 255.0 / s[i]).sum()
}

#[test]
fn tiny_rgb_dataset_follows_filenames_and_divides_per_channel() {
    let dir = data_dir("tiny_rgb");
    let ds = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(ds.stack.names, ["img_2.png", "img_10.png", "img_1.png"]);
    assert_eq!(
        (ds.stack.width, ds.stack.height, ds.stack.k, ds.bit_depth),
        (8, 6, 3, 8)
    );
    let scales = [[1.0, 1.0, 1.0], [0.5, 0.5, 0.5], [2.0, 1.0, 0.5]];
    let mut checked = 0;
    for (k, name) in ds.stack.names.iter().enumerate() {
        for (r, c) in [(0, 0), (2, 3), (3, 4), (5, 7)] {
            let want = expected_y(&dir.join(name), c as u32, r as u32, scales[k]);
            let got = ds.stack.pixel(r, c)[k];
            assert!(
                (got - want).abs() <= 1e-6 * want.max(1.0),
                "{name} ({r},{c}): {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 12);
    let mask = ds.mask.unwrap();
    assert_eq!(mask, io::read_mask(&dir.join("mask.png")).unwrap());
    assert!(mask.count() > 0 && mask.count() < 48);
    let lights = ds.lights.unwrap();
    assert!((lights.directions[0][0] - 0.403259).abs() < 1e-5);
    assert_eq!(ds.raw_intensities.unwrap()[2], [2.0, 1.0, 0.5]);

    // Without applying the intensities the luminance of each entry goes to the lights.
    let opts = LoadOptions {
        apply_intensities: false,
        ..LoadOptions::default()
    };
    let raw = io::load_dataset(&dir, &opts).unwrap();
    let lum = 0.2126 * 2.0 + 0.7152 * 1.0 + 0.0722 * 0.5;
    assert!((raw.lights.unwrap().intensities[2] - lum).abs() < 1e-6);
    let want = expected_y(&dir.join("img_1.png"), 3, 2, [1.0; 3]);
    assert!((raw.stack.pixel(2, 3)[2] - want).abs() < 1e-6);
}

#[test]
fn listing_without_filenames_uses_natural_order_and_skips_non_light_files() {
    let src = data_dir("tiny_rgb");
    let dir = tmp_dir("natural");
    for f in ["img_1.png", "img_2.png", "img_10.png", "mask.png"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    // Files that are not light images by the documented rule.
    for f in [
        "lit_mask.png",
        "normal_gt.png",
        "depth.png",
        "albedo.png",
        "notes.txt",
    ] {
        std::fs::copy(src.join("mask.png"), dir.join(f)).unwrap();
    }
    let ds = io::load_dataset(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(ds.stack.names, ["img_1.png", "img_2.png", "img_10.png"]);
    assert!(ds.lights.is_none());
    assert!(io::dataset::is_light_image_name("001.PNG"));
    assert!(!io::dataset::is_light_image_name("Mask.png"));
    assert!(!io::dataset::is_light_image_name("light_directions.txt"));
}

#[test]
fn failed_atomic_write_leaves_nothing_and_keeps_the_old_file() {
    let dir = tmp_dir("atomic");
    let path = dir.join("out.txt");
    let err = io::write_atomic(&path, |w| {
        w.write_all(b"half").unwrap();
        Err(photostereo::Error::invalid("test", "simulated failure"))
    });
    assert!(err.is_err());
    assert!(!path.exists());
    io::write_text(&path, "old").unwrap();
    let _ = io::write_atomic(&path, |w| {
        w.write_all(b"new but broken").unwrap();
        Err(photostereo::Error::invalid("test", "simulated failure"))
    });
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["out.txt"], "temporary files left behind");
    io::write_bytes(&path, b"new").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"new");
    // A zero-size PNG is refused without leaving a file.
    let empty: Mask = Image::filled(0, 3, true);
    assert!(io::write_mask_png(&dir.join("e.png"), &empty).is_err());
    assert!(!dir.join("e.png").exists());
}

/// Files in other layouts than the one this program writes (float64, Fortran order,
/// big-endian) read to the same values as the plain float32 C-order file, which is
/// read without ndarray's copy.
#[test]
fn npy_layouts_read_alike() {
    use ndarray::{Array2, Array3, ShapeBuilder};
    use ndarray_npy::WriteNpyExt;
    let dir = tmp_dir("npy-layouts");
    let (h, w) = (3, 5);
    let value = |r: usize, c: usize, k: usize| (r * 100 + c * 10 + k) as f32 * 0.25 - 7.0;
    let write = |name: &str, a: &dyn Fn(&mut std::fs::File)| {
        let path = dir.join(name);
        a(&mut std::fs::File::create(&path).unwrap());
        path
    };
    let c_order = Array3::from_shape_fn((h, w, 3), |(r, c, k)| value(r, c, k));
    let fortran = Array3::from_shape_fn((h, w, 3).f(), |(r, c, k)| value(r, c, k));
    let double = c_order.mapv(f64::from);
    let paths = [
        write("c.npy", &|f| c_order.write_npy(f).unwrap()),
        write("f.npy", &|f| fortran.write_npy(f).unwrap()),
        write("d.npy", &|f| double.write_npy(f).unwrap()),
    ];
    let maps: Vec<_> = paths
        .iter()
        .map(|p| io::read_normals_npy(p).unwrap())
        .collect();
    for m in &maps {
        assert_eq!((m.width, m.height), (w, h));
        for (i, n) in m.data.iter().enumerate() {
            let (r, c) = (i / w, i % w);
            assert_eq!(*n, [value(r, c, 0), value(r, c, 1), value(r, c, 2)]);
        }
    }
    // big-endian float32: the header's descr is '>f4'
    let mut be = Vec::new();
    let header = format!("{{'descr': '>f4', 'fortran_order': False, 'shape': ({h}, {w}), }}");
    let pad = 64 - (10 + header.len() + 1) % 64;
    be.extend_from_slice(b"\x93NUMPY\x01\x00");
    be.extend_from_slice(&((header.len() + pad + 1) as u16).to_le_bytes());
    be.extend_from_slice(header.as_bytes());
    be.extend(std::iter::repeat_n(b' ', pad));
    be.push(b'\n');
    let gray = Array2::from_shape_fn((h, w), |(r, c)| value(r, c, 0));
    for v in gray.iter() {
        be.extend_from_slice(&v.to_be_bytes());
    }
    std::fs::write(dir.join("be.npy"), &be).unwrap();
    let back = io::read_gray_npy(&dir.join("be.npy")).unwrap();
    assert_eq!(back.data, gray.iter().copied().collect::<Vec<_>>());
}
