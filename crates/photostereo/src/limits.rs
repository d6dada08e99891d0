//! The limits of every reader, in one place (the readers are in [`crate::io`]; the
//! lookup-table format checks a table's window against [`MAX_SIDE`] too).
//!
//! A file's header states how much data follows (an `.npy` shape, a PNG/TIFF size, a
//! table's window). Readers check that claim against the file's real size and against
//! the limits below *before* allocating anything of that size, and refuse a file that
//! breaks either with a message naming the file and what it claims. So a damaged or
//! hostile file can make a reader fail, never abort on an impossible allocation.
//!
//! | what | limit | why |
//! |---|---|---|
//! | any file read whole (`.npy`, `.lut`) | [`MAX_FILE_BYTES`] = 4 GiB | 30× a 1024² × 96-light float stack |
//! | text files (lights, intensities, file list, JSON) | [`MAX_TEXT_BYTES`] = 16 MiB | 400 000 light lines |
//! | image side (PNG/TIFF, `.npy` H and W) | [`MAX_SIDE`] = 65 536 px | |
//! | pixels per image or array plane | [`MAX_PIXELS`] = 2^28 (16 384²) | |
//! | decoder allocation per image | [`MAX_DECODE_BYTES`] = 2 GiB | a 16 384² RGBA 16-bit image |
//! | `.npy` header | [`MAX_NPY_HEADER`] = 64 KiB | NumPy writes < 1 KiB |
//!
//! Compressed images (PNG deflate, TIFF LZW) cannot be checked against the file size
//! (deflate reaches 1032:1), so for them the pixel and allocation limits are what
//! bound memory; an `.npy` array and a table must hold exactly the bytes their header
//! claims.

/// Largest file read whole into memory (`.npy` arrays, lookup tables), bytes.
pub const MAX_FILE_BYTES: u64 = 4 << 30;
/// Largest text file (light directions, intensities, file list, JSON side files), bytes.
pub const MAX_TEXT_BYTES: u64 = 16 << 20;
/// Largest width or height of an image or array, pixels.
pub const MAX_SIDE: u64 = 1 << 16;
/// Largest number of pixels of one image or array plane (16 384²).
pub const MAX_PIXELS: u64 = 1 << 28;
/// Largest buffer an image decoder may allocate for one image, bytes.
pub const MAX_DECODE_BYTES: u64 = 2 << 30;
/// Largest `.npy` header (the text dictionary after the magic), bytes.
pub const MAX_NPY_HEADER: u64 = 64 << 10;
