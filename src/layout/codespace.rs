//! How much of each field's code space a frame uses: the question "what does the scene not need" asked of a
//! layout's own bits, which an already-packed frame (an engine's capture, no float truth) can answer exactly.
//!
//! Per field, over the covered samples: the distinct codes and their share of the 2^bits codes, the smallest and
//! largest code, and the bits that never change (a field whose top bits are constant could be narrower; a
//! reserved field that is always 0 is free space).

use super::bits::{extract, load_le};
use super::{Layout, Packed, Slot};
use rayon::prelude::*;
use serde::Serialize;

/// The code usage of one field.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FieldCodes {
    /// The render target.
    pub target: String,
    /// What the field stores (`normal`, `albedo.g`, `material_index`, `reserved`).
    pub field: String,
    /// Its codec (empty for reserved bits and the material index).
    pub codec: String,
    /// First bit in the texel.
    pub offset: u32,
    /// Width in bits.
    pub bits: u32,
    /// Covered samples read.
    pub samples: u64,
    /// Distinct codes among them.
    pub distinct: u64,
    /// `distinct / 2^bits`.
    pub used_fraction: f64,
    /// Smallest code.
    pub min: u64,
    /// Largest code.
    pub max: u64,
    /// Bits (of the field, bit 0 = its lowest) that hold the same value in every sample.
    pub constant_bits: u64,
    /// How many of the field's bits never change.
    pub constant_bit_count: u32,
}

/// Fields up to this width count distinct codes in a bitmap (2^24 bits = 2 MiB); wider ones sort the codes.
const BITMAP_BITS: u32 = 24;

fn mask(bits: u32) -> u64 {
    if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    }
}

/// The code usage of every field of `layout` in `packed` over the samples where `coverage` is true (every
/// sample when `coverage` is empty).
#[must_use]
pub fn code_space(layout: &Layout, packed: &Packed, coverage: &[bool]) -> Vec<FieldCodes> {
    layout
        .fields()
        .iter()
        .map(|f| {
            let t = &packed.targets[f.target];
            let size = t.format.bytes();
            let covered = |i: usize| coverage.is_empty() || coverage.get(i).copied().unwrap_or(false);
            let codes: Vec<u64> = t
                .bytes
                .par_chunks_exact(size)
                .enumerate()
                .filter(|(i, _)| covered(*i))
                .map(|(_, texel)| extract(load_le(texel), f.offset, f.bits))
                .collect();
            let m = mask(f.bits);
            let (min, max, and, or) = codes
                .par_iter()
                .fold(|| (u64::MAX, 0u64, m, 0u64), |(lo, hi, a, o), &c| (lo.min(c), hi.max(c), a & c, o | c))
                .reduce(|| (u64::MAX, 0, m, 0), |x, y| (x.0.min(y.0), x.1.max(y.1), x.2 & y.2, x.3 | y.3));
            let distinct = if f.bits <= BITMAP_BITS {
                let mut seen = vec![0u64; (1usize << f.bits).div_ceil(64)];
                for &c in &codes {
                    seen[(c >> 6) as usize] |= 1 << (c & 63);
                }
                seen.iter().map(|w| u64::from(w.count_ones())).sum()
            } else {
                let mut v = codes.clone();
                v.par_sort_unstable();
                v.dedup();
                v.len() as u64
            };
            let constant = if codes.is_empty() { 0 } else { !(and ^ or) & m };
            let name = match f.slot {
                Slot::Reserved => "reserved".to_string(),
                s => s.name(),
            };
            FieldCodes {
                target: t.name.clone(),
                field: name,
                codec: f.codec.clone(),
                offset: f.offset,
                bits: f.bits,
                samples: codes.len() as u64,
                distinct,
                used_fraction: distinct as f64 / 2f64.powi(f.bits as i32),
                min: if codes.is_empty() { 0 } else { min },
                max,
                constant_bits: constant,
                constant_bit_count: constant.count_ones(),
            }
        })
        .collect()
}

/// One line per field: `target  field  codec  bits  distinct (share)  min–max  constant bits`.
#[must_use]
pub fn text(rows: &[FieldCodes]) -> String {
    let mut out = String::new();
    for r in rows {
        let constant = match r.constant_bit_count {
            0 => String::new(),
            n if n == r.bits => "  every bit constant".to_string(),
            n => format!("  {n} bits never change (mask {:#x})", r.constant_bits),
        };
        out.push_str(&format!(
            "  {:<14} {:<16} {:<14} {:>2} bits  {:>9} codes ({:.3} % of 2^{})  {}–{}{constant}\n",
            r.target,
            r.field,
            r.codec,
            r.bits,
            r.distinct,
            100.0 * r.used_fraction,
            r.bits,
            r.min,
            r.max
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gbuffer::GBuffer;

    /// A hand-made frame: the counts, extremes and constant bits are what the codes say.
    #[test]
    fn counts_extremes_and_constant_bits_match_the_codes() {
        let layout = Layout::by_name("unreal-like").unwrap();
        let mut gb = GBuffer::new(4, 1, 1).unwrap();
        gb.coverage = vec![true, true, true, false];
        gb.depth = Some(vec![1.0, 2.0, 2.0, 0.0]);
        gb.roughness = Some(vec![0.0, 1.0, 0.5, 0.0]);
        gb.metallic = Some(vec![1.0, 1.0, 1.0, 0.0]);
        let packed = layout.pack(&gb).unwrap();
        let rows = code_space(&layout, &packed, &gb.coverage);
        let r = rows.iter().find(|r| r.field == "roughness").unwrap();
        assert_eq!((r.samples, r.distinct, r.min, r.max), (3, 3, 0, 255));
        assert_eq!(r.constant_bit_count, 0);
        let m = rows.iter().find(|r| r.field == "metallic").unwrap();
        assert_eq!((m.distinct, m.min, m.max, m.constant_bit_count), (1, 255, 255, 8));
        assert!((m.used_fraction - 1.0 / 256.0).abs() < 1e-12);
        let d = rows.iter().find(|r| r.field == "depth").unwrap();
        assert_eq!(d.distinct, 2, "two depths over three covered samples");
        let reserved = rows.iter().find(|r| r.field == "reserved" && r.target == "gbuffer_b").unwrap();
        assert_eq!((reserved.distinct, reserved.max, reserved.constant_bit_count), (1, 0, reserved.bits));
        assert!(text(&rows).contains("every bit constant"));
    }
}
