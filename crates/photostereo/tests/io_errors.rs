//! Every bad input to `io` gives a clear error naming the file; none panics.

use photostereo::image::{Image, ImageStack, Lights};
use photostereo::io::{self, LoadOptions};
use photostereo::Error;
use std::path::{Path, PathBuf};

fn tmp_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("io_err_{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A valid 4x3, K = 3, 8-bit dataset with lights and a mask.
fn good_dataset(name: &str) -> PathBuf {
    let dir = tmp_dir(name);
    let images: Vec<_> = (0..3)
        .map(|i| Image::from_fn(4, 3, |r, c| (r + c + i) as f32 / 10.0))
        .collect();
    let stack = ImageStack::from_images(&images).unwrap();
    let lights = Lights::from_directions(vec![[0.0, 0.0, 1.0], [0.5, 0.0, 1.0], [0.0, 0.5, 1.0]]);
    let mask = Image::from_fn(4, 3, |r, _| r > 0);
    io::write_dataset(&dir, &stack, &lights, Some(&mask), 8).unwrap();
    dir
}

fn load(dir: &Path) -> Result<io::Dataset, Error> {
    io::load_dataset(dir, &LoadOptions::default())
}

/// The error message must mention `needle`.
fn assert_mentions(err: &Error, needle: &str) {
    let msg = err.to_string();
    assert!(
        msg.contains(needle),
        "message `{msg}` does not mention `{needle}`"
    );
}

#[test]
fn the_good_dataset_loads() {
    let ds = load(&good_dataset("good")).unwrap();
    assert_eq!((ds.stack.k, ds.stack.width, ds.stack.height), (3, 4, 3));
    assert_eq!(ds.mask.unwrap().count(), 8);
}

#[test]
fn missing_directory() {
    let dir = tmp_dir("missing").join("nope");
    let err = load(&dir).unwrap_err();
    assert!(
        matches!(&err, Error::NotFound { path, .. } if *path == dir),
        "{err}"
    );
}

#[test]
fn no_images() {
    let dir = tmp_dir("noimages");
    std::fs::write(dir.join("light_directions.txt"), "0 0 1\n").unwrap();
    std::fs::copy(
        good_dataset("noimages_src").join("mask.png"),
        dir.join("mask.png"),
    )
    .unwrap();
    let err = load(&dir).unwrap_err();
    assert!(matches!(err, Error::InvalidInput { .. }), "{err}");
    assert_mentions(&err, "no light images");
}

#[test]
fn images_of_different_sizes_name_both_files() {
    let dir = good_dataset("sizes");
    image::GrayImage::new(5, 3)
        .save(dir.join("002.png"))
        .unwrap();
    let err = load(&dir).unwrap_err();
    assert!(
        matches!(
            err,
            Error::SizeMismatch {
                found_w: 5,
                expected_w: 4,
                ..
            }
        ),
        "{err}"
    );
    assert_mentions(&err, "002.png");
    assert_mentions(&err, "001.png");
}

#[test]
fn mixed_bit_depths_are_refused() {
    let dir = good_dataset("depths");
    image::ImageBuffer::<image::Luma<u16>, _>::new(4, 3)
        .save(dir.join("003.png"))
        .unwrap();
    let err = load(&dir).unwrap_err();
    assert_mentions(&err, "003.png");
    assert_mentions(&err, "16-bit");
}

#[test]
fn wrong_number_of_light_directions() {
    let dir = good_dataset("ndirs");
    std::fs::write(dir.join("light_directions.txt"), "0 0 1\n0.1 0 1\n").unwrap();
    let err = load(&dir).unwrap_err();
    assert!(
        matches!(
            err,
            Error::LightCount {
                expected: 3,
                found: 2,
                ..
            }
        ),
        "{err}"
    );
    assert_mentions(&err, "light_directions.txt");
}

#[test]
fn wrong_number_of_intensities() {
    let dir = good_dataset("nint");
    std::fs::write(dir.join("light_intensities.txt"), "1\n1\n1\n1\n").unwrap();
    let err = load(&dir).unwrap_err();
    assert!(
        matches!(
            err,
            Error::LightCount {
                expected: 3,
                found: 4,
                ..
            }
        ),
        "{err}"
    );
    assert_mentions(&err, "light_intensities.txt");
}

#[test]
fn non_image_file_listed_in_filenames() {
    let dir = good_dataset("nonimage");
    std::fs::write(dir.join("notes.txt"), "not a picture").unwrap();
    std::fs::write(dir.join("filenames.txt"), "001.png\nnotes.txt\n003.png\n").unwrap();
    let err = load(&dir).unwrap_err();
    assert!(
        matches!(&err, Error::Decode { path, .. } if path.ends_with("notes.txt")),
        "{err}"
    );
}

#[test]
fn corrupt_png_is_named() {
    let dir = good_dataset("corrupt");
    std::fs::write(dir.join("002.png"), b"\x89PNG\r\n\x1a\ngarbage").unwrap();
    std::fs::remove_file(dir.join("filenames.txt")).unwrap();
    let err = load(&dir).unwrap_err();
    assert!(
        matches!(&err, Error::Decode { path, .. } if path.ends_with("002.png")),
        "{err}"
    );
}

#[test]
fn listed_file_that_does_not_exist() {
    let dir = good_dataset("listedmissing");
    std::fs::write(dir.join("filenames.txt"), "001.png\n002.png\n007.png\n").unwrap();
    let err = load(&dir).unwrap_err();
    assert!(
        matches!(&err, Error::NotFound { path, .. } if path.ends_with("007.png")),
        "{err}"
    );
}

#[test]
fn mask_of_the_wrong_size() {
    let dir = good_dataset("masksize");
    image::GrayImage::from_pixel(4, 4, image::Luma([255]))
        .save(dir.join("mask.png"))
        .unwrap();
    let err = load(&dir).unwrap_err();
    assert!(
        matches!(
            err,
            Error::SizeMismatch {
                found_h: 4,
                expected_h: 3,
                ..
            }
        ),
        "{err}"
    );
    assert_mentions(&err, "mask.png");
}

#[test]
fn empty_mask() {
    let dir = good_dataset("maskempty");
    image::GrayImage::new(4, 3)
        .save(dir.join("mask.png"))
        .unwrap();
    let err = load(&dir).unwrap_err();
    assert!(matches!(err, Error::EmptyMask { .. }), "{err}");
    assert_mentions(&err, "mask.png");
}

#[test]
fn missing_mask_when_one_is_required() {
    let dir = good_dataset("maskreq");
    std::fs::remove_file(dir.join("mask.png")).unwrap();
    assert!(load(&dir).unwrap().mask.is_none());
    let opts = LoadOptions {
        require_mask: true,
        ..LoadOptions::default()
    };
    let err = io::load_dataset(&dir, &opts).unwrap_err();
    assert!(
        matches!(&err, Error::NotFound { path, .. } if path.ends_with("mask.png")),
        "{err}"
    );
}

#[test]
fn missing_lights_when_required() {
    let dir = good_dataset("lightsreq");
    std::fs::remove_file(dir.join("light_directions.txt")).unwrap();
    let opts = LoadOptions {
        require_lights: true,
        ..LoadOptions::default()
    };
    let err = io::load_dataset(&dir, &opts).unwrap_err();
    assert_mentions(&err, "light_directions.txt");
}

/// Each bad `light_directions.txt` gives a parse error on the right line.
#[test]
fn bad_light_direction_lines() {
    let cases = [
        ("0 0 1\nnan 0 1\n0 0.2 1\n", 2, "nan"),
        ("0 0 1\n0 0 1\n0 0.2 abc\n", 3, "abc"),
        ("# header\n0 0 1 0\n0 0 1\n0 0 1\n", 2, "4 numbers"),
        ("0 0 1\n\n0 0 0\n0 0 1\n", 3, "zero-length"),
        ("inf 0 1\n0 0 1\n0 0 1\n", 1, "inf"),
    ];
    for (i, (text, line, needle)) in cases.iter().enumerate() {
        let dir = good_dataset(&format!("dirs{i}"));
        std::fs::write(dir.join("light_directions.txt"), text).unwrap();
        let err = load(&dir).unwrap_err();
        match &err {
            Error::Parse { path, line: l, .. } => {
                assert!(path.ends_with("light_directions.txt"));
                assert_eq!(l, line, "{err}");
            }
            other => panic!("case {i}: expected a parse error, got {other}"),
        }
        assert_mentions(&err, needle);
    }
}

#[test]
fn bad_intensities() {
    for (i, text) in ["1\n-1\n1\n", "1\n1 2\n1\n", "1\n1\nx\n"]
        .iter()
        .enumerate()
    {
        let dir = good_dataset(&format!("int{i}"));
        std::fs::write(dir.join("light_intensities.txt"), text).unwrap();
        let err = load(&dir).unwrap_err();
        assert!(
            matches!(&err, Error::Parse { path, .. } if path.ends_with("light_intensities.txt")),
            "{err}"
        );
    }
}

#[test]
fn bad_arrays_and_files() {
    let dir = tmp_dir("arrays");
    let gray = Image::filled(3, 2, 1.0f32);
    io::write_gray_npy(&dir.join("g.npy"), &gray).unwrap();
    // A 2-D array is not a normal map.
    let err = io::read_normals_npy(&dir.join("g.npy")).unwrap_err();
    assert!(matches!(err, Error::Decode { .. }), "{err}");
    assert_mentions(&err, "(H, W, 3)");
    // Garbage is not an npy file; a missing file is named.
    std::fs::write(dir.join("junk.npy"), b"junk").unwrap();
    assert!(matches!(
        io::read_gray_npy(&dir.join("junk.npy")),
        Err(Error::Decode { .. })
    ));
    assert!(matches!(
        io::read_mask_any(&dir.join("junk.npy")),
        Err(Error::Decode { .. })
    ));
    let err = io::read_mask_any(&dir.join("none.png")).unwrap_err();
    assert!(matches!(err, Error::NotFound { .. }), "{err}");
    let err = io::read_gray_image(&dir.join("g.npy"), None).unwrap_err();
    assert!(matches!(err, Error::Decode { .. }), "{err}");
    let err = io::read_gray_image(&dir.join("g.npy"), Some([1.0, 0.0, 1.0])).unwrap_err();
    assert_mentions(&err, "positive");
}

#[test]
fn write_dataset_refuses_bad_arguments() {
    let dir = tmp_dir("writebad");
    let stack = ImageStack::zeros(2, 2, 2);
    let lights = Lights::from_directions(vec![[0.0, 0.0, 1.0]]);
    let err = io::write_dataset(&dir.join("a"), &stack, &lights, None, 8).unwrap_err();
    assert!(
        matches!(
            err,
            Error::LightCount {
                expected: 2,
                found: 1,
                ..
            }
        ),
        "{err}"
    );
    let lights = Lights::from_directions(vec![[0.0, 0.0, 1.0]; 2]);
    assert!(io::write_dataset(&dir.join("b"), &stack, &lights, None, 12).is_err());
    let mask = Image::filled(3, 2, true);
    let err = io::write_dataset(&dir.join("c"), &stack, &lights, Some(&mask), 8).unwrap_err();
    assert!(matches!(err, Error::SizeMismatch { .. }), "{err}");
    assert!(!dir.join("a").exists() && !dir.join("b").exists() && !dir.join("c").exists());
}
