//! Runtime dispatch of the element-wise loops to the widest vector instructions the CPU has.
//!
//! The crate is compiled for baseline x86-64 (SSE2), where LLVM vectorises loops 4 lanes wide.
//! [`vectorized`] runs a closure inside a function compiled with AVX-512 or AVX2 enabled, so
//! the loops inlined into it are vectorised 16 or 8 lanes wide. The loops are element-wise
//! (no reductions are reordered and Rust never fuses a multiply and an add on its own), so
//! results are bit-identical whichever path runs.

/// Runs `f` compiled for the best instruction set available (see the module docs). Mark the
/// closure `#[inline(always)]`: a closure that is not inlined keeps baseline code.
#[inline(always)]
pub(crate) fn vectorized<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx512f")]
        fn avx512<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        #[target_feature(enable = "avx2")]
        fn avx2<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            return unsafe { avx512(f) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above).
            return unsafe { avx2(f) };
        }
    }
    f()
}
