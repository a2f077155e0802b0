//! Large planes allocated without a serial fill.

/// From this many bytes, [`zeroed_on_huge_pages`] gives a block the global allocator maps on huge pages.
pub const HUGE_FROM: usize = 512 << 10;

/// `n` zero vectors from zeroed memory (`calloc`: the pages are zeroed lazily by the OS, when first written, rather
/// than filled one by one, which `vec![Vec3::ZERO; n]` does serially). For large planes a loader fills in parallel.
#[must_use]
pub fn zeroed_vec3(n: usize) -> Vec<glam::Vec3> {
    const _: () = assert!(std::mem::size_of::<glam::Vec3>() == 12 && std::mem::align_of::<glam::Vec3>() == 4);
    let mut v = std::mem::ManuallyDrop::new(vec![[0.0f32; 3]; n]);
    let (ptr, len, cap) = (v.as_mut_ptr(), v.len(), v.capacity());
    // SAFETY: `[f32; 3]` and `Vec3` (`#[repr(C)]`, three f32 fields) have the same size and alignment (checked
    // above), so the allocation is valid for `Vec<Vec3>` with the same length and capacity, and all-zero bits are
    // `Vec3::ZERO`. The original vector is not dropped (`ManuallyDrop`).
    unsafe { Vec::from_raw_parts(ptr.cast::<glam::Vec3>(), len, cap) }
}

/// `n` zeros (`T` a number type), with the capacity raised to [`crate::base::alloc::LARGE`] bytes when they take
/// [`HUGE_FROM`] bytes or more: the command line's allocator ([`crate::base::alloc::LargePages`]) then maps the
/// block on 2 MiB pages, faulted in a dozen times instead of some 700 times a 2.7 MB picture. For a frame's planes
/// that a one-frame process fills once (`gbuf resolve` at 720p: its 8-bit picture and light counts, the coverage
/// and the 1-sample mask copied from it): 6 ms of a 59 ms process on a 2-core KVM guest. Only the pages written
/// are resident (at most one huge page beyond `n`). Lowering the allocator's own threshold instead made `gbuf report`, which frees and makes blocks of 1–4
/// MB all the time, pay 1.3–3.4 s more system time (docs/RESOLVE.md, "How the kernel is built").
#[must_use]
pub fn zeroed_on_huge_pages<T: Copy + Default>(n: usize) -> Vec<T> {
    let size = std::mem::size_of::<T>().max(1);
    let cap = if n.saturating_mul(size) >= HUGE_FROM { n.max(crate::base::alloc::LARGE.div_ceil(size)) } else { n };
    // `vec!` of a number type's zero asks the allocator for zeroed memory (`alloc_zeroed`): no fill here.
    let mut v = vec![T::default(); cap];
    v.truncate(n);
    v
}

/// Asks the CPU to load the cache lines holding bytes `a..b` of `base`: into every level when `near` (needed next),
/// else into L2 and beyond (needed a step later). A hint only: a prefetch never faults, whatever the address, and the
/// addresses are formed with `wrapping_add`, never claimed in bounds. Nothing on other architectures.
#[inline(always)]
pub fn prefetch(base: *const u8, a: usize, b: usize, near: bool) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0, _MM_HINT_T1};
        let (first, end) = (base.wrapping_add(a), base.wrapping_add(b));
        let mut line = first.wrapping_sub(first as usize & 63);
        while line < end {
            // SAFETY: a prefetch has no effect but on the cache, whatever the address.
            unsafe {
                if near {
                    _mm_prefetch::<_MM_HINT_T0>(line.cast());
                } else {
                    _mm_prefetch::<_MM_HINT_T1>(line.cast());
                }
            }
            line = line.wrapping_add(64);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (base, a, b, near);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeroed_on_huge_pages_is_zeros_with_a_large_block_from_a_megabyte() {
        for n in [0, 5, HUGE_FROM / 4 - 1, HUGE_FROM / 4, 3 << 20] {
            let mut v: Vec<u32> = zeroed_on_huge_pages(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|&x| x == 0));
            let large = n * 4 >= HUGE_FROM;
            assert_eq!(v.capacity() * 4 >= crate::base::alloc::LARGE, large, "{n}");
            assert!(large || v.capacity() == n, "{n}: no block rounded below the threshold");
            v.push(9); // a valid Vec: it grows and drops
            assert_eq!(v[n], 9);
        }
    }

    #[test]
    fn zeroed_vec3_is_zero_vectors_of_the_asked_length() {
        for n in [0, 1, 7, 100_000] {
            let mut v = zeroed_vec3(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|x| *x == glam::Vec3::ZERO));
            v.push(glam::Vec3::ONE); // the allocation is a valid Vec<Vec3>: it grows and drops
            assert_eq!(v[n], glam::Vec3::ONE);
        }
    }
}
