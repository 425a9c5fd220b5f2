//! A software prefetch hint for loops that walk particles in block order, i.e. at addresses the
//! hardware prefetcher cannot predict. A hint only: it never changes a result.

/// Asks the CPU to bring the cache line holding the start of `r` into L1 (x86-64; a no-op
/// elsewhere).
#[inline(always)]
pub(crate) fn prefetch<T>(r: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing and cannot fault; `r` is a valid reference anyway.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            (r as *const T).cast(),
        );
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = r;
}
