//! Every bad input to `io` gives a clear error naming the file; none panics.

mod common;
use photostereo::image::{Image, ImageStack, Lights};
use photostereo::io::{self, LoadOptions};
use photostereo::Error;
use std::path::{Path, PathBuf};

fn tmp_dir(name: &str) -> PathBuf {
    common::temp_dir("io-errors", name)
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

/// The good dataset `name`, changed by `edit`, loaded with `opts`: the error it must give.
fn error_after_with(name: &str, opts: &LoadOptions, edit: impl FnOnce(&Path)) -> Error {
    let dir = good_dataset(name);
    edit(&dir);
    io::load_dataset(&dir, opts).unwrap_err()
}

/// [`error_after_with`] with the default load options.
fn error_after(name: &str, edit: impl FnOnce(&Path)) -> Error {
    error_after_with(name, &LoadOptions::default(), edit)
}

/// Load options that require the mask and/or the light directions.
fn requiring(mask: bool, lights: bool) -> LoadOptions {
    LoadOptions {
        require_mask: mask,
        require_lights: lights,
        ..LoadOptions::default()
    }
}

/// Replace (or create) the text file `file` in `dir`.
fn write(dir: &Path, file: &str, text: &str) {
    std::fs::write(dir.join(file), text).unwrap();
}

fn remove(dir: &Path, file: &str) {
    std::fs::remove_file(dir.join(file)).unwrap();
}

/// Save an 8-bit grey image as `file` in `dir`.
fn save_gray(dir: &Path, file: &str, img: image::GrayImage) {
    img.save(dir.join(file)).unwrap();
}

/// The error message must mention `needle`.
fn assert_mentions(err: &Error, needle: &str) {
    let msg = err.to_string();
    assert!(
        msg.contains(needle),
        "message `{msg}` does not mention `{needle}`"
    );
}

/// The error is `LightCount` with these counts and names `file`.
fn assert_light_count(err: &Error, expected: usize, found: usize, file: &str) {
    assert!(
        matches!(err, Error::LightCount { expected: e, found: f, .. } if (*e, *f) == (expected, found)),
        "{err}"
    );
    assert_mentions(err, file);
}

/// The error is `Decode` for a path ending in `file`.
fn assert_decode_of(err: &Error, file: &str) {
    assert!(
        matches!(err, Error::Decode { path, .. } if path.ends_with(file)),
        "{err}"
    );
}

/// The error is `NotFound` for a path ending in `file`.
fn assert_not_found(err: &Error, file: &str) {
    assert!(
        matches!(err, Error::NotFound { path, .. } if path.ends_with(file)),
        "{err}"
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
    write(&dir, "light_directions.txt", "0 0 1\n");
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
    let err = error_after("sizes", |d| {
        save_gray(d, "002.png", image::GrayImage::new(5, 3))
    });
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
    let err = error_after("depths", |d| {
        let img = image::ImageBuffer::<image::Luma<u16>, _>::new(4, 3);
        img.save(d.join("003.png")).unwrap();
    });
    assert_mentions(&err, "003.png");
    assert_mentions(&err, "16-bit");
}

#[test]
fn wrong_number_of_light_directions() {
    let err = error_after("ndirs", |d| {
        write(d, "light_directions.txt", "0 0 1\n0.1 0 1\n")
    });
    assert_light_count(&err, 3, 2, "light_directions.txt");
}

#[test]
fn wrong_number_of_intensities() {
    let err = error_after("nint", |d| {
        write(d, "light_intensities.txt", "1\n1\n1\n1\n")
    });
    assert_light_count(&err, 3, 4, "light_intensities.txt");
}

#[test]
fn non_image_file_listed_in_filenames() {
    let err = error_after("nonimage", |d| {
        write(d, "notes.txt", "not a picture");
        write(d, "filenames.txt", "001.png\nnotes.txt\n003.png\n");
    });
    assert_decode_of(&err, "notes.txt");
}

#[test]
fn corrupt_png_is_named() {
    let err = error_after("corrupt", |d| {
        std::fs::write(d.join("002.png"), b"\x89PNG\r\n\x1a\ngarbage").unwrap();
        remove(d, "filenames.txt");
    });
    assert_decode_of(&err, "002.png");
}

#[test]
fn listed_file_that_does_not_exist() {
    let err = error_after("listedmissing", |d| {
        write(d, "filenames.txt", "001.png\n002.png\n007.png\n")
    });
    assert_not_found(&err, "007.png");
}

#[test]
fn mask_of_the_wrong_size() {
    let err = error_after("masksize", |d| {
        let full = image::GrayImage::from_pixel(4, 4, image::Luma([255]));
        save_gray(d, "mask.png", full);
    });
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
    let err = error_after("maskempty", |d| {
        save_gray(d, "mask.png", image::GrayImage::new(4, 3))
    });
    assert!(matches!(err, Error::EmptyMask { .. }), "{err}");
    assert_mentions(&err, "mask.png");
}

#[test]
fn missing_mask_when_one_is_required() {
    let err = error_after_with("maskreq", &requiring(true, false), |d| {
        remove(d, "mask.png");
        // the mask is optional unless required
        assert!(load(d).unwrap().mask.is_none());
    });
    assert_not_found(&err, "mask.png");
}

#[test]
fn missing_lights_when_required() {
    let err = error_after_with("lightsreq", &requiring(false, true), |d| {
        remove(d, "light_directions.txt")
    });
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
        let err = error_after(&format!("dirs{i}"), |d| {
            write(d, "light_directions.txt", text)
        });
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
        let err = error_after(&format!("int{i}"), |d| {
            write(d, "light_intensities.txt", text)
        });
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
    write(&dir, "junk.npy", "junk");
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
