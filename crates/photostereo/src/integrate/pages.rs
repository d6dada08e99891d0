//! The big work vectors of the multigrid solver, on transparent huge pages where the
//! system lends them.
//!
//! Why: a multigrid CG iteration streams about ten vectors of the grid's size (weights,
//! residual, iterate, direction, preconditioned residual), a 1024² grid's f64 vector
//! being some 1,900 pages of 4 KiB. Each page costs a fault on its first touch (a few
//! µs in a virtual machine), and the sweeps' walk through ten streams at once misses
//! the TLB at every page boundary. Asking the kernel for 2 MiB pages on these vectors
//! (`madvise(MADV_HUGEPAGE)`, Linux only) takes both away: on a 1024² disk the masked
//! least squares process went from 22.3k page faults to 12.4k (those of the
//! Frankot–Chellappa process) and from about 290–420 ms to 260–280 ms of CPU
//! (docs/benchmarks.md). A big vector's storage is rounded up to whole huge pages (at
//! most 2 MiB more per vector). Where the kernel has transparent huge pages off
//! (`/sys/kernel/mm/transparent_hugepage/enabled` = `never`), or on other systems, the
//! advice is ignored and the vectors are on ordinary pages, as before; the values never
//! depend on it.

use bytemuck::{bytes_of, Pod};
use std::alloc::{alloc, alloc_zeroed, dealloc, handle_alloc_error, Layout};
use std::fmt;
use std::ops::{Deref, DerefMut};
use std::ptr::NonNull;

/// Vectors of fewer bytes stay on ordinary pages (a coarse level's vectors are small
/// and touched little).
const MIN_BYTES: usize = 2 << 20;

/// Vectors of more bytes stay on ordinary pages too. Measured (docs/benchmarks.md): on a
/// 2048² grid (17–34 MB per vector) and a 4096² one the huge pages cost more than they
/// saved: the kernel clears each 2 MiB page whole on its first touch, past the caches,
/// where a 4 KiB page is cleared just before the program writes it (system time 0.35 ->
/// 0.75 s at 2048², 1.4 -> 2.4 s at 4096², user time unchanged), and the 4096² peak
/// grew by 27 MB (13 MB with only the coarse levels' vectors advised: these now never
/// are); the gain is on grids of about a million cells.
const MAX_BYTES: usize = 16 << 20;

/// The size and alignment of a huge page (x86-64 and aarch64 with 4 KiB pages).
const HUGE: usize = 2 << 20;

/// A fixed-length vector whose storage starts on a huge-page boundary when it is big,
/// so that huge pages can cover all of it (`Vec`'s storage is aligned for its element
/// only, and a huge page lies on a 2 MiB boundary).
pub(crate) struct Buf<T> {
    ptr: NonNull<T>,
    len: usize,
    layout: Layout,
}

// SAFETY: a `Buf` owns its elements as a `Vec` does (no sharing, no interior
// mutability), so it is `Send`/`Sync` exactly when they are.
unsafe impl<T: Send> Send for Buf<T> {}
// SAFETY: see `Send` above.
unsafe impl<T: Sync> Sync for Buf<T> {}

/// n copies of `v`. A big vector is on huge pages (module documentation) and written
/// now (the pages are touched by writing, so a page read before it is written does not
/// fault twice: once for the shared zero page, then for a copy on write); a small one
/// of zeros comes from the allocator's zeroed memory.
pub(crate) fn filled<T: Pod>(n: usize, v: T) -> Buf<T> {
    make(n, v, true)
}

/// n zeros from the allocator's zeroed memory, on ordinary pages whatever the size: for
/// vectors written in a few places only (the masses), whose untouched pages then take
/// no memory (a huge page would be resident whole as soon as one value is written).
pub(crate) fn sparse<T: Pod>(n: usize) -> Buf<T> {
    make(n, T::zeroed(), false)
}

/// [`filled`] (`huge`: on huge pages when big) or [`sparse`].
fn make<T: Pod>(n: usize, v: T, huge: bool) -> Buf<T> {
    // More than the address space can hold: refused below as `Vec` would.
    let bytes = n.saturating_mul(size_of::<T>()).min(isize::MAX as usize);
    // A big vector starts on a huge-page boundary, and ends on one where that adds at
    // most an eighth (so that its last page can be huge too: the tail of that page is
    // never read, but resident).
    let big = huge && (MIN_BYTES..=MAX_BYTES).contains(&bytes);
    let (size, align) = if big {
        let whole = bytes.next_multiple_of(HUGE);
        let size = if whole - bytes <= bytes / 8 {
            whole
        } else {
            bytes
        };
        (size, HUGE)
    } else {
        (bytes, align_of::<T>())
    };
    let layout = Layout::from_size_align(size, align)
        .unwrap_or_else(|_| handle_alloc_error(Layout::new::<T>()));
    if layout.size() == 0 {
        return Buf {
            ptr: NonNull::dangling(),
            len: n,
            layout,
        };
    }
    let zero = bytes_of(&v).iter().all(|&b| b == 0);
    // A small vector of zeros comes zeroed from the allocator (untouched where the
    // memory is fresh), as `vec![0.0; n]` does.
    // SAFETY: the layout has a non-zero size (checked just above).
    let raw = unsafe {
        if zero && !big {
            alloc_zeroed(layout)
        } else {
            alloc(layout)
        }
    } as *mut T;
    let Some(ptr) = NonNull::new(raw) else {
        handle_alloc_error(layout)
    };
    if big {
        advise_huge(raw as usize, size);
    }
    if zero && big {
        // SAFETY: n elements of T fit in the allocation; all-zero bytes are a valid T
        // (`Pod`), here the very bytes of `v`.
        unsafe { raw.write_bytes(0, n) };
    } else if !zero {
        for i in 0..n {
            // SAFETY: i < n, inside the allocation of n elements of T, aligned for T.
            unsafe { raw.add(i).write(v) };
        }
    }
    Buf {
        ptr,
        len: n,
        layout,
    }
}

impl<T> Deref for Buf<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` holds `len` initialised elements (written by `filled`), or is
        // dangling and aligned with `len` elements of size 0 bytes in all.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T> DerefMut for Buf<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`, and `&mut self` makes the access exclusive.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }
}

impl<'a, T> IntoIterator for &'a Buf<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<T> Drop for Buf<T> {
    fn drop(&mut self) {
        if self.layout.size() > 0 {
            // SAFETY: allocated by `alloc` with this very layout; the elements are
            // `Copy` (no drop to run).
            unsafe { dealloc(self.ptr.as_ptr() as *mut u8, self.layout) };
        }
    }
}

impl<T: Pod + Default> Clone for Buf<T> {
    fn clone(&self) -> Self {
        let mut out = filled(self.len, T::default());
        out.copy_from_slice(self);
        out
    }
}

impl<T: fmt::Debug> fmt::Debug for Buf<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// Asks for huge pages on [addr, addr + bytes) (not yet touched).
#[cfg(target_os = "linux")]
fn advise_huge(addr: usize, bytes: usize) {
    // SAFETY: MADV_HUGEPAGE changes only how the kernel backs these pages when they are
    // first touched, never their contents, and reads or writes no memory itself; the
    // range is this vector's own allocation, which starts on a huge-page boundary. A
    // failure (no transparent huge pages) leaves ordinary pages: ignored.
    unsafe {
        libc::madvise(addr as *mut libc::c_void, bytes, libc::MADV_HUGEPAGE);
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge(_addr: usize, _bytes: usize) {}

#[cfg(test)]
mod tests {
    use super::filled;

    /// Small and big vectors hold what was asked, whether or not the kernel lends huge
    /// pages.
    #[test]
    fn filled_vectors_hold_their_value() {
        for n in [0, 1, 1000, 3 << 20] {
            let v = filled(n, 1.5f64);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|&x| x == 1.5));
            let mut w = filled(n, 0.0f32);
            assert!(w.iter().all(|&x| x == 0.0));
            if n > 0 {
                w[n - 1] = 2.0;
                let c = w.clone();
                assert_eq!((c.len(), c[n - 1]), (n, 2.0));
            }
        }
    }
}
