//! Whole-image scratch arrays (a value per pixel, alive for one render).
//!
//! A fresh heap array of a few megabytes is mapped in 4 KiB pages, each
//! faulted in and zeroed by the kernel on first touch: several microseconds
//! a page, which for the 20 MB of a 1920×1080 render's transients adds up
//! to tens of milliseconds. On Linux, large arrays are
//! instead their own anonymous mapping, 2 MiB aligned and advised
//! `MADV_HUGEPAGE`, so that (with transparent huge pages in `madvise` or
//! `always` mode) a fault maps 2 MiB at once. A dropped mapping is kept for
//! the next render (up to [`KEEP`] bytes in all, the largest kept), so that
//! renders in a row neither fault nor have the kernel zero their scratch
//! again: [`ScratchArray::zeroed`] clears a kept mapping, and
//! [`ScratchArray::filled`] writes its value over it (in parallel). Elsewhere,
//! or should the mapping fail, a `Vec`. [`populate_write`] faults in a
//! fresh output array's pages in one call before it is written whole.

use std::ops::{Deref, DerefMut};

/// Types whose all-zero bytes are a valid value (0, 0.0, false).
///
/// # Safety
/// The all-zero bit pattern must be a valid value of the type.
pub unsafe trait Zeroable: Copy + Send + Sync {}
// SAFETY: integers, floats and bool are valid all-zero. (The types the
// renderers and tests use.)
unsafe impl Zeroable for u32 {}
unsafe impl Zeroable for f64 {}
unsafe impl Zeroable for bool {}

/// Types of which every bit pattern is a valid value (not bool).
///
/// # Safety
/// Every bit pattern of the type's size must be a valid value.
pub unsafe trait AnyBits: Zeroable {}
// SAFETY: every bit pattern is an integer or a float (possibly NaN).
unsafe impl AnyBits for u32 {}
unsafe impl AnyBits for f64 {}

/// An array of n values (see the module documentation).
pub struct ScratchArray<T: Zeroable> {
    ptr: *mut T,
    len: usize,
    /// The mapping when the array is one; else the array is `_vec`.
    map: Option<Mapping>,
    /// Owner of the memory when not mapped.
    _vec: Vec<T>,
}

// SAFETY: `ScratchArray` owns its memory as a `Vec<T>` would.
unsafe impl<T: Zeroable> Send for ScratchArray<T> {}
unsafe impl<T: Zeroable> Sync for ScratchArray<T> {}

/// Arrays from this size up get a mapping of their own (Linux): even a
/// sixteenth of a huge page costs more in 4 KiB faults than one 2 MiB
/// fault, and an array of that size from the heap can make the allocator
/// hand a render's buffers back to the system (measured: a 229 KB array
/// of set flags per orthographic 480×477 render brought 595 page faults
/// per render in the buffers' fill, against 3 with a kept mapping).
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
const MAP_FROM: usize = 1 << 17;

/// Bytes of dropped mappings kept for later arrays (a 1920×1080
/// perspective render's scratch, its set flags and depths, takes 20 MiB
/// of them).
pub const KEEP: usize = 32 << 20;

impl<T: Zeroable> ScratchArray<T> {
    /// n zeros.
    pub fn zeroed(len: usize) -> Self {
        Self::make(len, true)
    }

    fn make(len: usize, zero: bool) -> Self {
        #[cfg(target_os = "linux")]
        {
            let bytes = len.saturating_mul(std::mem::size_of::<T>());
            if bytes >= MAP_FROM {
                if let Some((map, fresh)) = Mapping::take(bytes) {
                    if zero && !fresh {
                        // SAFETY: the body holds at least `bytes` bytes, ours.
                        unsafe { std::ptr::write_bytes(map.start, 0, bytes) };
                    }
                    return ScratchArray {
                        ptr: map.start.cast(),
                        len,
                        map: Some(map),
                        _vec: Vec::new(),
                    };
                }
            }
        }
        let _ = zero;
        let mut vec = vec![zero_value::<T>(); len];
        ScratchArray {
            ptr: vec.as_mut_ptr(),
            len,
            map: None,
            _vec: vec,
        }
    }

    /// The array as a raw pointer (to write from several threads).
    pub fn as_mut_ptr(&mut self) -> *mut T {
        self.ptr
    }
}

impl<T: AnyBits> ScratchArray<T> {
    /// n copies of x, written in parallel (rayon's current pool).
    pub fn filled(len: usize, x: T) -> Self {
        use rayon::prelude::*;
        // (a kept mapping's old values: every bit pattern is a T)
        let mut a = Self::make(len, false);
        a.par_chunks_mut(1 << 14).for_each(|c| c.fill(x));
        a
    }
}

/// The all-zero value of T.
#[inline]
fn zero_value<T: Zeroable>() -> T {
    // SAFETY: `Zeroable` promises all-zero bytes are a valid T.
    unsafe { std::mem::zeroed() }
}

impl<T: Zeroable> Deref for ScratchArray<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        // SAFETY: ptr holds len valid values (see `AnyBits`, `Zeroable`),
        // owned by self.
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }
}

impl<T: Zeroable> DerefMut for ScratchArray<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`, and &mut self is exclusive.
        unsafe { std::slice::from_raw_parts_mut(self.ptr, self.len) }
    }
}

impl<T: Zeroable> Drop for ScratchArray<T> {
    fn drop(&mut self) {
        if let Some(m) = self.map.take() {
            m.give_back();
        }
    }
}

/// An anonymous mapping: [base, base + total), whose 2 MiB-aligned body
/// [start, start + body) holds the array.
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
struct Mapping {
    base: *mut u8,
    total: usize,
    start: *mut u8,
    body: usize,
}

// SAFETY: a mapping is plain memory, owned by one array or by the pool.
unsafe impl Send for Mapping {}

/// Dropped mappings kept for later arrays (at most [`KEEP`] bytes of
/// bodies).
static POOL: std::sync::Mutex<Vec<Mapping>> = std::sync::Mutex::new(Vec::new());

#[cfg(target_os = "linux")]
const HUGE: usize = 1 << 21;

impl Mapping {
    /// A mapping with a body of at least `bytes`: the smallest kept one
    /// that is large enough, else a fresh one (`true`: fresh, so zero).
    #[cfg(target_os = "linux")]
    fn take(bytes: usize) -> Option<(Mapping, bool)> {
        {
            let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
            let best = (0..pool.len())
                .filter(|&i| pool[i].body >= bytes)
                .min_by_key(|&i| pool[i].body);
            if let Some(i) = best {
                return Some((pool.swap_remove(i), false));
            }
        }
        Self::fresh(bytes).map(|m| (m, true))
    }

    #[cfg(target_os = "linux")]
    fn fresh(bytes: usize) -> Option<Mapping> {
        // Room for the array rounded up to whole huge pages, plus the
        // alignment slack.
        let body = bytes.checked_next_multiple_of(HUGE)?;
        let total = body.checked_add(HUGE)?;
        // SAFETY: a fresh private anonymous mapping (no file, no fixed
        // address); checked for failure below.
        let base = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                total,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if base == libc::MAP_FAILED {
            return None;
        }
        let base = base.cast::<u8>();
        let at = (base as usize).next_multiple_of(HUGE) - base as usize;
        // SAFETY: at < HUGE and at + body ≤ total, inside the mapping.
        let start = unsafe { base.add(at) };
        // (a hint: its failure, THP off, leaves ordinary pages)
        advise_huge(start, body);
        Some(Mapping {
            base,
            total,
            start,
            body,
        })
    }

    /// Keep the mapping for a later array; unmap the smallest kept ones
    /// beyond [`KEEP`] bytes.
    fn give_back(self) {
        let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
        pool.push(self);
        while pool.iter().map(|m| m.body).sum::<usize>() > KEEP {
            let i = (0..pool.len())
                .min_by_key(|&i| pool[i].body)
                .expect("a kept mapping");
            pool.swap_remove(i).unmap();
        }
    }

    fn unmap(self) {
        // SAFETY: the mapping made in `fresh`, owned by self, unmapped once.
        #[cfg(target_os = "linux")]
        unsafe {
            libc::munmap(self.base.cast(), self.total)
        };
    }
}

/// Ask for huge pages behind the whole 2 MiB pages of the `len` values
/// from `ptr` (Linux, transparent huge pages in `madvise` or `always`
/// mode), for memory not touched yet: for large arrays read or written in
/// an order that meets a different 4 KiB page at almost every step (a TLB
/// miss each). A hint: no value changes, and a failure leaves ordinary
/// pages. The values need not be initialised (a `Vec`'s capacity).
pub fn advise_huge<T>(ptr: *const T, len: usize) {
    #[cfg(target_os = "linux")]
    {
        let a = ptr as usize;
        let bytes = len.saturating_mul(std::mem::size_of::<T>());
        let (start, end) = (
            a.next_multiple_of(HUGE),
            a.saturating_add(bytes) / HUGE * HUGE,
        );
        if end > start {
            // SAFETY: [start, end) lies inside the caller's allocation of
            // `len` values; the advice changes no contents.
            unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (ptr, len);
}

/// Fault in the pages of `buf` in one system call (Linux
/// `MADV_POPULATE_WRITE`, kernel 5.14+) rather than one page fault per 4 KiB
/// page as they are first written: for a fresh output array about to be
/// written whole. No value changes (a page reads as before); where the call
/// is not supported, or for a small array, nothing happens.
pub fn populate_write<T>(buf: &mut [T]) {
    #[cfg(target_os = "linux")]
    {
        const PAGE: usize = 4096;
        let bytes = std::mem::size_of_val(buf);
        if bytes >= 64 * PAGE {
            let a = buf.as_mut_ptr() as usize;
            let (start, end) = (a.next_multiple_of(PAGE), (a + bytes) / PAGE * PAGE);
            // SAFETY: [start, end) is page-aligned and inside `buf`, which is
            // borrowed mutably; populating changes no value. A failure only
            // leaves the pages to be faulted in one by one.
            unsafe {
                libc::madvise(
                    start as *mut libc::c_void,
                    end - start,
                    libc::MADV_POPULATE_WRITE,
                )
            };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = buf;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scratch_small_and_large() {
        for n in [0usize, 7, 1000, (MAP_FROM / 8) + 3, 3 * MAP_FROM / 8] {
            // Twice over: the second round reuses the first's mappings.
            for _ in 0..2 {
                let mut z = ScratchArray::<f64>::zeroed(n);
                assert_eq!(z.len(), n);
                assert!(z.iter().all(|&x| x == 0.0));
                for (k, x) in z.iter_mut().enumerate() {
                    *x = k as f64 + 0.5;
                }
                assert!(z.iter().enumerate().all(|(k, &x)| x == k as f64 + 0.5));
                let b = ScratchArray::<bool>::zeroed(n);
                assert!(b.iter().all(|&x| !x));
                let mut a = ScratchArray::<u32>::filled(n, 7);
                assert_eq!(a.len(), n);
                assert!(a.iter().all(|&x| x == 7));
                a.iter_mut().for_each(|x| *x = 9);
                drop(a);
                // (over a kept mapping whose values were written above)
                let f = ScratchArray::<f64>::filled(n, f64::INFINITY);
                assert!(f.len() == n && f.iter().all(|&x| x == f64::INFINITY));
            }
        }
        let pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
        assert!(pool.iter().map(|m| m.body).sum::<usize>() <= KEEP);
    }

    #[test]
    fn populate_write_keeps_values() {
        // unaligned start and end, fresh and written pages alike
        let mut v = vec![0.0f32; 300_001];
        for (k, x) in v.iter_mut().enumerate().skip(1).step_by(977) {
            *x = k as f32;
        }
        populate_write(&mut v[1..]);
        assert!(v
            .iter()
            .enumerate()
            .all(|(k, &x)| x == if k % 977 == 1 { k as f32 } else { 0.0 }));
    }
}
