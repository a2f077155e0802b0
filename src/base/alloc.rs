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
//! Linux only; elsewhere the type forwards everything to [`std::alloc::System`].

use std::alloc::{GlobalAlloc, Layout, System};

/// Blocks of at least this many bytes are mapped on their own.
pub const LARGE: usize = 4 << 20;
/// The huge page size blocks are aligned and rounded to.
const HUGE: usize = 2 << 20;

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
            os::map(rounded(layout.size()))
        } else {
            // SAFETY: forwarded with the caller's layout (non-zero size, as `GlobalAlloc` requires).
            unsafe { System.alloc(layout) }
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if mapped(layout) {
            // Anonymous maps are zero.
            os::map(rounded(layout.size()))
        } else {
            // SAFETY: as in `alloc`.
            unsafe { System.alloc_zeroed(layout) }
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if mapped(layout) {
            // SAFETY: `ptr` came from `alloc`/`alloc_zeroed`/`realloc` with this layout, which mapped it with this
            // rounded length.
            unsafe { os::unmap(ptr, rounded(layout.size())) }
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
            _ => {
                // SAFETY: `new` has a non-zero size (`new_size ≥ 1` by the contract).
                let to = unsafe { self.alloc(new) };
                if !to.is_null() {
                    // SAFETY: both blocks hold at least the smaller size; they are distinct allocations.
                    unsafe {
                        std::ptr::copy_nonoverlapping(ptr, to, layout.size().min(new_size));
                        self.dealloc(ptr, layout);
                    }
                }
                to
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks either side of the threshold, grown and shrunk across it, keep their bytes and are released.
    #[test]
    fn blocks_keep_their_bytes_across_the_threshold() {
        let a = LargePages;
        for (size, new_size) in
            [(64, LARGE + 1), (LARGE + 1, 64), (LARGE, LARGE + HUGE), (LARGE + 5, LARGE + 7), (3 * LARGE, LARGE - 1)]
        {
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
                for i in (0..size.min(new_size)).step_by(4093) {
                    assert_eq!(*q.add(i), (i % 251) as u8, "{size} → {new_size}: byte {i}");
                }
                *q.add(new_size - 1) = 7;
                a.dealloc(q, Layout::from_size_align(new_size, 16).unwrap());
            }
        }
    }
}
