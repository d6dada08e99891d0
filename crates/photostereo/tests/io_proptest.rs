//! Property tests: any size down to 0x0 / 1x1 and any mask (all-false included) goes
//! through the writers and readers without panicking, and round trips are exact.

use photostereo::image::{Image, ImageStack, Lights};
use photostereo::io::{self, LoadOptions};
use photostereo::Error;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

fn fresh_dir() -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("io_prop_{}", N.fetch_add(1, Ordering::Relaxed)));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// (width, height, values) with sizes 0..=6.
fn gray(max: usize) -> impl Strategy<Value = (usize, usize, Vec<f32>)> {
    (0..=max, 0..=max).prop_flat_map(|(w, h)| {
        let v = prop_oneof![any::<f32>(), -10.0f32..10.0];
        (Just(w), Just(h), proptest::collection::vec(v, w * h))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn npy_round_trip_any_size((w, h, v) in gray(6)) {
        let dir = fresh_dir();
        let img = Image::from_vec(w, h, v).unwrap();
        io::write_gray_npy(&dir.join("g.npy"), &img).unwrap();
        let back = io::read_gray_npy(&dir.join("g.npy")).unwrap();
        prop_assert_eq!((back.width, back.height), (w, h));
        let bits = |m: &Image<f32>| m.data.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        prop_assert_eq!(bits(&back), bits(&img));
        let normals = img.map(|&x| [x, -x, 0.5]);
        io::write_normals(&dir.join("n.npy"), &normals).unwrap();
        let back = io::read_normals_npy(&dir.join("n.npy")).unwrap();
        prop_assert_eq!((back.width, back.height), (w, h));
        prop_assert!(back.data.iter().zip(&normals.data).all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)));
        let mask = img.map(|&x| x > 0.0);
        io::write_mask_npy(&dir.join("m.npy"), &mask).unwrap();
        prop_assert_eq!(io::read_mask_any(&dir.join("m.npy")).unwrap(), mask);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn pngs_of_any_size_write_or_refuse_cleanly((w, h, v) in gray(6), seed in any::<u64>()) {
        let dir = fresh_dir();
        let img = Image::from_vec(w, h, v).unwrap();
        let mask = img.map(|&x| (x.to_bits() ^ seed as u32) % 3 != 0);
        let normals = img.map(|&x| [x, 0.3, 1.0]);
        let results = [
            io::write_gray_png(&dir.join("g.png"), &img),
            io::write_depth_png(&dir.join("d.png"), &img, Some(&mask)),
            io::write_normals_png(&dir.join("n.png"), &normals, Some(&mask)),
            io::write_mask_png(&dir.join("m.png"), &mask),
        ];
        for r in &results {
            // A PNG needs a pixel: empty images are refused, all others written.
            prop_assert_eq!(r.is_ok(), w > 0 && h > 0, "{:?}", r);
        }
        if w > 0 && h > 0 {
            prop_assert_eq!(io::read_mask(&dir.join("m.png")).unwrap(), mask);
            let (g, depth) = io::read_gray_image(&dir.join("g.png"), None).unwrap();
            prop_assert_eq!((g.width, g.height, depth), (w, h, 16));
        } else {
            // Nothing, not even a temporary file, is left behind.
            let left = std::fs::read_dir(&dir).map(|d| d.count()).unwrap_or(0);
            prop_assert_eq!(left, 0);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn dataset_round_trip_any_size_and_mask(
        (w, h, k) in (1usize..=5, 1usize..=5, 1usize..=3),
        seed in any::<u32>(),
        sixteen in any::<bool>(),
    ) {
        let full = if sixteen { 65535u32 } else { 255 };
        let images: Vec<_> = (0..k)
            .map(|i| Image::from_fn(w, h, |r, c| {
                let x = (r as u32 * 7919 + c as u32 * 104729 + i as u32 * 31).wrapping_mul(seed | 1);
                (x % (full + 1)) as f32 / full as f32
            }))
            .collect();
        let stack = ImageStack::from_images(&images).unwrap();
        let lights = Lights::from_directions(vec![[0.1, 0.2, 1.0]; k]);
        let mask = Image::from_fn(w, h, |r, c| (seed >> ((r * w + c) % 32)) & 1 == 1);
        let dir = fresh_dir();
        io::write_dataset(&dir, &stack, &lights, Some(&mask), if sixteen { 16 } else { 8 }).unwrap();
        match io::load_dataset(&dir, &LoadOptions::default()) {
            Ok(ds) => {
                prop_assert!(mask.count() > 0);
                prop_assert_eq!(&ds.stack.data, &stack.data);
                prop_assert_eq!(ds.mask.unwrap(), mask);
            }
            Err(e) => {
                prop_assert!(matches!(e, Error::EmptyMask { .. }), "{}", e);
                prop_assert_eq!(mask.count(), 0);
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
