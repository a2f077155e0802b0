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
//! Freed blocks are kept for the next large allocation (a cache of at most 64 blocks and 256 MiB) instead of being
//! returned at once: on the 2-core Zen 4 KVM guest a fresh page costs 0.25–2.3 ms a MB (the kernel's fault and
//! zeroing), a reused one 0.04 (a `memset`), and `gbuf report` makes and frees several GB of images, masks, bands and
//! packed frames of a few sizes. The smallest cached block that fits is cut to size (its tail stays cached). Failing
//! one, the block is assembled from the largest cached blocks: the kernel moves their pages onto one reserved range
//! (`mremap`, no copy), and only what the cache cannot fill is fresh; the pieces return to the cache one by one when it
//! is freed. Reading a 1080p × 4 EXR frees its decoded channels while the G-buffer's planes are built: assembled from
//! them, `gbuf resolve` of that frame peaks at 0.84 instead of 1.11 GB. The cache never raises the resident set above
//! what it was by itself; it does keep freed pages resident while small allocations grow, hence its bound (at 1 GiB the
//! report peaked 24 MiB higher).
//!
//! Linux only; elsewhere the type forwards everything to [`std::alloc::System`].

use std::alloc::{GlobalAlloc, Layout, System};

/// Blocks of at least this many bytes are mapped on their own.
pub const LARGE: usize = 4 << 20;
/// The huge page size blocks are aligned and rounded to.
const HUGE: usize = 2 << 20;
/// Freed blocks the cache holds at most, and their bytes at most.
const CACHE_SLOTS: usize = 64;
const CACHE_BYTES: usize = 256 << 20;

/// Blocks the cache has assembled from several and that are in use, at most; and pieces per block, at most.
const ASSEMBLED: usize = 16;
const PIECES: usize = 8;

/// Freed mapped blocks (address, length), oldest first, waiting to be reused; and the blocks in use that were
/// assembled from several, with their pieces' lengths in order (their pages are mappings of their own, which the
/// kernel moves only one at a time: each returns to the cache as a block of its own).
struct Cache {
    blocks: [(usize, usize); CACHE_SLOTS],
    n: usize,
    bytes: usize,
    assembled: [(usize, [usize; PIECES]); ASSEMBLED],
    na: usize,
}

static CACHE: std::sync::Mutex<Cache> = std::sync::Mutex::new(Cache::new());

impl Cache {
    const fn new() -> Cache {
        Cache { blocks: [(0, 0); CACHE_SLOTS], n: 0, bytes: 0, assembled: [(0, [0; PIECES]); ASSEMBLED], na: 0 }
    }

    /// A block of `len` bytes made from the cache, and how many of its leading bytes may hold old data (the rest
    /// are fresh zero pages); `None` when the cache is empty (or the kernel refuses a move). The smallest cached
    /// block of at least `len` bytes is cut to `len` (its tail stays cached). Failing one, the block is assembled
    /// from the largest cached blocks, their pages moved by the kernel onto one reserved range, the rest of which is
    /// fresh only when the cache runs out: the resident set does not grow while freed blocks sit here. When too many
    /// assembled blocks are in use, the largest cached block is grown instead, after the oldest others are unmapped
    /// until as many bytes are returned as it adds.
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
        if self.n == 0 {
            return None;
        }
        if self.na < ASSEMBLED {
            return self.assemble(len);
        }
        let largest = (0..self.n).max_by_key(|&i| self.blocks[i].1)?;
        let (addr, have) = self.remove(largest);
        let mut returned = 0;
        while returned < len - have && self.n > 0 {
            let (a, l) = self.remove(0);
            // SAFETY: a whole block this cache owns, unused.
            unsafe { os::unmap(a as *mut u8, l) };
            returned += l;
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

    /// [`Cache::take`]'s assembly: the largest cached blocks moved onto a fresh reservation of `len` bytes, one
    /// after another (the last one cut), until it is full or [`PIECES`]` - 1` are in; the rest opened fresh.
    fn assemble(&mut self, len: usize) -> Option<(*mut u8, usize)> {
        let target = os::reserve(len);
        if target.is_null() {
            return None;
        }
        let (mut pieces, mut np, mut filled) = ([0usize; PIECES], 0, 0);
        while filled < len && self.n > 0 && np < PIECES - 1 {
            let i = (0..self.n).max_by_key(|&i| self.blocks[i].1).expect("a cached block");
            let (addr, have) = self.blocks[i];
            let part = have.min(len - filled);
            // SAFETY: the first `part` bytes of a block this cache owns (one mapping, unused), moved onto the part of
            // our own reservation that nothing has used yet.
            let moved = unsafe { os::move_to(addr as *mut u8, part, target.add(filled)) };
            if !moved {
                // SAFETY: the pieces moved so far and the reservation after the failed range are ours and unused; the
                // failed range may already be unmapped (and then is not ours), so it is left alone. The block that
                // did not move is still whole where it was, and stays cached.
                unsafe {
                    os::unmap(target, filled);
                    if filled + part < len {
                        os::unmap(target.add(filled + part), len - filled - part);
                    }
                }
                return None;
            }
            if part == have {
                self.remove(i);
            } else {
                self.blocks[i] = (addr + part, have - part);
                self.bytes -= part;
            }
            pieces[np] = part;
            np += 1;
            filled += part;
        }
        if filled < len {
            // SAFETY: the rest of our own reservation, unused.
            if !unsafe { os::open(target.add(filled), len - filled) } {
                // SAFETY: all of it ours: the moved pieces and the reservation.
                unsafe { os::unmap(target, len) };
                return None;
            }
            pieces[np] = len - filled;
            np += 1;
        }
        if np > 1 {
            self.assembled[self.na] = (target as usize, pieces);
            self.na += 1;
        }
        Some((target, filled))
    }

    /// Takes back a freed block of `len` bytes: each of its pieces when it was assembled, else itself; what does not
    /// fit is unmapped.
    fn release(&mut self, addr: usize, len: usize) {
        let keep = |c: &mut Cache, a: usize, l: usize| {
            if !c.keep(a, l) {
                // SAFETY: a freed block (or a piece of one, one mapping) that nothing uses.
                unsafe { os::unmap(a as *mut u8, l) };
            }
        };
        let Some(k) = self.forget(addr) else { return keep(self, addr, len) };
        let mut off = 0;
        for &piece in k.iter().take_while(|&&p| p > 0) {
            if off >= len {
                break;
            }
            let l = piece.min(len - off);
            keep(self, addr + off, l);
            off += l;
        }
        if off < len {
            keep(self, addr + off, len - off);
        }
    }

    /// Drops the record of the assembled block at `addr` (freed, or moved by `realloc`), returning its pieces.
    fn forget(&mut self, addr: usize) -> Option<[usize; PIECES]> {
        let k = (0..self.na).find(|&k| self.assembled[k].0 == addr)?;
        let pieces = self.assembled[k].1;
        self.assembled.copy_within(k + 1..self.na, k);
        self.na -= 1;
        Some(pieces)
    }

    /// Keeps a freed block of `len` bytes; false (the caller unmaps it) when it does not fit. Older blocks are
    /// unmapped to make room.
    fn keep(&mut self, addr: usize, len: usize) -> bool {
        if len > CACHE_BYTES {
            return false;
        }
        while self.n > 0 && (self.n == CACHE_SLOTS || self.bytes + len > CACHE_BYTES) {
            let (a, l) = self.remove(0);
            // SAFETY: a whole block this cache owns, unused.
            unsafe { os::unmap(a as *mut u8, l) };
        }
        self.blocks[self.n] = (addr, len);
        self.n += 1;
        self.bytes += len;
        true
    }

    fn remove(&mut self, i: usize) -> (usize, usize) {
        let b = self.blocks[i];
        self.blocks.copy_within(i + 1..self.n, i);
        self.n -= 1;
        self.bytes -= b.1;
        b
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

    /// An inaccessible reservation of `len` bytes (a multiple of [`HUGE`]) at a 2 MiB boundary, for [`move_to`] and
    /// [`open`]; null when the system refuses.
    pub fn reserve(len: usize) -> *mut u8 {
        let Some(over) = len.checked_add(HUGE) else { return std::ptr::null_mut() };
        // SAFETY: an inaccessible anonymous map at an address the kernel chooses: no existing memory is affected.
        let raw = unsafe {
            libc::mmap(std::ptr::null_mut(), over, libc::PROT_NONE, libc::MAP_PRIVATE | libc::MAP_ANONYMOUS, -1, 0)
        };
        if raw == libc::MAP_FAILED {
            return std::ptr::null_mut();
        }
        let raw = raw.cast::<u8>();
        let lead = raw.align_offset(HUGE);
        // SAFETY: the trimmed ends are parts of the map just made that no one else has seen.
        unsafe {
            if lead > 0 {
                libc::munmap(raw.cast(), lead);
            }
            let tail = over - lead - len;
            if tail > 0 {
                libc::munmap(raw.add(lead + len).cast(), tail);
            }
            raw.add(lead)
        }
    }

    /// Moves the `len` mapped bytes at `from` (within one mapping) onto `to` without copying: the kernel moves the
    /// pages. False when it refuses: `from` is then as it was, and `[to, to + len)` may have been unmapped.
    ///
    /// # Safety
    /// `from..from + len` lies in one of our mappings that nothing uses; `to..to + len` in a reservation of
    /// [`reserve`]'s that nothing uses.
    pub unsafe fn move_to(from: *mut u8, len: usize, to: *mut u8) -> bool {
        // SAFETY: the caller's unused pages moved onto the caller's unused reservation, which they replace.
        let moved = unsafe {
            libc::mremap(from.cast(), len, len, libc::MREMAP_MAYMOVE | libc::MREMAP_FIXED, to.cast::<libc::c_void>())
        };
        moved != libc::MAP_FAILED
    }

    /// Makes `[ptr, ptr + len)` of a reservation readable and writable (zero pages, faulted in on first touch) and
    /// advises huge pages; false when the system refuses.
    ///
    /// # Safety
    /// The range lies in a reservation of [`reserve`]'s that nothing uses.
    pub unsafe fn open(ptr: *mut u8, len: usize) -> bool {
        // SAFETY: the caller's own reservation.
        unsafe {
            if libc::mprotect(ptr.cast(), len, libc::PROT_READ | libc::PROT_WRITE) != 0 {
                return false;
            }
            // Advice only, as in `map`.
            libc::madvise(ptr.cast(), len, libc::MADV_HUGEPAGE);
        }
        true
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
    pub fn reserve(_: usize) -> *mut u8 {
        unreachable!("no block is mapped outside Linux")
    }
    pub unsafe fn move_to(_: *mut u8, _: usize, _: *mut u8) -> bool {
        unreachable!("no block is mapped outside Linux")
    }
    pub unsafe fn open(_: *mut u8, _: usize) -> bool {
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
            match CACHE.lock() {
                Ok(mut c) => c.release(ptr as usize, len),
                // SAFETY: `ptr` came from `alloc`/`alloc_zeroed`/`realloc` with this layout, which mapped it with
                // this rounded length.
                Err(_) => unsafe { os::unmap(ptr, len) },
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
                    // Resized whole: one mapping now, whatever it was made of.
                    if let Ok(mut c) = CACHE.lock() {
                        c.forget(ptr as usize);
                    }
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

    /// The cache hands back the smallest freed block that fits, cut to size (the tail kept); failing one it assembles
    /// the block from its largest ones (their bytes kept, the rest zero), which return as pieces; with too many
    /// assembled blocks in use it grows its largest instead, after returning as many other cached bytes as it adds; a
    /// full cache drops its oldest block.
    #[test]
    #[cfg(target_os = "linux")]
    fn the_cache_reuses_the_best_fit_assembles_or_grows_and_never_holds_more_than_it_returns() {
        let mut c = Cache::new();
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
        // No block fits: the block is assembled from the largest ones, their bytes kept, the rest fresh.
        assert_eq!(c.take(HUGE), None, "an empty cache serves nothing");
        let third = block(HUGE);
        assert!(c.keep(small, 2 * HUGE) && c.keep(big, 3 * HUGE) && c.keep(third, HUGE));
        let (five, dirty) = c.take(5 * HUGE).expect("assembled");
        assert_eq!(dirty, 5 * HUGE);
        assert_eq!((c.n, c.bytes, c.na), (1, HUGE, 1), "the third block stays cached");
        // SAFETY: a block of 5 huge pages the cache made from the big block's 3 and the small one's 2.
        unsafe {
            for at in [0, 3 * HUGE - 1, 3 * HUGE, 5 * HUGE - 1] {
                assert_eq!(*five.add(at), 0xab, "byte {at}");
            }
        }
        // Freed, it returns as its pieces; a larger request then takes all three and opens the rest fresh.
        c.release(five as usize, 5 * HUGE);
        assert_eq!((c.n, c.bytes, c.na), (3, 6 * HUGE, 0));
        let (eight, dirty) = c.take(8 * HUGE).expect("assembled");
        assert_eq!(dirty, 6 * HUGE, "only the moved pieces may hold old bytes");
        assert_eq!((c.n, c.bytes, c.na), (0, 0, 1));
        // SAFETY: a block of 8 huge pages: 6 moved, 2 fresh.
        unsafe {
            assert_eq!(*eight.add(6 * HUGE - 1), 0xab);
            assert!(std::slice::from_raw_parts(eight.add(6 * HUGE), 2 * HUGE).iter().all(|&b| b == 0));
            *eight.add(8 * HUGE - 1) = 1;
        }
        c.release(eight as usize, 8 * HUGE);
        assert_eq!((c.n, c.bytes, c.na), (4, 8 * HUGE, 0), "four pieces: 3, 2, 1 and the fresh 2");
        // With too many assembled blocks in use, the largest grows instead, after the oldest others go back.
        c.na = ASSEMBLED;
        let (grown, dirty) = c.take(5 * HUGE).expect("the largest block grows");
        assert_eq!(dirty, 3 * HUGE, "only the grown block's own bytes may be old");
        assert_eq!((c.n, c.bytes), (2, 3 * HUGE), "growing by 2 huge pages returned the oldest other (2)");
        c.na = 0;
        // SAFETY: a block of 5 huge pages this test owns: its first 3 are the old block's, the others fresh.
        unsafe {
            assert_eq!(*grown.add(3 * HUGE - 1), 0xab);
            assert!(std::slice::from_raw_parts(grown.add(3 * HUGE), 2 * HUGE).iter().all(|&b| b == 0));
            os::unmap(grown, 5 * HUGE);
        }
        while c.n > 0 {
            let (a, l) = c.remove(0);
            // SAFETY: the cached pieces left, each released once.
            unsafe { os::unmap(a as *mut u8, l) };
        }
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
