//! A global allocator that counts allocations per thread, for the tests that prove a hot path
//! allocates nothing once warm (defender-nn's passes, defender-rl's act/observe/update, the
//! filter's push and the dynamics model's step), and that measures a thread's peak memory
//! ([`PeakBytes`]), for the replay of the fuzz corpora (crates/defender-fuzz).
//!
//! Counting per thread means other tests of the same binary, running in parallel, do not disturb
//! the count; the paths under test run single-threaded (`Parallelism::Sequential`), so nothing
//! they allocate escapes it. Use it in an integration test file:
//!
//! ```ignore
//! #[global_allocator]
//! static GLOBAL: alloc_counter::Counting = alloc_counter::Counting;
//!
//! let before = alloc_counter::allocations();
//! hot_path();
//! assert_eq!(alloc_counter::allocations() - before, 0);
//! ```

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

thread_local! {
    // `const` initialisation: reading it never allocates, which an allocator requires.
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
    // Live bytes allocated by this thread (minus those it freed), and their peak since the last
    // `start_peak`: the fuzz corpora's replay bounds the memory an input makes a parser take.
    static LIVE: Cell<i64> = const { Cell::new(0) };
    static PEAK: Cell<i64> = const { Cell::new(0) };
}

/// Forwards to the system allocator, counting every `alloc`, `alloc_zeroed` and `realloc` of the
/// calling thread (frees are not counted: a path that frees must have allocated).
pub struct Counting;

fn count() {
    // `try_with`: during thread teardown the counter may already be gone; then do not count.
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

fn grew(by: usize) {
    let _ = LIVE.try_with(|live| {
        let now = live.get().saturating_add(by as i64);
        live.set(now);
        let _ = PEAK.try_with(|p| p.set(p.get().max(now)));
    });
}

fn shrank(by: usize) {
    let _ = LIVE.try_with(|live| live.set(live.get().saturating_sub(by as i64)));
}

// SAFETY: every method forwards to `System` with the caller's arguments; counting has no effect
// on the memory handed out.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        grew(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        grew(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        shrank(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        if new_size >= layout.size() {
            grew(new_size - layout.size());
        } else {
            shrank(layout.size() - new_size);
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Allocations made so far by the calling thread (only when [`Counting`] is the global
/// allocator; otherwise 0).
pub fn allocations() -> u64 {
    ALLOCATIONS.with(Cell::get)
}

/// A measurement of the calling thread's peak memory, started by [`PeakBytes::start`].
#[derive(Debug)]
pub struct PeakBytes {
    base: i64,
}

impl PeakBytes {
    /// Starts measuring: the peak is reset to the bytes live now.
    pub fn start() -> Self {
        let base = LIVE.with(Cell::get);
        PEAK.with(|p| p.set(base));
        Self { base }
    }

    /// The most bytes the calling thread held at once since [`PeakBytes::start`], beyond those
    /// it held then (only when [`Counting`] is the global allocator; otherwise 0).
    pub fn peak(&self) -> u64 {
        (PEAK.with(Cell::get) - self.base).max(0) as u64
    }
}
