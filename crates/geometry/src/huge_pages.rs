//! Large BVH arrays in 2 MB pages where the operating system offers them.
//!
//! A ray through a big mesh's BVH touches nodes and leaf blocks all over tens of megabytes: with 4 KB pages nearly
//! every such load also misses the address-translation caches. Linux backs memory with 2 MB pages ("transparent
//! huge pages") when a program asks with `madvise(MADV_HUGEPAGE)`, the default mode of most distributions, as
//! Embree does for its BVHs. Measured on the 1M-triangle benchmark (the same binary, the system switched between
//! that mode and huge pages everywhere, 3 alternating runs): closest hits on bounce and shadow rays +5% and +7%,
//! occlusion +5% and +4%, camera rays level (BENCHMARKS.md, "Huge pages").

/// Arrays smaller than this stay in ordinary pages (a 2 MB page would mostly hold other data).
const MIN_BYTES: usize = 4 << 20;

/// An empty vector with room for `capacity` elements, whose memory the kernel is asked to back with 2 MB pages
/// when it is first written (Linux; elsewhere, and for small arrays, a plain `Vec::with_capacity`). Fill it
/// without growing it past `capacity`, which would move it to ordinary memory.
pub(crate) fn vec_in_huge_pages<T>(capacity: usize) -> Vec<T> {
    #[allow(unused_mut)]
    let mut v = Vec::with_capacity(capacity);
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let bytes = capacity.saturating_mul(std::mem::size_of::<T>());
        if bytes >= MIN_BYTES {
            let start = v.as_mut_ptr() as usize;
            // The whole 2 MB pages inside the allocation.
            let (a, b) = (start.div_ceil(HUGE) * HUGE, (start + bytes) / HUGE * HUGE);
            if b > a {
                // SAFETY: [a, b) lies inside the vector's allocation of `bytes` bytes from `start`, which this
                // function owns. MADV_HUGEPAGE is advice about how to back the range: it changes neither the
                // mapping's contents nor its validity, and its failure (a kernel without huge pages) is harmless,
                // so the result is ignored.
                #[allow(unsafe_code)]
                unsafe {
                    libc::madvise(a as *mut libc::c_void, b - a, libc::MADV_HUGEPAGE);
                }
            }
        }
    }
    v
}

/// `v`'s elements in a vector from [`vec_in_huge_pages`] (a copy), or `v` itself if it is too small to gain.
pub(crate) fn moved_to_huge_pages<T: Copy>(v: Vec<T>) -> Vec<T> {
    if cfg!(not(target_os = "linux")) || v.len().saturating_mul(std::mem::size_of::<T>()) < MIN_BYTES {
        return v;
    }
    let mut moved = vec_in_huge_pages(v.len());
    moved.extend_from_slice(&v);
    moved
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_vector_holds_what_is_put_in_it_without_moving() {
        for n in [0usize, 10, (MIN_BYTES / 4) + 12_345] {
            let mut v: Vec<u32> = vec_in_huge_pages(n);
            assert!(v.capacity() >= n);
            let p = v.as_ptr();
            v.extend((0..n as u32).map(|i| i.wrapping_mul(2_654_435_761)));
            assert_eq!(v.as_ptr(), p, "the vector moved");
            assert!(v.iter().enumerate().all(|(i, &x)| x == (i as u32).wrapping_mul(2_654_435_761)));
        }
    }
}
