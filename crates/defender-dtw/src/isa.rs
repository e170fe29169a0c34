//! Which instruction set the SIMD kernels run with: the CPU's best, detected once per process,
//! unless a test forces another one on its thread ([`crate::kernels::with_kernel`]).

use std::cell::Cell;

/// The instruction set a kernel runs with, detected once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    /// AVX-512F (16 lanes) with FMA.
    Avx512,
    /// AVX2 (8 lanes) with FMA.
    Avx2,
    /// Whatever the compile target has (SSE2 on x86-64), no FMA.
    Portable,
}

impl Isa {
    /// The best instruction set of this CPU.
    pub(crate) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                return Isa::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                return Isa::Avx2;
            }
        }
        Isa::Portable
    }
}

thread_local! {
    static FORCED: Cell<Option<Isa>> = const { Cell::new(None) };
}

/// Makes this thread's kernels use `isa` (`None`: the detected one); returns the previous setting.
pub(crate) fn force(isa: Option<Isa>) -> Option<Isa> {
    FORCED.with(|c| c.replace(isa))
}

/// The instruction set DTW uses: this CPU's best, detected once per process, unless this thread
/// forces another one ([`crate::kernels::with_kernel`], for tests).
pub(crate) fn isa() -> Isa {
    FORCED.with(Cell::get).unwrap_or_else(detected)
}

/// This CPU's best instruction set, detected once per process.
pub(crate) fn detected() -> Isa {
    static ISA: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
    *ISA.get_or_init(Isa::detect)
}
