//! Zero-filled whole-image scratch arrays (a value per pixel, alive for one
//! render).
//!
//! A fresh heap array of a few megabytes is mapped in 4 KiB pages, each
//! faulted in and zeroed by the kernel on first touch: several microseconds
//! a page, which for the tens of megabytes of a 1920×1080 render's
//! transients adds up to tens of milliseconds. On Linux, large arrays are
//! instead their own anonymous mapping, 2 MiB aligned and advised
//! `MADV_HUGEPAGE`, so that (with transparent huge pages in `madvise` or
//! `always` mode) a fault maps 2 MiB at once. The mapping is zero already,
//! so no fill is needed. Elsewhere, or should the mapping fail, a `Vec`.

use std::ops::{Deref, DerefMut};

/// Types whose all-zero bytes are a valid value (0, 0.0, false).
///
/// # Safety
/// The all-zero bit pattern must be a valid value of the type.
pub unsafe trait Zeroable: Copy + Send + Sync {}
// SAFETY: integers, floats and bool are valid all-zero.
unsafe impl Zeroable for u8 {}
unsafe impl Zeroable for u32 {}
unsafe impl Zeroable for u64 {}
unsafe impl Zeroable for usize {}
unsafe impl Zeroable for f64 {}
unsafe impl Zeroable for bool {}

/// A zero-filled array of n values (see the module documentation).
pub struct Zeroed<T: Zeroable> {
    ptr: *mut T,
    len: usize,
    /// The mapping (start, length) when the array is one; else a `Vec`.
    map: Option<(*mut u8, usize)>,
    /// Owner of the memory when not mapped.
    _vec: Vec<T>,
}

// SAFETY: `Zeroed` owns its memory as a `Vec<T>` would.
unsafe impl<T: Zeroable> Send for Zeroed<T> {}
unsafe impl<T: Zeroable> Sync for Zeroed<T> {}

/// Arrays from this size up get a mapping of their own (Linux): even a
/// quarter of a huge page costs more in 4 KiB faults than one 2 MiB fault.
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
const MAP_FROM: usize = 1 << 18;

#[cfg(target_os = "linux")]
const HUGE: usize = 1 << 21;

impl<T: Zeroable> Zeroed<T> {
    /// n zeros.
    pub fn new(len: usize) -> Self {
        #[cfg(target_os = "linux")]
        {
            let bytes = len.saturating_mul(std::mem::size_of::<T>());
            if bytes >= MAP_FROM {
                if let Some(z) = Self::mapped(len, bytes) {
                    return z;
                }
            }
        }
        let mut vec = vec![unsafe_zero::<T>(); len];
        Zeroed {
            ptr: vec.as_mut_ptr(),
            len,
            map: None,
            _vec: vec,
        }
    }

    #[cfg(target_os = "linux")]
    fn mapped(len: usize, bytes: usize) -> Option<Self> {
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
        // SAFETY: [start, start + body) lies in the mapping. The advice is a
        // hint: its failure (THP off) leaves ordinary pages.
        unsafe { libc::madvise(start.cast(), body, libc::MADV_HUGEPAGE) };
        Some(Zeroed {
            ptr: start.cast(),
            len,
            map: Some((base, total)),
            _vec: Vec::new(),
        })
    }

    /// The array as a raw pointer (to write from several threads).
    pub fn as_mut_ptr(&mut self) -> *mut T {
        self.ptr
    }
}

/// The all-zero value of T.
#[inline]
fn unsafe_zero<T: Zeroable>() -> T {
    // SAFETY: `Zeroable` promises all-zero bytes are a valid T.
    unsafe { std::mem::zeroed() }
}

impl<T: Zeroable> Deref for Zeroed<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        // SAFETY: ptr holds len initialised values (zero or written since),
        // owned by self.
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }
}

impl<T: Zeroable> DerefMut for Zeroed<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`, and &mut self is exclusive.
        unsafe { std::slice::from_raw_parts_mut(self.ptr, self.len) }
    }
}

impl<T: Zeroable> Drop for Zeroed<T> {
    fn drop(&mut self) {
        if let Some((base, total)) = self.map.take() {
            // SAFETY: the mapping made in `mapped`, unmapped once.
            #[cfg(target_os = "linux")]
            unsafe {
                libc::munmap(base.cast(), total)
            };
            #[cfg(not(target_os = "linux"))]
            let _ = (base, total);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeroed_small_and_large() {
        for n in [0usize, 7, 1000, (MAP_FROM / 8) + 3, 3 * MAP_FROM / 8] {
            let mut z = Zeroed::<f64>::new(n);
            assert_eq!(z.len(), n);
            assert!(z.iter().all(|&x| x == 0.0));
            for (k, x) in z.iter_mut().enumerate() {
                *x = k as f64;
            }
            assert!(z.iter().enumerate().all(|(k, &x)| x == k as f64));
            let b = Zeroed::<bool>::new(n);
            assert!(b.iter().all(|&x| !x));
        }
    }
}
