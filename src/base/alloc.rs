//! [`LargePages`], the command line's global allocator: large blocks (a frame's planes and images, 4 MiB and up)
//! mapped on their own, 2 MiB-aligned, and marked for transparent huge pages; everything else from the system
//! allocator.
//!
//! A 720p frame lit from a `.bin` touches about 25 MB of fresh memory (the image, the heatmap, the 8-bit picture,
//! the PNG). In 4 KiB pages that is some 6,000 page faults, each entering the kernel: on a 2-core Zen 4 KVM guest
//! 7 ms of a 60 ms process. In 2 MiB pages it is a dozen. Most Linux systems set transparent huge pages to
//! `madvise`, so a region only gets them when asked, which this allocator does. Where the kernel has no huge
//! pages the advice is refused and ignored: the blocks are then ordinary anonymous maps.
//!
//! Freed blocks are kept for the next large allocation (a cache of at most 64 blocks and 1 GiB) instead of being
//! returned at once: on the 2-core Zen 4 KVM guest a fresh page costs 0.25–2.3 ms a MB (the kernel's fault and
//! zeroing), a reused one 0.04 (a `memset`), and `gbuf report` makes and frees several GB of images, masks, bands and
//! packed frames of a few sizes. The smallest cached block that fits is cut to size (its tail stays cached); failing
//! one, the largest grows (the kernel moves its pages; only the added ones are fresh) after as many other cached bytes
//! go back to the system as it adds. So the cache never raises the resident set above what it was by itself, but it
//! keeps freed pages resident while a phase grows by other means: reading a file runs without it ([`uncached`]).
//!
//! Linux only; elsewhere the type forwards everything to [`std::alloc::System`].

use std::alloc::{GlobalAlloc, Layout, System};

/// Blocks of at least this many bytes are mapped on their own.
pub const LARGE: usize = 4 << 20;
/// The huge page size blocks are aligned and rounded to.
const HUGE: usize = 2 << 20;
/// Freed blocks the cache holds at most, and their bytes at most.
const CACHE_SLOTS: usize = 64;
const CACHE_BYTES: usize = 1 << 30;

/// Freed mapped blocks (address, length), oldest first, waiting to be reused.
struct Cache {
    blocks: [(usize, usize); CACHE_SLOTS],
    n: usize,
    bytes: usize,
}

static CACHE: std::sync::Mutex<Cache> = std::sync::Mutex::new(Cache { blocks: [(0, 0); CACHE_SLOTS], n: 0, bytes: 0 });

impl Cache {
    /// A block of `len` bytes made from the cache, and how many of its leading bytes may hold old data (the rest
    /// are fresh zero pages); `None` when the cache is empty (or the kernel refuses to grow a block). The smallest
    /// cached block of at least `len` bytes is cut to `len` (its tail stays cached). Failing one, the largest cached
    /// block is grown to `len` (the kernel moves its pages: only the added ones are fresh), after the oldest other
    /// blocks are unmapped until as many bytes are returned as it adds, so that the resident set does not grow while
    /// freed blocks sit here.
    fn take(&mut self, len: usize) -> Option<(*mut u8, usize)> {
        let best = (0..self.n).filter(|&i| self.blocks[i].1 >= len).min_by_key(|&i| self.blocks[i].1);
        if let Some(i) = best {
            let (addr, have) = self.remove(i);
            if have > len {
                // The tail stays, a block of its own (a slot was just freed): pages of one mapping, cut at a multiple
                // of the huge page size (both lengths are).
                self.blocks[self.n] = (addr + len, have - len);
                self.n += 1;
                self.bytes += have - len;
            }
            return Some((addr as *mut u8, len));
        }
        let largest = (0..self.n).max_by_key(|&i| self.blocks[i].1)?;
        let (addr, have) = self.remove(largest);
        let mut returned = 0;
        while returned < len - have && self.n > 0 {
            returned += self.unmap_oldest();
        }
        // SAFETY: a whole block of `map`'s that this cache owns, unused, grown to another multiple of the huge page
        // size; on failure it is still whole where it was, and released.
        unsafe {
            let grown = os::remap(addr as *mut u8, have, len);
            if grown.is_null() {
                os::unmap(addr as *mut u8, have);
                return None;
            }
            Some((grown, have))
        }
    }

    /// Keeps a freed block of `len` bytes; false (the caller unmaps it) when it does not fit. Older blocks are
    /// unmapped to make room.
    fn keep(&mut self, addr: usize, len: usize) -> bool {
        if len > CACHE_BYTES {
            return false;
        }
        while self.n > 0 && (self.n == CACHE_SLOTS || self.bytes + len > CACHE_BYTES) {
            self.unmap_oldest();
        }
        self.blocks[self.n] = (addr, len);
        self.n += 1;
        self.bytes += len;
        true
    }

    /// Returns the oldest cached block (there is one) to the system; its length.
    fn unmap_oldest(&mut self) -> usize {
        let (a, l) = self.remove(0);
        // SAFETY: a whole block this cache owns, unused.
        unsafe { os::unmap(a as *mut u8, l) };
        l
    }

    fn remove(&mut self, i: usize) -> (usize, usize) {
        let b = self.blocks[i];
        self.blocks.copy_within(i + 1..self.n, i);
        self.n -= 1;
        self.bytes -= b.1;
        b
    }
}

/// Runs `f` with nothing freed kept for reuse (the cache emptied first and after): for a phase whose freed blocks
/// would sit in the cache while it grows, such as reading a file (the decoder's buffers and the file's decoded
/// channels, freed while the G-buffer's planes are built): with the cache, `gbuf resolve` of a 1080p × 4 EXR peaked
/// at 0.70 GB (16 blocks) or 1.11 GB (64), without it at 0.68. Nested and concurrent calls are fine. Nothing changes
/// where [`LargePages`] is not the allocator.
pub fn uncached<R>(f: impl FnOnce() -> R) -> R {
    /// Ends an [`uncached`] phase, even on unwinding.
    struct Phase;
    impl Drop for Phase {
        fn drop(&mut self) {
            UNCACHED.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
            trim();
        }
    }
    UNCACHED.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    trim();
    let _phase = Phase;
    f()
}

/// How many [`uncached`] phases are running: while any is, freed blocks are unmapped at once.
static UNCACHED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Returns every cached block to the system.
fn trim() {
    if let Ok(mut c) = CACHE.lock() {
        while c.n > 0 {
            c.unmap_oldest();
        }
    }
}

/// A mapped block of `len` bytes (a multiple of [`HUGE`]): made from the cache, else a fresh map; and how many of
/// its leading bytes may be non-zero (0 for a fresh map).
fn block(len: usize) -> (*mut u8, usize) {
    let cached = CACHE.lock().ok().and_then(|mut c| c.take(len));
    cached.unwrap_or_else(|| (os::map(len), 0))
}

/// The global allocator that asks for huge pages for large blocks (see the module documentation). Install it with
/// `#[global_allocator] static A: LargePages = LargePages;` in a binary.
#[derive(Clone, Copy, Debug, Default)]
pub struct LargePages;

/// Whether a block of `layout` is one of ours (mapped), rather than the system allocator's.
fn mapped(layout: Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= LARGE && layout.align() <= HUGE
}

/// `size` rounded up to whole huge pages.
fn rounded(size: usize) -> usize {
    size.div_ceil(HUGE) * HUGE
}

#[cfg(target_os = "linux")]
mod os {
    use super::HUGE;

    /// Maps `len` bytes (a multiple of [`HUGE`]) of zeroed memory at a 2 MiB boundary and advises huge pages; null
    /// when the system has no memory left.
    pub fn map(len: usize) -> *mut u8 {
        let Some(over) = len.checked_add(HUGE) else { return std::ptr::null_mut() };
        // SAFETY: an anonymous private map at an address the kernel chooses: no existing memory is affected.
        let raw = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                over,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if raw == libc::MAP_FAILED {
            return std::ptr::null_mut();
        }
        let raw = raw.cast::<u8>();
        let lead = raw.align_offset(HUGE);
        // SAFETY: `lead < HUGE` and `lead + len ≤ over`: both ends stay inside the map just made.
        let (start, end) = unsafe { (raw.add(lead), raw.add(lead + len)) };
        let tail = over - lead - len;
        // SAFETY: the trimmed ends (the bytes before `start` and after `end`) are parts of the map just made that no
        // one else has seen; unmapping them cannot fail for lack of memory in a way that matters (a failure leaves
        // them mapped: a leak of less than 2 MiB, not a fault).
        unsafe {
            if lead > 0 {
                libc::munmap(raw.cast(), lead);
            }
            if tail > 0 {
                libc::munmap(end.cast(), tail);
            }
            // Advice only: refused where the kernel has no transparent huge pages, and then ignored.
            libc::madvise(start.cast(), len, libc::MADV_HUGEPAGE);
        }
        start
    }

    /// Resizes a block [`map`] returned from `old` to `new` bytes (both multiples of [`HUGE`]) without copying: the
    /// kernel moves its pages. In place when the addresses after it are free (or it shrinks), else to a fresh
    /// 2 MiB boundary (reserved first, then the pages moved onto it), so that it keeps its huge pages. Only the pages
    /// a grown block adds are new. Null when the kernel refuses: the block is then whole and where it was (a failed
    /// move may leave part of the reservation mapped, inaccessible: address space, not memory).
    ///
    /// # Safety
    /// `ptr` and `old` are a live block of [`map`]'s; on success the caller uses only the returned block.
    pub unsafe fn remap(ptr: *mut u8, old: usize, new: usize) -> *mut u8 {
        // SAFETY: resizing the caller's own mapping in place (no flags: it never moves).
        let same = unsafe { libc::mremap(ptr.cast(), old, new, 0) };
        if same != libc::MAP_FAILED {
            return same.cast();
        }
        // Only a growing block moves (a shrink in place cannot lack room).
        if new <= old {
            return std::ptr::null_mut();
        }
        let Some(over) = new.checked_add(HUGE) else { return std::ptr::null_mut() };
        // SAFETY: an inaccessible anonymous reservation at an address the kernel chooses: nothing existing is
        // affected.
        let raw = unsafe {
            libc::mmap(std::ptr::null_mut(), over, libc::PROT_NONE, libc::MAP_PRIVATE | libc::MAP_ANONYMOUS, -1, 0)
        };
        if raw == libc::MAP_FAILED {
            return std::ptr::null_mut();
        }
        let raw = raw.cast::<u8>();
        let lead = raw.align_offset(HUGE);
        // SAFETY: `lead < HUGE`, so `[target, target + new)` lies inside the reservation.
        let target = unsafe { raw.add(lead) };
        // SAFETY: the caller's mapping moved onto the aligned part of our own reservation, which it replaces.
        let moved = unsafe {
            libc::mremap(ptr.cast(), old, new, libc::MREMAP_MAYMOVE | libc::MREMAP_FIXED, target.cast::<libc::c_void>())
        };
        // SAFETY: the reservation's parts outside `[target, target + new)` are ours and unused, moved or not. That range
        // is left alone even on failure: the kernel may already have unmapped it, and something else may have been
        // mapped there since.
        unsafe {
            if lead > 0 {
                libc::munmap(raw.cast(), lead);
            }
            let tail = over - lead - new;
            if tail > 0 {
                libc::munmap(target.add(new).cast(), tail);
            }
            if moved == libc::MAP_FAILED {
                return std::ptr::null_mut();
            }
        }
        target
    }

    /// Unmaps a block [`map`] returned, of `len` bytes.
    ///
    /// # Safety
    /// `ptr` and `len` are a block of [`map`]'s, not unmapped before, and nothing uses it afterwards.
    pub unsafe fn unmap(ptr: *mut u8, len: usize) {
        // SAFETY: the caller passes a block of `map`'s, whole.
        unsafe { libc::munmap(ptr.cast(), len) };
    }
}

#[cfg(not(target_os = "linux"))]
mod os {
    pub fn map(_: usize) -> *mut u8 {
        unreachable!("no block is mapped outside Linux")
    }
    pub unsafe fn remap(_: *mut u8, _: usize, _: usize) -> *mut u8 {
        unreachable!("no block is mapped outside Linux")
    }
    pub unsafe fn unmap(_: *mut u8, _: usize) {
        unreachable!("no block is mapped outside Linux")
    }
}

// SAFETY: every block is either the system allocator's (all calls forwarded with the same layout) or a fresh
// anonymous map of at least the layout's size at a 2 MiB boundary (which satisfies any alignment up to 2 MiB, the
// only ones mapped), unmapped only by `dealloc`/`realloc` with the layout it was made for. `mapped(layout)` decides
// which, from the layout alone, identically at allocation and release.
unsafe impl GlobalAlloc for LargePages {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if mapped(layout) {
            block(rounded(layout.size())).0
        } else {
            // SAFETY: forwarded with the caller's layout (non-zero size, as `GlobalAlloc` requires).
            unsafe { System.alloc(layout) }
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if mapped(layout) {
            // Anonymous maps are zero; the reused part of a block is cleared.
            let (p, dirty) = block(rounded(layout.size()));
            if dirty > 0 && !p.is_null() {
                // SAFETY: a block of at least `layout.size()` bytes that nothing else uses.
                unsafe { std::ptr::write_bytes(p, 0, dirty.min(layout.size())) };
            }
            p
        } else {
            // SAFETY: as in `alloc`.
            unsafe { System.alloc_zeroed(layout) }
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if mapped(layout) {
            let len = rounded(layout.size());
            let caching = UNCACHED.load(std::sync::atomic::Ordering::Relaxed) == 0;
            let kept = caching && CACHE.lock().is_ok_and(|mut c| c.keep(ptr as usize, len));
            if !kept {
                // SAFETY: `ptr` came from `alloc`/`alloc_zeroed`/`realloc` with this layout, which mapped it with
                // this rounded length.
                unsafe { os::unmap(ptr, len) }
            }
        } else {
            // SAFETY: `ptr` came from the system allocator with this layout.
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: `GlobalAlloc::realloc`'s contract: `new_size` rounded to the alignment does not overflow.
        let new = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        match (mapped(layout), mapped(new)) {
            // SAFETY: the system allocator's block, resized by it.
            (false, false) => unsafe { System.realloc(ptr, layout, new_size) },
            // The same whole huge pages: the block already holds `new_size` bytes.
            (true, true) if rounded(layout.size()) == rounded(new_size) => ptr,
            // A mapped block resized: its pages moved by the kernel, not copied (nor the copy's pages made and
            // zeroed: a growing vector faulted its whole length in again at every doubling).
            (true, true) => {
                // SAFETY: `ptr` is a live mapped block of `rounded(layout.size())` bytes (`mapped(layout)`); on
                // success only the returned block is used, and `mapped(new)` frees it with the new rounded length.
                let moved = unsafe { os::remap(ptr, rounded(layout.size()), rounded(new_size)) };
                if moved.is_null() {
                    // SAFETY: as below, the general path (allocate, copy, release).
                    unsafe { self.copy_to_new(ptr, layout, new) }
                } else {
                    moved
                }
            }
            // SAFETY: `new` has a non-zero size (`new_size ≥ 1` by the contract) and `ptr` is a live block of
            // `layout`.
            _ => unsafe { self.copy_to_new(ptr, layout, new) },
        }
    }
}

impl LargePages {
    /// `realloc` by allocating a block of `new`, copying, then releasing the old one (null, with the old block
    /// untouched, when the allocation fails).
    ///
    /// # Safety
    /// `ptr` is a live block of `layout` from this allocator; `new` has a non-zero size.
    unsafe fn copy_to_new(&self, ptr: *mut u8, layout: Layout, new: Layout) -> *mut u8 {
        // SAFETY: `new` has a non-zero size (this function's contract).
        let to = unsafe { self.alloc(new) };
        if !to.is_null() {
            // SAFETY: both blocks hold at least the smaller size; they are distinct allocations; `ptr` is released
            // once, with its own layout.
            unsafe {
                std::ptr::copy_nonoverlapping(ptr, to, layout.size().min(new.size()));
                self.dealloc(ptr, layout);
            }
        }
        to
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cache hands back the smallest freed block that fits, cut to size (the tail kept); failing one it grows its
    /// largest block (its bytes kept, the added pages zero) after returning at least as many other cached bytes as it
    /// adds; a full cache drops its oldest block.
    #[test]
    #[cfg(target_os = "linux")]
    fn the_cache_reuses_the_best_fit_grows_the_largest_and_never_holds_more_than_it_returns() {
        let mut c = Cache { blocks: [(0, 0); CACHE_SLOTS], n: 0, bytes: 0 };
        let block = |len: usize| {
            let p = os::map(len);
            assert!(!p.is_null());
            // SAFETY: a fresh block of `len` bytes.
            unsafe { std::ptr::write_bytes(p, 0xab, len) };
            p as usize
        };
        let (small, big) = (block(2 * HUGE), block(6 * HUGE));
        assert!(c.keep(big, 6 * HUGE) && c.keep(small, 2 * HUGE));
        assert_eq!((c.n, c.bytes), (2, 8 * HUGE));
        // The best fit: the small block for a small request, the big one cut for a middling one.
        assert_eq!(c.take(2 * HUGE), Some((small as *mut u8, 2 * HUGE)));
        assert_eq!(c.take(3 * HUGE), Some((big as *mut u8, 3 * HUGE)));
        assert_eq!((c.n, c.bytes), (1, 3 * HUGE), "the cut tail is a block of its own");
        assert_eq!(c.take(3 * HUGE), Some(((big + 3 * HUGE) as *mut u8, 3 * HUGE)));
        assert_eq!((c.n, c.bytes), (0, 0));
        // SAFETY: both halves kept their bytes (reused, not remapped); the test owns them again.
        unsafe {
            assert_eq!(*(big as *const u8).add(3 * HUGE - 1), 0xab);
            assert_eq!(*(big as *const u8).add(6 * HUGE - 1), 0xab);
            os::unmap((big + 3 * HUGE) as *mut u8, 3 * HUGE);
        }
        // No block fits: the largest grows, and the others go back to the system first.
        assert_eq!(c.take(HUGE), None, "an empty cache serves nothing");
        assert!(c.keep(small, 2 * HUGE) && c.keep(big, 3 * HUGE));
        let third = block(HUGE);
        assert!(c.keep(third, HUGE));
        let (grown, dirty) = c.take(5 * HUGE).expect("the largest block grows");
        assert_eq!(dirty, 3 * HUGE, "only the grown block's own bytes may be old");
        assert_eq!((c.n, c.bytes), (1, HUGE), "growing by 2 huge pages returned the oldest block (2), kept the third");
        // SAFETY: a block of 5 huge pages this test owns: its first 3 are the old block's, the others fresh.
        unsafe {
            assert_eq!(*grown.add(3 * HUGE - 1), 0xab);
            assert!(std::slice::from_raw_parts(grown.add(3 * HUGE), 2 * HUGE).iter().all(|&b| b == 0));
            os::unmap(grown, 5 * HUGE);
        }
        let (a, l) = c.remove(0);
        // SAFETY: the third block, released once.
        unsafe { os::unmap(a as *mut u8, l) };
        let blocks: Vec<usize> = (0..=CACHE_SLOTS).map(|_| block(HUGE)).collect();
        for &b in &blocks {
            assert!(c.keep(b, HUGE));
        }
        assert_eq!(c.n, CACHE_SLOTS, "the oldest block made room");
        assert_eq!(c.blocks[0].0, blocks[1]);
        assert!(!c.keep(0, CACHE_BYTES + HUGE), "a block larger than the cache is not kept");
        while c.n > 0 {
            let (a, l) = c.remove(0);
            // SAFETY: blocks of `os::map`, released once.
            unsafe { os::unmap(a as *mut u8, l) };
        }
    }

    /// Inside [`uncached`] (nested too) a freed block goes back to the system at once.
    #[test]
    #[cfg(target_os = "linux")]
    fn an_uncached_phase_keeps_nothing() {
        let layout = Layout::from_size_align(LARGE, 64).unwrap();
        let cached = |p: *mut u8| {
            let c = CACHE.lock().unwrap();
            c.blocks[..c.n].iter().any(|&(a, _)| a == p as usize)
        };
        let freed_and_kept = || {
            let a = LargePages;
            // SAFETY: a non-zero layout, released once with it.
            unsafe {
                let p = a.alloc(layout);
                assert!(!p.is_null());
                *p = 1;
                a.dealloc(p, layout);
                cached(p)
            }
        };
        uncached(|| {
            assert!(!freed_and_kept(), "a block freed inside the phase is not kept");
            uncached(|| assert!(!freed_and_kept(), "nested"));
            assert!(!freed_and_kept(), "after a nested phase");
        });
    }

    /// Blocks either side of the threshold, grown and shrunk across it, keep their bytes and are released.
    #[test]
    fn blocks_keep_their_bytes_across_the_threshold() {
        let a = LargePages;
        for (size, new_size) in [
            (64, LARGE + 1),
            (LARGE + 1, 64),
            (LARGE, LARGE + HUGE),
            (LARGE + 5, LARGE + 7),
            (3 * LARGE, LARGE - 1),
            (LARGE + 1, 6 * LARGE),
            (8 * LARGE, 2 * LARGE),
        ] {
            let layout = Layout::from_size_align(size, 16).unwrap();
            // SAFETY: a non-zero layout; every pointer is checked before use and released once with its layout.
            unsafe {
                let p = a.alloc_zeroed(layout);
                assert!(!p.is_null(), "{size}");
                assert_eq!(p as usize % 16, 0);
                if mapped(layout) {
                    assert_eq!(p as usize % HUGE, 0, "a mapped block starts at a huge page");
                }
                assert!(std::slice::from_raw_parts(p, size).iter().all(|&b| b == 0), "{size}: zeroed");
                for i in (0..size).step_by(4093) {
                    *p.add(i) = (i % 251) as u8;
                }
                let q = a.realloc(p, layout, new_size);
                assert!(!q.is_null(), "{size} → {new_size}");
                if mapped(Layout::from_size_align(new_size, 16).unwrap()) {
                    assert_eq!(q as usize % HUGE, 0, "{size} → {new_size}: still at a huge page");
                }
                for i in (0..size.min(new_size)).step_by(4093) {
                    assert_eq!(*q.add(i), (i % 251) as u8, "{size} → {new_size}: byte {i}");
                }
                *q.add(new_size - 1) = 7;
                a.dealloc(q, Layout::from_size_align(new_size, 16).unwrap());
            }
        }
    }

    /// A mapped block that cannot grow where it is (the next page is taken) moves, keeps its bytes and its 2 MiB
    /// boundary, and is released whole.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_blocked_block_moves_its_pages() {
        let a = LargePages;
        let layout = Layout::from_size_align(LARGE, 64).unwrap();
        // SAFETY: a fresh block, a fresh guard page after it (MAP_FIXED_NOREPLACE fails rather than replace
        // anything), every pointer released once with its own size.
        unsafe {
            let p = a.alloc(layout);
            assert!(!p.is_null());
            std::slice::from_raw_parts_mut(p, LARGE).iter_mut().enumerate().for_each(|(i, b)| *b = (i % 253) as u8);
            let end = p.add(rounded(LARGE));
            let guard = libc::mmap(
                end.cast(),
                4096,
                libc::PROT_NONE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS | libc::MAP_FIXED_NOREPLACE,
                -1,
                0,
            );
            let q = a.realloc(p, layout, 5 * LARGE);
            assert!(!q.is_null() && (q as usize).is_multiple_of(HUGE));
            if guard != libc::MAP_FAILED {
                assert_ne!(q, p, "the guard page after it leaves no room in place");
                libc::munmap(guard, 4096);
            }
            assert!(std::slice::from_raw_parts(q, LARGE).iter().enumerate().all(|(i, &b)| b == (i % 253) as u8));
            assert!(std::slice::from_raw_parts(q.add(LARGE), 4 * LARGE).iter().all(|&b| b == 0), "new pages are zero");
            a.dealloc(q, Layout::from_size_align(5 * LARGE, 64).unwrap());
        }
    }
}
