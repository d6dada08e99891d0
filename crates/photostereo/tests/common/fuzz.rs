//! Support of the fuzz tests: a capped global allocator, byte mutations, and valid
//! files to mutate (an `.npy`, a small lookup table, a dataset, PNG and TIFF images).

use photostereo::image::{ImageStack, Lights, Mask};
use photostereo::io::{self, limits};
use photostereo::lut::{BuildOptions, Table};
use photostereo::sphere::Circle;
use proptest::prelude::*;
use proptest::sample::Index;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

// ---------------------------------------------------------------- capped allocator

/// The global allocator of the fuzz binary: refuses (returns null, which aborts the
/// binary with "memory allocation of N bytes failed") any allocation over the cap of
/// the calling thread, or over the decoder limit on threads without a cap (rayon
/// workers decoding images).
pub struct Capped;

static REFUSED: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static CAP: Cell<usize> = const { Cell::new(0) };
}

fn over(size: usize) -> bool {
    let cap = CAP.try_with(Cell::get).unwrap_or(0);
    let cap = if cap == 0 {
        limits::MAX_DECODE_BYTES as usize
    } else {
        cap
    };
    if size > cap {
        REFUSED.fetch_max(size, Ordering::Relaxed);
        return true;
    }
    false
}

// SAFETY: every call forwards to `System` unchanged, or returns null (allowed: an
// allocation failure).
unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if over(layout.size()) {
            return std::ptr::null_mut();
        }
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if over(layout.size()) {
            return std::ptr::null_mut();
        }
        System.alloc_zeroed(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if over(new_size) {
            return std::ptr::null_mut();
        }
        System.realloc(ptr, layout, new_size)
    }
}

/// The largest allocation refused so far (0: none).
pub fn refused() -> usize {
    REFUSED.load(Ordering::Relaxed)
}

/// Caps single allocations of this thread at `bytes` until dropped.
pub struct Cap(usize);

impl Cap {
    pub fn set(bytes: usize) -> Cap {
        Cap(CAP.with(|c| c.replace(bytes)))
    }
}

impl Drop for Cap {
    fn drop(&mut self) {
        CAP.with(|c| c.set(self.0));
    }
}

// ---------------------------------------------------------------- files

/// A fresh, empty directory for `tag` (one per test, reused across its cases).
pub fn fresh_dir(tag: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("io_fuzz")
        .join(format!("{tag}-{}", N.fetch_add(1, Ordering::Relaxed)));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Write `bytes` to `name` in the directory of `tag` (created once per test).
pub fn write_case(tag: &str, name: &str, bytes: &[u8]) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("io_fuzz")
        .join(format!("case-{tag}"));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// An `.npy` file (version 1) with this element type, shape text and data bytes.
pub fn npy_bytes(descr: &str, shape: &str, data: &[u8]) -> Vec<u8> {
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(data);
    out
}

// ---------------------------------------------------------------- mutations

/// One way of damaging a file.
#[derive(Clone, Debug)]
pub enum Mutation {
    /// Cut the file at this point.
    Truncate(Index),
    /// Flip these bits (byte, bit).
    Flip(Vec<(Index, u8)>),
    /// Overwrite a run starting here with these bytes (a damaged sector).
    Overwrite(Index, Vec<u8>),
    /// Invert a run of this many bytes in the middle.
    InvertMiddle(usize),
    /// Insert these bytes here.
    Insert(Index, Vec<u8>),
    /// Replace the whole file by these bytes.
    Replace(Vec<u8>),
}

pub fn mutation() -> impl Strategy<Value = Mutation> {
    let bytes = |n| proptest::collection::vec(any::<u8>(), 1..n);
    prop_oneof![
        any::<Index>().prop_map(Mutation::Truncate),
        proptest::collection::vec((any::<Index>(), 0u8..8), 1..64).prop_map(Mutation::Flip),
        (any::<Index>(), bytes(129)).prop_map(|(i, b)| Mutation::Overwrite(i, b)),
        (1usize..=128).prop_map(Mutation::InvertMiddle),
        (any::<Index>(), bytes(65)).prop_map(|(i, b)| Mutation::Insert(i, b)),
        proptest::collection::vec(any::<u8>(), 0..512).prop_map(Mutation::Replace),
    ]
}

impl Mutation {
    pub fn apply(&self, original: &[u8]) -> Vec<u8> {
        let mut b = original.to_vec();
        if b.is_empty() {
            return b;
        }
        let n = b.len();
        match self {
            Mutation::Truncate(i) => b.truncate(i.index(n)),
            Mutation::Flip(flips) => {
                for (i, bit) in flips {
                    b[i.index(n)] ^= 1 << bit;
                }
            }
            Mutation::Overwrite(i, run) => {
                let at = i.index(n);
                for (dst, src) in b[at..].iter_mut().zip(run) {
                    *dst = *src;
                }
            }
            Mutation::InvertMiddle(len) => {
                let len = (*len).min(n);
                let at = (n - len) / 2;
                for x in &mut b[at..at + len] {
                    *x = !*x;
                }
            }
            Mutation::Insert(i, run) => {
                let at = i.index(n);
                b.splice(at..at, run.iter().copied());
            }
            Mutation::Replace(all) => b = all.clone(),
        }
        b
    }
}

// ---------------------------------------------------------------- a small table

/// A table of a radius-12 Lambertian sphere under 6 lights (window 24x24).
pub fn small_table() -> Table {
    let k = 6;
    let lights: Vec<[f32; 3]> = (0..k)
        .map(|i| {
            let az = i as f32 / k as f32 * std::f32::consts::TAU;
            let (s, c) = az.sin_cos();
            [0.6 * c, 0.6 * s, 0.8]
        })
        .collect();
    let size = 30;
    let circle = Circle {
        cx: 15.3,
        cy: 14.8,
        radius: 12.0,
    };
    let mut stack = ImageStack::zeros(size, size, k);
    for r in 0..size {
        for c in 0..size {
            if let Some(n) = circle.normal_at(r, c, 0.0) {
                let px = stack.pixel_flat_mut(r * size + c);
                for (o, l) in px.iter_mut().zip(&lights) {
                    *o = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]).max(0.0);
                }
            }
        }
    }
    Table::build(&stack, &circle, &BuildOptions::default()).unwrap()
}

/// The bytes of [`small_table`] (built once).
pub fn table_bytes() -> &'static Vec<u8> {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| small_table().to_bytes())
}

/// (width, height, k) of the small table's window.
pub fn small_table_dims() -> (usize, usize, usize) {
    let t = small_table();
    (t.window.stack.width, t.window.stack.height, t.k)
}

/// The small table's content with its JSON header claiming a window of w x h x k.
pub fn table_content_claiming(w: usize, h: usize, k: usize) -> Vec<u8> {
    let content = &table_bytes()[photostereo::lut::format::FRAME_LEN..];
    let hlen = u32::from_le_bytes(content[..4].try_into().unwrap()) as usize;
    let mut json: serde_json::Value = serde_json::from_slice(&content[4..4 + hlen]).unwrap();
    json["window"]["width"] = w.into();
    json["window"]["height"] = h.into();
    json["k"] = k.into();
    json["names"] = serde_json::Value::Array(Vec::new());
    let text = serde_json::to_vec(&json).unwrap();
    let mut out = (text.len() as u32).to_le_bytes().to_vec();
    out.extend_from_slice(&text);
    out.extend_from_slice(&content[4 + hlen..]);
    out
}

// ---------------------------------------------------------------- a dataset

pub const DATASET_W: u32 = 6;
pub const DATASET_H: u32 = 5;
pub const DATASET_FILES: [&str; 8] = [
    "001.png",
    "002.png",
    "003.png",
    "004.png",
    "filenames.txt",
    "light_directions.txt",
    "light_intensities.txt",
    "mask.png",
];

/// A fresh copy of a valid 4-image 6x5 dataset with lights, intensities and mask.
pub fn fresh_dataset(tag: &str) -> PathBuf {
    static TEMPLATE: OnceLock<PathBuf> = OnceLock::new();
    let template = TEMPLATE.get_or_init(|| {
        let dir = fresh_dir("dataset-template");
        let (w, h) = (DATASET_W as usize, DATASET_H as usize);
        let mut stack = ImageStack::zeros(w, h, 4);
        for (i, v) in stack.data.iter_mut().enumerate() {
            *v = ((i * 37) % 101) as f32 / 100.0;
        }
        let mut lights = Lights::from_directions(vec![
            [0.3, 0.1, 1.0],
            [-0.3, 0.2, 1.0],
            [0.1, -0.4, 1.0],
            [0.0, 0.3, 1.0],
        ]);
        lights.intensities = vec![1.0, 0.5, 2.0, 1.5];
        let mut mask = Mask::full(w, h);
        mask.data[0] = false;
        io::write_dataset(&dir, &stack, &lights, Some(&mask), 8).unwrap();
        dir
    });
    let dir = fresh_dir(tag);
    for f in DATASET_FILES {
        std::fs::copy(template.join(f), dir.join(f)).unwrap();
    }
    dir
}

/// A PNG whose IHDR claims `w` x `h` (with a correct chunk checksum).
pub fn png_claiming(png: &[u8], w: u32, h: u32) -> Vec<u8> {
    let mut b = png.to_vec();
    assert_eq!(&b[12..16], b"IHDR");
    b[16..20].copy_from_slice(&w.to_be_bytes());
    b[20..24].copy_from_slice(&h.to_be_bytes());
    let crc = crc32fast::hash(&b[12..29]);
    b[29..33].copy_from_slice(&crc.to_be_bytes());
    b
}

/// A valid 7x5 TIFF: float RGB (one NaN sample) or 16-bit gray.
pub fn tiff_bytes(float: bool) -> Vec<u8> {
    let (w, h) = (7u32, 5u32);
    let img = if float {
        let mut data: Vec<f32> = (0..w * h * 3).map(|i| i as f32 / 100.0).collect();
        data[4] = f32::NAN;
        image::DynamicImage::ImageRgb32F(image::ImageBuffer::from_raw(w, h, data).unwrap())
    } else {
        let data: Vec<u16> = (0..w * h).map(|i| (i * 1000) as u16).collect();
        image::DynamicImage::ImageLuma16(image::ImageBuffer::from_raw(w, h, data).unwrap())
    };
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Tiff).unwrap();
    out.into_inner()
}

/// A little-endian TIFF whose first IFD claims `w` x `h` (tags 256 and 257 as LONG).
pub fn tiff_claiming(tiff: &[u8], w: u32, h: u32) -> Vec<u8> {
    let mut b = tiff.to_vec();
    assert_eq!(&b[..4], b"II*\0");
    let ifd = u32::from_le_bytes(b[4..8].try_into().unwrap()) as usize;
    let count = u16::from_le_bytes(b[ifd..ifd + 2].try_into().unwrap()) as usize;
    for e in 0..count {
        let at = ifd + 2 + 12 * e;
        let tag = u16::from_le_bytes(b[at..at + 2].try_into().unwrap());
        let value = match tag {
            256 => w,
            257 => h,
            _ => continue,
        };
        b[at + 2..at + 4].copy_from_slice(&4u16.to_le_bytes());
        b[at + 4..at + 8].copy_from_slice(&1u32.to_le_bytes());
        b[at + 8..at + 12].copy_from_slice(&value.to_le_bytes());
    }
    b
}
