//! How many threads the GEMMs of a network use.

use std::num::NonZeroUsize;

use faer::Par;

/// Below this many multiply-adds a GEMM runs on one thread whatever the setting: waking a second
/// thread costs more than it saves. Measured on the 2-core machine (docs/benchmarks-core.md, "Small
/// GEMMs on one thread"): at the former 64^3 threshold a SAC step on Hopper-v5 took 7.6 ms, with
/// the critics' 14-wide first layer (256x14x256) and the dynamics model's batch-64 layers
/// (64x256x256) split; with these on one thread, 5.2 ms. A 256x256 layer over a batch of 256
/// still gains from two threads.
const PARALLEL_MIN_MACS: usize = 128 * 256 * 256;

/// The threading of a network's matrix products.
///
/// Element-wise passes always run on the calling thread; only GEMMs big enough to gain
/// (>= 128x256x256 multiply-adds) are split. Results are bit-identical for every setting: faer splits
/// the output, never the reduction (tested).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parallelism {
    /// Everything on the calling thread.
    Sequential,
    /// Big GEMMs on this many threads of rayon's global pool.
    Threads(NonZeroUsize),
}

impl Default for Parallelism {
    /// `DEFENDER_NN_THREADS` if set (`1` forces sequential), else
    /// `min(2, available cores)`: two threads are ~1.6x faster than one on 256-wide GEMMs on
    /// the project's 2-core machine (see docs/benchmarks-core.md).
    fn default() -> Self {
        let from_env = std::env::var("DEFENDER_NN_THREADS").ok().and_then(|s| s.trim().parse::<usize>().ok());
        let n = from_env
            .unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get().min(2)).unwrap_or(1));
        Parallelism::threads(n)
    }
}

impl Parallelism {
    /// `Threads(n)` for `n >= 2`, `Sequential` for 0 or 1.
    pub fn threads(n: usize) -> Self {
        match NonZeroUsize::new(n) {
            Some(n) if n.get() >= 2 => Parallelism::Threads(n),
            _ => Parallelism::Sequential,
        }
    }

    /// The number of threads (1 for `Sequential`).
    pub fn num_threads(self) -> usize {
        match self {
            Parallelism::Sequential => 1,
            Parallelism::Threads(n) => n.get(),
        }
    }

    /// The faer setting for an `m x k` times `k x n` product.
    #[inline]
    pub(crate) fn for_gemm(self, m: usize, n: usize, k: usize) -> Par {
        match self {
            Parallelism::Threads(t) if m.saturating_mul(n).saturating_mul(k) >= PARALLEL_MIN_MACS => {
                PARALLEL_GEMMS.with(|c| c.set(c.get() + 1));
                Par::Rayon(t)
            }
            _ => Par::Seq,
        }
    }
}

thread_local! {
    static PARALLEL_GEMMS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// How many GEMMs this thread has handed to rayon so far (for tests: proof that a shape really
/// takes the parallel path). Not part of the API.
#[doc(hidden)]
pub fn parallel_gemms_on_this_thread() -> u64 {
    PARALLEL_GEMMS.with(std::cell::Cell::get)
}
