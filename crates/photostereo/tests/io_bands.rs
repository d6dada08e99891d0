//! Reading light images by row bands (`io::bands`) gives exactly the values of the
//! whole-stack loader, for PNGs read row by row and for files decoded whole (TIFF).

mod common;
use photostereo::image::ImageStack;
use photostereo::io::{self, LoadOptions};
use std::path::{Path, PathBuf};

fn data_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn tmp_dir(name: &str) -> PathBuf {
    common::temp_dir("io-bands", name)
}

/// Read `dir` by bands of `rows` rows and stitch them back into one stack.
fn stitched(dir: &Path, rows: usize) -> ImageStack {
    let ds = io::open_dataset_bands(dir, &LoadOptions::default()).unwrap();
    let mut reader = ds.reader().unwrap();
    let (w, h, k) = (ds.header.width, ds.header.height, ds.header.k());
    let mut data = Vec::with_capacity(w * h * k);
    let mut names = Vec::new();
    while reader.next_row() < h {
        let band = reader.next_band(rows).unwrap();
        assert_eq!((band.width, band.k), (w, k));
        data.extend_from_slice(&band.data);
        names = band.names;
    }
    assert!(reader.next_band(rows).is_err(), "no band past the last row");
    ImageStack {
        width: w,
        height: h,
        k,
        data,
        names,
    }
}

fn assert_same(dir: &Path, rows: &[usize]) {
    let whole = io::load_dataset(dir, &LoadOptions::default()).unwrap();
    for &r in rows {
        let banded = stitched(dir, r);
        assert_eq!(banded.data.len(), whole.stack.data.len());
        let diff = banded
            .data
            .iter()
            .zip(&whole.stack.data)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(diff, 0, "{}: bands of {r} rows differ", dir.display());
        assert_eq!(banded.names, whole.stack.names);
    }
}

#[test]
fn png16_gray_bands_equal_the_whole_stack() {
    let dir = data_dir("mitsuba_textured_plastic");
    let ds = io::open_dataset_bands(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(ds.header.bit_depth, 16);
    assert!(ds.header.layout.iter().all(|&(ch, rows)| ch == 1 && rows));
    // bands that divide the height, bands that do not, one band, one row
    assert_same(&dir, &[64, 37, 256, 1]);
}

#[test]
fn png8_rgb_bands_with_intensities_equal_the_whole_stack() {
    let dir = data_dir("tiny_rgb");
    let ds = io::open_dataset_bands(&dir, &LoadOptions::default()).unwrap();
    assert!(ds.scales.iter().all(Option::is_some), "intensities applied");
    assert_same(&dir, &[1, 4, 6]);
}

#[test]
fn tiff_images_are_decoded_whole_and_banded_the_same() {
    let src = data_dir("mitsuba_textured_plastic");
    let dir = tmp_dir("tiff");
    let names: Vec<String> = (1..=6).map(|i| format!("{i:03}.tif")).collect();
    for (i, n) in names.iter().enumerate() {
        let img = image::open(src.join(format!("{:03}.png", i + 1))).unwrap();
        img.save(dir.join(n)).unwrap();
    }
    let ds = io::open_dataset_bands(&dir, &LoadOptions::default()).unwrap();
    assert!(ds.header.layout.iter().all(|&(_, rows)| !rows));
    assert_eq!(
        ds.header.whole_bytes(),
        6 * 256 * 256 * 2,
        "kept at 16 bits"
    );
    assert_same(&dir, &[50, 256]);
}

#[test]
fn headers_of_different_sizes_are_refused_before_decoding() {
    let src = data_dir("mitsuba_textured_plastic");
    let dir = tmp_dir("sizes");
    for i in 1..=3 {
        let img = image::open(src.join(format!("{i:03}.png"))).unwrap();
        let img = if i == 3 {
            img.crop_imm(0, 0, 100, 80)
        } else {
            img
        };
        img.save(dir.join(format!("{i:03}.png"))).unwrap();
    }
    let err = io::open_dataset_bands(&dir, &LoadOptions::default()).unwrap_err();
    let text = err.to_string();
    assert!(text.contains("003.png"), "{text}");
    assert!(text.contains("100") && text.contains("80"), "{text}");
}
