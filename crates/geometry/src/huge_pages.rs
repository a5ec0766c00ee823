//! Large BVH arrays in 2 MB pages where the operating system offers them.
//!
//! A ray through a big mesh's BVH touches nodes and leaf blocks all over tens of megabytes: with 4 KB pages nearly
//! every such load also misses the address-translation caches. Linux backs memory with 2 MB pages ("transparent
//! huge pages") when a program asks with `madvise(MADV_HUGEPAGE)`, the default mode of most distributions, as
//! Embree does for its BVHs. On the 1M-triangle benchmark that made incoherent rays faster and left camera rays,
//! whose nodes stay in the caches, level (BENCHMARKS.md, "Why the traversal is as it is").
//!
//! The advice only takes effect on memory the process has not touched yet, in whole 2 MB pages: an array taken
//! from the allocator's heap (where it reuses memory freed during the build) got none, or only part, of them --
//! on the benchmark the 11 MB node array, allocated after the build had freed its temporaries, had 0 to 8 MB of
//! huge pages from one run to the next. So a large array gets a fresh anonymous mapping of its own, aligned to 2 MB,
//! advised before it is written ([`LargeArray`]): occlusion on the 1M-triangle benchmark gained on one and two
//! threads, closest hits stayed level (BENCHMARKS.md, "Why the traversal is as it is").

use std::ops::Deref;
use std::ptr::NonNull;

/// Arrays smaller than this stay in ordinary pages (a 2 MB page would mostly hold other data).
const MIN_BYTES: usize = 4 << 20;

/// The size and alignment of a huge page.
#[cfg(target_os = "linux")]
const HUGE: usize = 2 << 20;

/// A read-only array of `T`, in memory mapped for it alone and backed by 2 MB pages where the system allows
/// (Linux, arrays of 4 MB or more); elsewhere the vector it was made from. Reads as a slice. Public for the
/// traversal benchmark's memory probe, which places its test array as the BVH's arrays are placed.
pub struct LargeArray<T: Copy> {
    /// The first element: in the mapping, or the start of `heap`'s buffer.
    ptr: NonNull<T>,
    len: usize,
    /// Bytes of the mapping holding the elements, or 0 if they are in `heap`.
    mapped: usize,
    /// The elements when they are not mapped (moving the vector into this struct does not move its buffer).
    #[expect(dead_code, reason = "owns the buffer `ptr` points into when not mapped; read through `ptr`")]
    heap: Vec<T>,
}

// SAFETY: a `LargeArray` owns its elements as a `Vec<T>` would (the mapping is freed only by its `Drop`, and
// nothing else points into it) and gives out only shared references to them, so it may cross threads and be
// shared between them exactly when `T` may.
#[allow(unsafe_code)]
unsafe impl<T: Copy + Send> Send for LargeArray<T> {}
// SAFETY: as above.
#[allow(unsafe_code)]
unsafe impl<T: Copy + Sync> Sync for LargeArray<T> {}

impl<T: Copy> LargeArray<T> {
    /// `v`'s elements: copied into a mapping of their own if they take at least [`MIN_BYTES`] and one can be
    /// made (Linux), else `v` itself. The copy holds the array twice for a moment, after the build has freed its
    /// larger temporaries: the 1M-triangle benchmark's peak resident memory is the same as with the leaf blocks
    /// written in place (BENCHMARKS.md, "Memory").
    pub fn new(mut v: Vec<T>) -> Self {
        let bytes = v.len().saturating_mul(std::mem::size_of::<T>());
        #[cfg(target_os = "linux")]
        if bytes >= MIN_BYTES && std::mem::align_of::<T>() <= HUGE {
            if let Some((ptr, mapped)) = map_huge_pages(bytes) {
                let ptr = ptr.cast::<T>();
                // SAFETY: the mapping is at least `bytes` long, writable, 2 MB aligned (so aligned for `T`) and
                // new (it overlaps nothing, `v`'s buffer included); `v` holds `v.len()` initialised elements.
                #[allow(unsafe_code)]
                unsafe {
                    std::ptr::copy_nonoverlapping(v.as_ptr(), ptr.as_ptr(), v.len());
                }
                return Self { ptr, len: v.len(), mapped, heap: Vec::new() };
            }
        }
        let _ = bytes;
        let ptr = NonNull::new(v.as_mut_ptr()).expect("a vector's pointer is never null");
        Self { ptr, len: v.len(), mapped: 0, heap: v }
    }

    /// True if the elements are in a mapping of their own (advised to use 2 MB pages).
    #[cfg(test)]
    fn is_mapped(&self) -> bool {
        self.mapped > 0
    }
}

impl<T: Copy> Deref for LargeArray<T> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` points at `len` initialised elements that live as long as `self` (in the mapping, which
        // only `Drop` unmaps, or in `heap`'s buffer, which nothing resizes), aligned for `T`, and never written
        // after construction.
        #[allow(unsafe_code)]
        unsafe {
            std::slice::from_raw_parts(self.ptr.as_ptr(), self.len)
        }
    }
}

impl<T: Copy> Drop for LargeArray<T> {
    fn drop(&mut self) {
        #[cfg(target_os = "linux")]
        if self.mapped > 0 {
            // SAFETY: `ptr` and `mapped` are the start and length of the mapping `map_huge_pages` made for this
            // array, which nothing else refers to once `self` is dropped. (`T: Copy` has no destructor to run.)
            #[allow(unsafe_code)]
            unsafe {
                libc::munmap(self.ptr.as_ptr().cast(), self.mapped);
            }
        }
    }
}

/// A new private anonymous mapping of at least `bytes` bytes, starting at a multiple of 2 MB and as long as a
/// whole number of 2 MB pages, advised to use huge pages before anything touches it: its start and length, or
/// `None` if the system refuses the mapping.
#[cfg(target_os = "linux")]
fn map_huge_pages(bytes: usize) -> Option<(NonNull<u8>, usize)> {
    let len = bytes.checked_next_multiple_of(HUGE)?;
    // One huge page more than needed, so that an aligned start lies inside; the rest is unmapped again.
    let reserve = len.checked_add(HUGE)?;
    // SAFETY: a new anonymous private mapping at an address the kernel chooses: it aliases no Rust object.
    #[allow(unsafe_code)]
    let raw = unsafe {
        libc::mmap(
            std::ptr::null_mut(),
            reserve,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        )
    };
    if raw == libc::MAP_FAILED {
        return None;
    }
    let raw = raw as usize;
    let start = raw.next_multiple_of(HUGE);
    // SAFETY: the two ranges unmapped are the parts of the mapping just made before `start` and after
    // `start + len` (both inside `[raw, raw + reserve)`, as `start - raw < HUGE`); nothing refers to them. The
    // advice changes neither the contents nor the validity of `[start, start + len)`, and its failure (a kernel
    // without huge pages) is harmless, so its result is ignored.
    #[allow(unsafe_code)]
    unsafe {
        if start > raw {
            libc::munmap(raw as *mut libc::c_void, start - raw);
        }
        let tail = raw + reserve - (start + len);
        if tail > 0 {
            libc::munmap((start + len) as *mut libc::c_void, tail);
        }
        libc::madvise(start as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
    }
    Some((NonNull::new(start as *mut u8)?, len))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_array_reads_back_what_it_was_made_from_mapped_or_not() {
        for n in [0usize, 10, (MIN_BYTES / 4) + 12_345] {
            let v: Vec<u32> = (0..n as u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
            let a = LargeArray::new(v.clone());
            assert_eq!(&a[..], &v[..]);
            assert_eq!(a.is_mapped(), cfg!(target_os = "linux") && n * 4 >= MIN_BYTES, "{n} elements");
            if a.is_mapped() {
                assert_eq!(a.as_ptr() as usize % (2 << 20), 0, "the mapping starts on a 2 MB boundary");
            }
            // Moved, it still reads the same elements (from the same place).
            let p = a.as_ptr();
            let moved = Box::new(a);
            assert_eq!(moved.as_ptr(), p);
            assert_eq!(&moved[..], &v[..]);
        }
    }

    #[test]
    fn a_large_array_of_aligned_records_keeps_their_alignment() {
        #[derive(Clone, Copy, PartialEq, Debug)]
        #[repr(C, align(64))]
        struct Line([u32; 16]);
        let v: Vec<Line> = (0..(MIN_BYTES / 64) as u32 + 7).map(|i| Line([i; 16])).collect();
        let a = LargeArray::new(v.clone());
        assert_eq!(a.as_ptr() as usize % 64, 0);
        assert_eq!(&a[..], &v[..]);
    }
}
