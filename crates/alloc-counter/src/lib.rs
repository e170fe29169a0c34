//! A global allocator that counts allocations per thread, for the tests that prove a hot path
//! allocates nothing once warm (defender-nn's passes, defender-rl's act/observe/update, the
//! filter's push and the dynamics model's step).
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
}

/// Forwards to the system allocator, counting every `alloc`, `alloc_zeroed` and `realloc` of the
/// calling thread (frees are not counted: a path that frees must have allocated).
pub struct Counting;

fn count() {
    // `try_with`: during thread teardown the counter may already be gone; then do not count.
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

// SAFETY: every method forwards to `System` with the caller's arguments; counting has no effect
// on the memory handed out.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Allocations made so far by the calling thread (only when [`Counting`] is the global
/// allocator; otherwise 0).
pub fn allocations() -> u64 {
    ALLOCATIONS.with(Cell::get)
}
