//! Large arrays read at random: backed by huge pages where the system
//! offers them.

/// A vector with room for `n` elements whose memory the system is asked to
/// back with huge pages (2 MiB on x86-64 Linux) when it first touches it:
/// an array of tens of megabytes read at random then costs one TLB entry
/// per 2 MiB instead of per 4 KiB. Elsewhere, or when the system declines,
/// it is an ordinary vector.
pub fn huge_vec<T>(n: usize) -> Vec<T> {
    let v: Vec<T> = Vec::with_capacity(n);
    #[cfg(target_os = "linux")]
    advise_huge(v.as_ptr().cast::<u8>(), n * std::mem::size_of::<T>());
    v
}

#[cfg(target_os = "linux")]
fn advise_huge(start: *const u8, len: usize) {
    const HUGE: usize = 2 << 20;
    if len < HUGE {
        return;
    }
    // The whole huge pages within the buffer.
    let a = (start as usize).next_multiple_of(HUGE);
    let b = (start as usize + len) / HUGE * HUGE;
    if b > a {
        // SAFETY: [a, b) lies within the vector's allocation, which this
        // process owns; MADV_HUGEPAGE changes how it is backed, not its
        // contents. A refusal (an old kernel, huge pages off) is harmless.
        unsafe {
            libc::madvise(a as *mut libc::c_void, b - a, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Small and large vectors alike come empty with room for all their
    /// elements, and hold what is put in them (the advice concerns pages
    /// not yet touched).
    #[test]
    fn huge_vectors_are_ordinary_vectors() {
        for n in [0, 1, 1000, 3 << 20] {
            let mut v: Vec<u32> = huge_vec(n);
            assert!(v.is_empty() && v.capacity() >= n);
            let p = v.as_ptr();
            v.extend((0..n).map(|i| i as u32 ^ 0x5555));
            assert_eq!(v.as_ptr(), p, "no reallocation for {n}");
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32 ^ 0x5555));
        }
    }
}
