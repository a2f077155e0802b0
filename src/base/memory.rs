//! Large planes allocated without a serial fill.

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

#[cfg(test)]
mod tests {
    use super::*;

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
