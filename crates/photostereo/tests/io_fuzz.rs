//! Fuzzed readers: arbitrary and mutated bytes (truncations, bit flips, overwritten
//! runs, huge claimed sizes) fed to every reader — `.npy`, the dataset loader (light
//! directions, intensities, file list, PNG and TIFF images), the lookup table. Each
//! must return `Ok` or `Err`, never panic, never abort, and never ask for more memory
//! than the file holds (arrays, tables, text) or than the decoder limit (images): the
//! global allocator of this test binary refuses, loudly, any allocation over the cap
//! of the running test, which would abort the binary and fail the run.
//!
//! The two holes of issue 14 are cases here: an `.npy` whose header claims
//! (100000, 100000, 3) float32 and holds no data (`npy_header_claiming_…`, and the
//! `huge shape` strategy), and a table with 64 bytes flipped in its middle
//! (`table_with_64_bytes_flipped…`, and the `Overwrite` mutation).

mod common;
use common::fuzz::*;

/// The fuzz binary's allocator (`common::fuzz::Capped`): refuses allocations over the
/// calling thread's cap.
#[global_allocator]
static ALLOCATOR: Capped = Capped;
use photostereo::io::{self, limits, LoadOptions};
use photostereo::lut::{format, Table};
use proptest::prelude::*;

// ---------------------------------------------------------------- .npy

#[test]
fn npy_header_claiming_100000x100000x3_with_no_data_is_refused() {
    let dir = fresh_dir("npy-hole");
    let path = dir.join("claims.npy");
    std::fs::write(&path, npy_bytes("<f4", "(100000, 100000, 3)", &[])).unwrap();
    let _cap = Cap::set(1 << 20);
    let err = io::read_normals_npy(&path).unwrap_err().to_string();
    assert!(err.contains("claims.npy"), "{err}");
    assert!(err.contains("(100000, 100000, 3)") || err.contains("[100000, 100000, 3]"));
    assert!(err.contains("holds 0 bytes"), "{err}");
    for e in [
        io::read_gray_npy(&path).unwrap_err(),
        io::read_mask_npy(&path).unwrap_err(),
    ] {
        assert!(e.to_string().contains("claims.npy"), "{e}");
    }
}

#[test]
fn valid_npy_files_still_read() {
    let dir = fresh_dir("npy-valid");
    let path = dir.join("n.npy");
    let data: Vec<u8> = (0..2 * 3 * 3)
        .flat_map(|i| (i as f32).to_le_bytes())
        .collect();
    std::fs::write(&path, npy_bytes("<f4", "(2, 3, 3)", &data)).unwrap();
    let n = io::read_normals_npy(&path).unwrap();
    assert_eq!((n.width, n.height, n.data[5]), (3, 2, [15.0, 16.0, 17.0]));
    let data: Vec<u8> = (0..6).flat_map(|i| (i as f64).to_le_bytes()).collect();
    std::fs::write(&path, npy_bytes("<f8", "(2, 3)", &data)).unwrap();
    assert_eq!(io::read_gray_npy(&path).unwrap().data[4], 4.0);
    std::fs::write(&path, npy_bytes("|u1", "(2, 3)", &[0, 1, 0, 2, 0, 0])).unwrap();
    let m = io::read_mask_npy(&path).unwrap();
    assert_eq!(m.data, [false, true, false, true, false, false]);
}

/// A valid (3, 4, 3) float32 normal map file.
fn npy_normals() -> Vec<u8> {
    let data: Vec<u8> = (0..36)
        .flat_map(|i| (i as f32 * 0.1).to_le_bytes())
        .collect();
    npy_bytes("<f4", "(3, 4, 3)", &data)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn npy_mutations_are_errors_or_arrays(m in mutation()) {
        let original = npy_normals();
        let bytes = m.apply(&original);
        let path = write_case("npy-mut", "n.npy", &bytes);
        let _cap = Cap::set(8 * bytes.len() + (1 << 16));
        let r = io::read_normals_npy(&path);
        if bytes.len() < original.len() {
            prop_assert!(r.is_err(), "truncated file read: {m:?}");
        }
        if let Ok(n) = &r {
            prop_assert_eq!(n.data.len(), n.width * n.height);
        }
        let _ = io::read_gray_npy(&path);
        let _ = io::read_mask_npy(&path);
    }

    #[test]
    fn npy_huge_shapes_are_refused(
        h in 1u64..=u64::MAX, w in 1u64..=1 << 40, c in 1u64..=4, held in 0usize..64,
    ) {
        prop_assume!((h, w, c) != (1, 1, 1) || held != 4);
        let bytes = npy_bytes("<f4", &format!("({h}, {w}, {c})"), &vec![0u8; held * 4]);
        let path = write_case("npy-huge", "h.npy", &bytes);
        let _cap = Cap::set(8 * bytes.len() + (1 << 16));
        let claimed = (h as u128) * (w as u128) * (c as u128);
        let r = io::read_normals_npy(&path);
        if claimed != held as u128 {
            let e = r.unwrap_err().to_string();
            prop_assert!(e.contains("h.npy") && e.contains("claims"), "{}", e);
        }
    }

    #[test]
    fn npy_arbitrary_bytes_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
        let path = write_case("npy-any", "a.npy", &bytes);
        let _cap = Cap::set(8 * bytes.len() + (1 << 16));
        prop_assert!(io::read_normals_npy(&path).is_err());
        prop_assert!(io::read_mask_npy(&path).is_err());
    }
}

// ---------------------------------------------------------------- the table

#[test]
fn table_with_64_bytes_flipped_in_its_middle_is_refused() {
    let table = small_table();
    let bytes = table.to_bytes();
    assert_eq!(Table::from_bytes(&bytes).unwrap(), table);
    assert_eq!(small_table(), table);
    let mut bad = bytes.clone();
    let mid = bad.len() / 2;
    for b in &mut bad[mid - 32..mid + 32] {
        *b = !*b;
    }
    let err = Table::from_bytes(&bad).unwrap_err().to_string();
    assert!(err.contains("damaged or not a photostereo table"), "{err}");
}

#[test]
fn table_outline_sample_round_trips_and_older_files_read_without_it() {
    let table = small_table();
    let sample = table
        .outline
        .clone()
        .expect("a built table keeps its outline");
    assert_eq!(sample.tuples.len(), table.k * sample.normals.len());
    assert_eq!(
        Table::from_bytes(&table.to_bytes()).unwrap().outline,
        Some(sample)
    );
    // a file written before the outline was kept: no `outline` in its header
    let older = Table {
        outline: None,
        ..table.clone()
    };
    assert_eq!(Table::from_bytes(&older.to_bytes()).unwrap().outline, None);
    // an outline whose tuples do not hold K samples per pixel is refused by name
    let mut bad = table.clone();
    if let Some(o) = bad.outline.as_mut() {
        o.tuples.pop();
    }
    let e = Table::from_bytes(&bad.to_bytes()).unwrap_err().to_string();
    assert!(e.contains("outline sample"), "{e}");
    let mut bad = table;
    if let Some(o) = bad.outline.as_mut() {
        o.normals[0][2] = f32::NAN;
    }
    let e = Table::from_bytes(&bad.to_bytes()).unwrap_err().to_string();
    assert!(
        e.contains("outline sample") || e.contains("bad header"),
        "{e}"
    );
}

#[test]
fn table_versions_old_and_future_are_refused_by_name() {
    let bytes = small_table().to_bytes();
    let content = &bytes[format::FRAME_LEN..];
    // a version-1 file: magic, version 1, then the content as version 1 laid it out
    let mut v1 = format::MAGIC.to_vec();
    v1.extend_from_slice(&1u32.to_le_bytes());
    v1.extend_from_slice(content);
    let e = Table::from_bytes(&v1).unwrap_err().to_string();
    assert!(
        e.contains("version 1") && e.contains("re-run `photostereo calibrate`"),
        "{e}"
    );
    let mut v3 = bytes.clone();
    v3[8..12].copy_from_slice(&3u32.to_le_bytes());
    let e = Table::from_bytes(&v3).unwrap_err().to_string();
    assert!(
        e.contains("version 3") && e.contains("update photostereo"),
        "{e}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any change to a table file is an error: the checksum covers all of the content.
    #[test]
    fn table_mutations_are_always_errors(m in mutation()) {
        let original = table_bytes();
        let bytes = m.apply(original);
        prop_assume!(bytes != *original);
        let _cap = Cap::set(8 * bytes.len() + (1 << 20));
        let e = Table::from_bytes(&bytes);
        prop_assert!(e.is_err(), "{:?} accepted", m);
    }

    /// Content that passes the checksum (re-framed after the mutation) is still
    /// checked: never a panic, and sizes come from the bytes present.
    #[test]
    fn reframed_table_content_mutations_never_panic(m in mutation()) {
        let content = &table_bytes()[format::FRAME_LEN..];
        let bytes = format::frame(&m.apply(content));
        let _cap = Cap::set(8 * bytes.len() + (1 << 20));
        let _ = Table::from_bytes(&bytes);
    }

    #[test]
    fn table_windows_claiming_huge_sizes_are_refused(
        w in 2usize..=usize::MAX, h in 2usize..=usize::MAX, k in 0usize..=usize::MAX,
    ) {
        let bytes = format::frame(&table_content_claiming(w, h, k));
        let _cap = Cap::set(8 * bytes.len() + (1 << 20));
        prop_assume!((w, h, k) != small_table_dims());
        let e = Table::from_bytes(&bytes).unwrap_err().to_string();
        prop_assert!(e.contains("lookup table data"), "{}", e);
    }
}

// ---------------------------------------------------------------- text files

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn light_text_files_of_any_text_parse_or_are_refused(text in "[0-9eE+\\-., \t\n#a-z]{0,200}") {
        let path = write_case("text", "light_directions.txt", text.as_bytes());
        let _cap = Cap::set(64 * text.len() + (1 << 16));
        if let Ok(l) = io::read_lights(&path) {
            prop_assert!(l.directions.iter().all(|d| d.iter().all(|v| v.is_finite())));
            let norms = l.directions.iter().map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt());
            prop_assert!(norms.into_iter().all(|n| (n - 1.0).abs() < 1e-5));
        }
        if let Ok(v) = io::read_intensities(&path) {
            prop_assert!(v.iter().flatten().all(|x| x.is_finite() && *x > 0.0));
        }
    }
}

#[test]
fn oversized_text_files_are_refused_before_reading() {
    let dir = fresh_dir("text-big");
    let path = dir.join("light_directions.txt");
    let line = b"0 0 1\n".repeat((limits::MAX_TEXT_BYTES as usize) / 6 + 1);
    std::fs::write(&path, &line).unwrap();
    let _cap = Cap::set(1 << 20);
    let e = io::read_lights(&path).unwrap_err().to_string();
    assert!(
        e.contains("light_directions.txt") && e.contains("over the limit"),
        "{e}"
    );
}

// ---------------------------------------------------------------- the dataset loader

proptest! {
    #![proptest_config(ProptestConfig::with_cases(160))]

    /// One file of a valid 4-image dataset mutated: the loader returns a consistent
    /// dataset or an error.
    #[test]
    fn dataset_with_one_mutated_file_loads_or_is_refused(which in 0usize..8, m in mutation()) {
        let dir = fresh_dataset("ds-mut");
        let name = DATASET_FILES[which];
        let original = std::fs::read(dir.join(name)).unwrap();
        std::fs::write(dir.join(name), m.apply(&original)).unwrap();
        let _cap = Cap::set(limits::MAX_DECODE_BYTES as usize);
        if let Ok(d) = io::load_dataset(&dir, &LoadOptions::default()) {
            prop_assert_eq!(d.stack.data.len(), d.stack.width * d.stack.height * d.stack.k);
            prop_assert!(d.lights.is_none_or(|l| l.len() == d.stack.k));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A light image whose header claims another size (up to the PNG maximum of
    /// 2^31 − 1 per side), with a correct chunk checksum: refused.
    #[test]
    fn png_header_claiming_any_size_is_refused(w in 1u32..=i32::MAX as u32, h in 1u32..=i32::MAX as u32) {
        prop_assume!((w, h) != (DATASET_W, DATASET_H));
        let dir = fresh_dataset("ds-png");
        let path = dir.join("002.png");
        let png = std::fs::read(&path).unwrap();
        std::fs::write(&path, png_claiming(&png, w, h)).unwrap();
        let _cap = Cap::set(limits::MAX_DECODE_BYTES as usize);
        let e = io::load_dataset(&dir, &LoadOptions::default()).unwrap_err().to_string();
        prop_assert!(e.contains("002.png"), "{}", e);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Float and 16-bit TIFFs mutated, or claiming any size: no panic, bounded memory.
    #[test]
    fn tiff_mutations_and_huge_sizes_are_errors_or_images(
        m in mutation(), w in 1u32..=u32::MAX, h in 1u32..=u32::MAX, float in any::<bool>(),
    ) {
        let original = tiff_bytes(float);
        let _cap = Cap::set(limits::MAX_DECODE_BYTES as usize);
        for (case, bytes) in [("mut", m.apply(&original)), ("size", tiff_claiming(&original, w, h))] {
            let path = write_case("tiff", &format!("{case}.tif"), &bytes);
            if let Ok((img, _)) = io::read_gray_image(&path, None) {
                prop_assert_eq!(img.data.len(), img.width * img.height);
                if case == "size" {
                    prop_assert_eq!((img.width as u32, img.height as u32), (w, h));
                }
            }
        }
    }
}

#[test]
fn png_header_claiming_100000x100000_is_refused_fast() {
    let dir = fresh_dataset("ds-png-huge");
    let path = dir.join("002.png");
    let png = std::fs::read(&path).unwrap();
    std::fs::write(&path, png_claiming(&png, 100_000, 100_000)).unwrap();
    let _cap = Cap::set(1 << 24);
    let e = io::load_dataset(&dir, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("002.png") && e.contains("100000x100000"), "{e}");
}

#[test]
fn the_allocation_cap_is_live() {
    // The cap would catch the hole: a refused allocation is recorded (and would abort
    // the binary); here the probe asks through `try_reserve`, which returns an error.
    let _cap = Cap::set(1 << 20);
    let mut v: Vec<u8> = Vec::new();
    assert!(v.try_reserve(2 << 20).is_err());
    assert!(refused() >= 2 << 20);
    assert!(v.try_reserve(1 << 19).is_ok());
}
