//! The counting allocator behind every "the cycle allocates nothing" test.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// A global allocator that forwards to the system allocator and counts the allocations a
/// thread makes inside [`count_allocations`]. Per thread: tests run in parallel, and another
/// thread (iceoryx2's publisher thread, by design) must not count in the control thread's figure.
///
/// Install it once per test binary:
///
/// ```
/// use jointctl_test_support::{CountingAlloc, count_allocations};
/// #[global_allocator]
/// static GLOBAL: CountingAlloc = CountingAlloc;
///
/// let (_, n) = count_allocations(|| std::hint::black_box(vec![1u8; 4]));
/// assert_eq!(n, 1);
/// let (_, n) = count_allocations(|| std::hint::black_box(1 + 1));
/// assert_eq!(n, 0);
/// ```
pub struct CountingAlloc;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn counting() -> bool {
    COUNTING.try_with(Cell::get).unwrap_or(false)
}

fn count_one() {
    let _ = ALLOCATIONS.try_with(|a| a.set(a.get() + 1));
}

/// Runs `f` and returns its result with the number of allocations (and reallocations) this
/// thread made meanwhile. Counts only when [`CountingAlloc`] is the global allocator.
pub fn count_allocations<R>(f: impl FnOnce() -> R) -> (R, u64) {
    ALLOCATIONS.with(|a| a.set(0));
    COUNTING.with(|c| c.set(true));
    let r = f();
    COUNTING.with(|c| c.set(false));
    (r, ALLOCATIONS.with(Cell::get))
}

// SAFETY: every call is forwarded unchanged to the system allocator; counting touches only
// thread-local cells, which do not allocate (`const` initialised).
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if counting() {
            count_one();
        }
        // SAFETY: forwarded unchanged; the caller upholds `alloc`'s contract.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged; `ptr` came from `System` through this allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if counting() {
            count_one();
        }
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if counting() {
            count_one();
        }
        // SAFETY: forwarded unchanged; `ptr` came from `System` through this allocator.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}
