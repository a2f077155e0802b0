//! A counting global allocator for the tests that bound memory (`tests/mutation.rs`, `tests/load_memory.rs`).
//! A test binary installs it with `#[global_allocator] static ALLOC: support::alloc::Counting = support::alloc::Counting;`
//! and measures with [`peak_of`]; the counters are process-wide, so such tests run one at a time.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// The system allocator, counting live and peak bytes.
pub struct Counting;
/// Bytes allocated and not yet freed.
pub static CURRENT: AtomicUsize = AtomicUsize::new(0);
/// Highest [`CURRENT`] since the last reset.
pub static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(by: usize) {
    PEAK.fetch_max(CURRENT.fetch_add(by, Relaxed) + by, Relaxed);
}

// SAFETY: every method hands its arguments to `System` unchanged and returns its result; the counting touches
// only atomics.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        // SAFETY: the caller's layout and pointer go to the system allocator unchanged (GlobalAlloc's contract).
        let p = unsafe { System.alloc(l) };
        if !p.is_null() {
            grew(l.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        // SAFETY: the caller's layout and pointer go to the system allocator unchanged (GlobalAlloc's contract).
        let p = unsafe { System.alloc_zeroed(l) };
        if !p.is_null() {
            grew(l.size());
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: the caller's layout and pointer go to the system allocator unchanged (GlobalAlloc's contract).
        unsafe { System.dealloc(p, l) };
        CURRENT.fetch_sub(l.size(), Relaxed);
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        // SAFETY: the caller's layout and pointer go to the system allocator unchanged (GlobalAlloc's contract).
        let q = unsafe { System.realloc(p, l, new) };
        if !q.is_null() {
            if new >= l.size() {
                grew(new - l.size());
            } else {
                CURRENT.fetch_sub(l.size() - new, Relaxed);
            }
        }
        q
    }
}

/// Runs `f` and returns its result with the peak bytes allocated above what was live when it started (only
/// meaningful in a binary that installed [`Counting`]).
pub fn peak_of<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let base = CURRENT.load(Relaxed);
    PEAK.store(base, Relaxed);
    let out = f();
    (out, PEAK.load(Relaxed).saturating_sub(base))
}
