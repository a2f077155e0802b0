//! Bit packing: placing codes into texel words and texel words into little-endian bytes.
//!
//! A texel is at most 128 bits (RGBA32UI), so one `u128` holds any texel. Codes are the low `bits` bits of a `u64`
//! (the codec convention); anything above is masked off, never shifted into a neighbouring field.

/// A mask of the low `bits` bits (`bits` ≤ 64).
#[inline]
#[must_use]
pub fn mask(bits: u32) -> u64 {
    debug_assert!(bits <= 64);
    if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    }
}

/// ORs the low `bits` bits of `code` into `word` at bit `offset`.
#[inline]
pub fn insert(word: &mut u128, offset: u32, bits: u32, code: u64) {
    debug_assert!(offset + bits <= 128);
    *word |= u128::from(code & mask(bits)) << offset;
}

/// Reads `bits` bits of `word` starting at bit `offset`.
#[inline]
#[must_use]
pub fn extract(word: u128, offset: u32, bits: u32) -> u64 {
    debug_assert!(offset + bits <= 128);
    (word >> offset) as u64 & mask(bits)
}

/// Writes the low `out.len()` bytes of `word`, little-endian.
#[inline]
pub fn store_le(word: u128, out: &mut [u8]) {
    let bytes = word.to_le_bytes();
    out.copy_from_slice(&bytes[..out.len()]);
}

/// Reads a little-endian word of `src.len()` (≤ 16) bytes.
#[inline]
#[must_use]
pub fn load_le(src: &[u8]) -> u128 {
    let mut bytes = [0u8; 16];
    bytes[..src.len()].copy_from_slice(src);
    u128::from_le_bytes(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn insert_and_extract_round_trip_without_touching_neighbours() {
        let mut w = 0u128;
        insert(&mut w, 0, 10, 0x3ff);
        insert(&mut w, 10, 10, 0x155);
        insert(&mut w, 20, 10, 0xffff_ffff); // oversized code: masked to 10 bits
        insert(&mut w, 30, 2, 2);
        assert_eq!(extract(w, 0, 10), 0x3ff);
        assert_eq!(extract(w, 10, 10), 0x155);
        assert_eq!(extract(w, 20, 10), 0x3ff);
        assert_eq!(extract(w, 30, 2), 2);
        assert_eq!(w >> 32, 0);
        insert(&mut w, 64, 64, u64::MAX);
        assert_eq!(extract(w, 64, 64), u64::MAX);
        assert_eq!(extract(w, 0, 32), 0xbff5_57ff);
    }

    #[test]
    fn little_endian_bytes_match_the_gpu_layout() {
        // RGBA8 (r=1, g=2, b=3, a=4) is the bytes 01 02 03 04 in memory.
        let mut w = 0u128;
        for (i, v) in [1u64, 2, 3, 4].into_iter().enumerate() {
            insert(&mut w, 8 * i as u32, 8, v);
        }
        let mut out = [0u8; 4];
        store_le(w, &mut out);
        assert_eq!(out, [1, 2, 3, 4]);
        assert_eq!(load_le(&out), w);
        // D24S8: depth 0xABCDEF in bits 0-23, stencil 0x12 in 24-31.
        let mut d = 0u128;
        insert(&mut d, 0, 24, 0xabcdef);
        insert(&mut d, 24, 8, 0x12);
        store_le(d, &mut out);
        assert_eq!(out, [0xef, 0xcd, 0xab, 0x12]);
        let mut wide = [0u8; 16];
        store_le(u128::MAX - 5, &mut wide);
        assert_eq!(load_le(&wide), u128::MAX - 5);
    }
}
