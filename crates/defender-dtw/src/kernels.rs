//! Choosing the DTW kernel by hand, for tests: the property tests run every kernel this CPU can
//! execute (AVX-512, AVX2, portable), not only the one detected as best. Not part of the API
//! (hidden from the docs); a kernel the CPU lacks can never be forced.

use crate::isa::{self, Isa, detected};

fn name(isa: Isa) -> &'static str {
    match isa {
        Isa::Avx512 => "avx512",
        Isa::Avx2 => "avx2",
        Isa::Portable => "portable",
    }
}

/// The kernels this CPU can run, best first: `"avx512"`, `"avx2"` (x86-64 with those features),
/// always `"portable"`.
#[must_use]
pub fn available() -> Vec<&'static str> {
    let best = detected();
    [Isa::Avx512, Isa::Avx2, Isa::Portable]
        .into_iter()
        .filter(|&i| i == Isa::Portable || best == Isa::Avx512 || (best == Isa::Avx2 && i == Isa::Avx2))
        .map(name)
        .collect()
}

/// The kernel a DTW computed now on this thread would use.
#[must_use]
pub fn current() -> &'static str {
    name(isa::isa())
}

/// Runs `f` with every DTW set up on this thread computed by `kernel` (one of [`available`]);
/// [`crate::References`] built inside keep it for their lifetime.
///
/// # Panics
/// If this CPU cannot run `kernel` (it is not in [`available`]).
pub fn with_kernel<R>(kernel: &str, f: impl FnOnce() -> R) -> R {
    let chosen = [Isa::Avx512, Isa::Avx2, Isa::Portable]
        .into_iter()
        .find(|&i| name(i) == kernel && available().contains(&kernel))
        .unwrap_or_else(|| panic!("kernel {kernel:?} is not one this CPU runs: {:?}", available()));
    struct Restore(Option<Isa>);
    impl Drop for Restore {
        fn drop(&mut self) {
            isa::force(self.0);
        }
    }
    let _restore = Restore(isa::force(Some(chosen)));
    f()
}
