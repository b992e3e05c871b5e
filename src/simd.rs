//! Which vector kernels run: the AVX2 variants where the CPU has AVX2, the portable ones
//! elsewhere. Both give bit-identical results (tests run both and compare).

/// Set by tests to run the portable kernels on a CPU that has AVX2.
#[cfg(test)]
static FORCE_PORTABLE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether the AVX2 kernels may run: the CPU has AVX2 (checked at run time; cached by `std`).
#[inline]
pub(crate) fn avx2() -> bool {
    #[cfg(test)]
    if FORCE_PORTABLE.load(std::sync::atomic::Ordering::Relaxed) {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Runs `f` on the portable kernels, then (when the CPU has AVX2) on the AVX2 ones: the two
/// results. Tests that do this run one at a time; any other test running meanwhile may take the
/// portable path, which gives the same bits.
#[cfg(test)]
pub(crate) fn on_both_paths<R>(f: impl Fn() -> R) -> (R, Option<R>) {
    use std::sync::atomic::Ordering;
    static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _turn = ONE_AT_A_TIME
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    FORCE_PORTABLE.store(true, Ordering::Relaxed);
    let portable = f();
    FORCE_PORTABLE.store(false, Ordering::Relaxed);
    let vector = avx2().then(f);
    (portable, vector)
}
