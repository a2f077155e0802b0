//! Scalar codecs: specular amount, roughness, metallic, AO, specular power.
//!
//! | name | bits | domain | error bound | source |
//! |---|---|---|---|---|
//! | `unorm-N` (N = 1..=24) | N | [0, 1] | 0.5/(2^N−1) | D3D/Vulkan UNORM conversion rules |
//! | `snorm-N` (N = 2..=24) | N | [−1, 1] | 0.5/(2^(N−1)−1) | D3D/Vulkan SNORM conversion rules |
//! | `snorm-N:R` (R > 0 finite) | N | [−R, R] | R·0.5/(2^(N−1)−1) | SNORM scaled by R (e.g. motion in pixels) |
//! | `f16` | 16 | [−65504, 65504] | |v|·2^-11 + 2^-25 | IEEE 754 binary16 (`half` crate) |
//! | `f32` | 32 | all finite f32 | 0 | IEEE 754 binary32 |
//! | `log2-unorm-N` (N = 2..=24) | N | specular power [1, 4096] | v·(2^(6/(2^N−1)) − 1) | power as log2 (Killzone 2 / Valient 2007 style) |
//! | `specpow-unorm-N` (N = 2..=24) | N | specular power [0, 4096] | 2048/(2^N−1) | power stored directly, scaled |
//!
//! Defined results outside the domain: NaN encodes as the domain's lower end (0, or 1 for log2; 0 for snorm), +Inf
//! as the upper end, −Inf as the lower end; finite values clamp. Snorm codes are N-bit two's complement; 0 and ±R
//! are exact, and the code −2^(N−1) (which no encode produces) decodes to −R, as in D3D. f16: magnitudes above 65504 clamp to ±65504 (never Inf),
//! magnitudes below 2^-25 flush to ±0. Decoders only ever return finite values (f16 Inf/NaN codes decode to
//! ±65504 / 0).

use super::normal::{f16_to_finite, round_in_range_f64, F16_TO_FINITE_OPS};
use super::simd::f32_to_f16_bits;
use super::{mask, split_bits, Codec, ScalarCodec, TRANSCENDENTAL_OPS};
use crate::base::isa::Isa;

/// Every valid name pattern (for error messages).
pub const VALID_NAMES: &[&str] = &[
    "unorm-N (1..=24)",
    "snorm-N (2..=24)",
    "snorm-N:R (range ±R)",
    "f16",
    "f32",
    "log2-unorm-N (2..=24)",
    "specpow-unorm-N (2..=24)",
];

/// Largest `R` of `snorm-N:R` (beyond it the range overflows f32 arithmetic of the bound).
pub const MAX_SNORM_RANGE: f32 = 1e30;

/// Largest specular power the log2 and direct power codecs represent (2^12).
pub const MAX_SPECULAR_POWER: f32 = 4096.0;
const LOG2_MAX_POWER: f32 = 12.0;

/// Looks a scalar codec up by name (see the module table); `None` for unknown names or bit counts.
#[must_use]
pub fn scalar_codec(name: &str) -> Option<Box<dyn ScalarCodec>> {
    match name {
        "f16" => return Some(Box::new(ScalarF16)),
        "f32" => return Some(Box::new(ScalarF32)),
        _ => {}
    }
    if let Some(rest) = name.strip_prefix("snorm-") {
        let (bits, range) = match rest.split_once(':') {
            Some((b, r)) => (b, r.parse::<f32>().ok()?),
            None => (rest, 1.0),
        };
        if bits.is_empty() || bits.len() > 2 || !bits.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        let n: u32 = bits.parse().ok()?;
        let range_ok = range.is_finite() && range > 0.0 && range <= MAX_SNORM_RANGE;
        return ((2..=24).contains(&n) && range_ok).then(|| Box::new(Snorm::new(n, range)) as Box<dyn ScalarCodec>);
    }
    let (prefix, n) = split_bits(name)?;
    match prefix {
        "unorm" if (1..=24).contains(&n) => Some(Box::new(Unorm::new(n, 0.0, 1.0, "unorm"))),
        "specpow-unorm" if (2..=24).contains(&n) => {
            Some(Box::new(Unorm::new(n, 0.0, MAX_SPECULAR_POWER, "specpow-unorm")))
        }
        "log2-unorm" if (2..=24).contains(&n) => Some(Box::new(Log2Unorm { inner: Unorm::new(n, 0.0, 1.0, "") })),
        _ => None,
    }
}

/// Unsigned normalized integer of `bits` bits over [lo, hi]: `u = round((v−lo)/(hi−lo)·(2^N−1))`.
#[derive(Clone, Copy, Debug)]
pub struct Unorm {
    bits: u32,
    lo: f32,
    hi: f32,
    prefix: &'static str,
}

impl Unorm {
    /// A unorm codec over [lo, hi].
    #[must_use]
    pub fn new(bits: u32, lo: f32, hi: f32, prefix: &'static str) -> Self {
        Unorm { bits, lo, hi, prefix }
    }
    #[inline(always)]
    fn max_code(&self) -> f64 {
        mask(self.bits) as f64
    }
}

/// Signed normalized integer of `bits` bits over [−R, R] (D3D SNORM rules scaled by R):
/// `s = round(clamp(v/R, −1, 1)·(2^(N−1)−1))` in N-bit two's complement; decode `max(s/(2^(N−1)−1), −1)·R`.
#[derive(Clone, Copy, Debug)]
pub struct Snorm {
    bits: u32,
    range: f32,
}

impl Snorm {
    /// Snorm with `bits` bits (2..=24) over [−range, range].
    #[must_use]
    pub fn new(bits: u32, range: f32) -> Self {
        Snorm { bits, range }
    }
    #[inline(always)]
    fn max_code(&self) -> f64 {
        mask(self.bits - 1) as f64
    }
}

impl Codec for Snorm {
    type Value = f32;
    fn name(&self) -> String {
        if self.range == 1.0 {
            format!("snorm-{}", self.bits)
        } else {
            format!("snorm-{}:{}", self.bits, self.range)
        }
    }
    fn bits(&self) -> u32 {
        self.bits
    }
    #[inline(always)]
    fn encode(&self, v: f32) -> u64 {
        let t = if v.is_nan() { 0.0 } else { (v / self.range).clamp(-1.0, 1.0) };
        // f64 so that 24-bit codes round exactly (halves away from zero, like D3D).
        let s = round_in_range_f64(f64::from(t) * self.max_code());
        (s as u32 as u64) & mask(self.bits)
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> f32 {
        let k = self.bits;
        let s = ((((code & mask(k)) as u32) << (32 - k)) as i32) >> (32 - k);
        ((f64::from(s) / self.max_code()).max(-1.0) * f64::from(self.range)) as f32
    }
    fn decode_ops(&self) -> u32 {
        // and, shl, sar (sign-extend), int→f64, div, max(−1), mul by R, f64→f32
        8
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::ScalarSnorm { bits: self.bits, range: self.range })
    }
}

impl ScalarCodec for Snorm {
    fn domain(&self) -> (f32, f32) {
        (-self.range, self.range)
    }
    fn error_bound(&self, _v: f32) -> f32 {
        // Half a step, plus f32 rounding of the result (relative 2^-24 of the range).
        ((0.5 / self.max_code()) * f64::from(self.range)) as f32 + self.range * 2f32.powi(-23)
    }
}

impl Codec for Unorm {
    type Value = f32;
    fn name(&self) -> String {
        format!("{}-{}", self.prefix, self.bits)
    }
    fn bits(&self) -> u32 {
        self.bits
    }
    #[inline(always)]
    fn encode(&self, v: f32) -> u64 {
        let t = if v.is_nan() { 0.0 } else { ((v - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0) };
        // f64 so that 24-bit codes round exactly; the code is < 2^24, so i32 lanes hold it (and vectorise).
        round_in_range_f64(f64::from(t) * self.max_code()) as u64
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> f32 {
        let t = f64::from((code & mask(self.bits)) as i32) / self.max_code();
        (f64::from(self.lo) + t * f64::from(self.hi - self.lo)) as f32
    }
    fn decode_ops(&self) -> u32 {
        // and, int→f64, div, mul, add, f64→f32 (the scale and offset are per-codec constants)
        6
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::ScalarUnorm { bits: self.bits, lo: self.lo, hi: self.hi })
    }
}

impl ScalarCodec for Unorm {
    fn domain(&self) -> (f32, f32) {
        (self.lo, self.hi)
    }
    fn error_bound(&self, _v: f32) -> f32 {
        // Half a step, plus f32 rounding of the result (relative 2^-24 of the range).
        ((0.5 / self.max_code()) * f64::from(self.hi - self.lo)) as f32 + (self.hi - self.lo).abs() * 2f32.powi(-23)
    }
}

/// Specular power stored as `log2(p)/12` in unorm N: constant relative precision over [1, 4096].
#[derive(Clone, Copy, Debug)]
pub struct Log2Unorm {
    inner: Unorm,
}

impl Codec for Log2Unorm {
    type Value = f32;
    fn name(&self) -> String {
        format!("log2-unorm-{}", self.inner.bits)
    }
    fn bits(&self) -> u32 {
        self.inner.bits
    }
    #[inline]
    fn encode(&self, v: f32) -> u64 {
        // NaN and anything below 1 (including 0, negatives, −Inf) map to power 1; +Inf to the top.
        let v = if v.is_nan() { 1.0 } else { v.clamp(1.0, MAX_SPECULAR_POWER) };
        self.inner.encode(v.log2() / LOG2_MAX_POWER)
    }
    #[inline]
    fn decode(&self, code: u64) -> f32 {
        (self.inner.decode(code) * LOG2_MAX_POWER).exp2().clamp(1.0, MAX_SPECULAR_POWER)
    }
    fn decode_ops(&self) -> u32 {
        // the unorm decode, mul by 12, exp2, clamp
        self.inner.decode_ops() + 2 + TRANSCENDENTAL_OPS
    }
    fn recipe(&self) -> Option<super::Recipe> {
        let bits = self.inner.bits;
        if bits > super::TABLE_RECIPE_BITS {
            return Some(super::Recipe::ScalarLog2 { bits });
        }
        // exp2/log2 differ between libm and GPUs: tables keep the bits exact (encode is monotonic on [1, 4096]).
        Some(super::Recipe::ScalarTable {
            bits,
            lo: 1.0,
            hi: MAX_SPECULAR_POWER,
            nan: 1.0,
            thresholds: super::code_thresholds(bits, 1.0, MAX_SPECULAR_POWER, |v| self.encode(v)),
            decoded: (0..1u64 << bits).map(|c| self.decode(c)).collect(),
        })
    }
    /// Up to [`LOG2_TABLE_BITS`] bits, a table of every code's [`Codec::decode`] (built once per bit count): the
    /// same values, without a libm `exp2f` per sample (9% of a `fat-20` roundtrip in `perf`).
    fn decode_slice_isa(&self, isa: Isa, codes: &[u64], out: &mut [f32]) {
        assert_eq!(codes.len(), out.len(), "decode_slice: {} codes into {} values", codes.len(), out.len());
        match log2_table(self) {
            Some(t) => {
                let m = mask(self.inner.bits);
                for (o, &c) in out.iter_mut().zip(codes) {
                    *o = t[(c & m) as usize];
                }
            }
            None => crate::codec::simd::run(
                isa,
                crate::codec::simd::MapKernel { input: codes, out, f: crate::codec::simd::Decode(self) },
            ),
        }
    }
}

/// Largest bit count whose [`Log2Unorm`] decodes through a table (4096 entries, 16 KiB).
pub const LOG2_TABLE_BITS: u32 = 12;

/// The decode table of `codec`'s bit count, built on first use; `None` above [`LOG2_TABLE_BITS`].
fn log2_table(codec: &Log2Unorm) -> Option<&'static [f32]> {
    static TABLES: [std::sync::OnceLock<Box<[f32]>>; LOG2_TABLE_BITS as usize + 1] =
        [const { std::sync::OnceLock::new() }; LOG2_TABLE_BITS as usize + 1];
    let bits = codec.inner.bits;
    let slot = TABLES.get(bits as usize).filter(|_| bits <= LOG2_TABLE_BITS)?;
    Some(slot.get_or_init(|| (0..1u64 << bits).map(|c| codec.decode(c)).collect()))
}

impl ScalarCodec for Log2Unorm {
    fn domain(&self) -> (f32, f32) {
        (1.0, MAX_SPECULAR_POWER)
    }
    fn error_bound(&self, v: f32) -> f32 {
        let half = 0.5 / self.inner.max_code() as f32 * LOG2_MAX_POWER;
        v * (half.exp2() - 1.0) + v * 2f32.powi(-20)
    }
}

/// IEEE half float (see the module table for clamping).
#[derive(Clone, Copy, Debug)]
pub struct ScalarF16;

impl Codec for ScalarF16 {
    type Value = f32;
    fn name(&self) -> String {
        "f16".into()
    }
    fn bits(&self) -> u32 {
        16
    }
    #[inline(always)]
    fn encode(&self, v: f32) -> u64 {
        let v = if v.is_nan() { 0.0 } else { v.clamp(-super::normal::F16_MAX, super::normal::F16_MAX) };
        u64::from(f32_to_f16_bits(v))
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> f32 {
        f16_to_finite((code & 0xffff) as u16)
    }
    fn decode_ops(&self) -> u32 {
        // and, f16_to_finite
        1 + F16_TO_FINITE_OPS
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::ScalarF16)
    }
}

impl ScalarCodec for ScalarF16 {
    fn domain(&self) -> (f32, f32) {
        (-super::normal::F16_MAX, super::normal::F16_MAX)
    }
    fn error_bound(&self, v: f32) -> f32 {
        v.abs() * 2f32.powi(-11) + 2f32.powi(-25)
    }
}

/// IEEE single float: exact for finite input; NaN → 0, ±Inf → ±f32::MAX.
#[derive(Clone, Copy, Debug)]
pub struct ScalarF32;

impl Codec for ScalarF32 {
    type Value = f32;
    fn name(&self) -> String {
        "f32".into()
    }
    fn bits(&self) -> u32 {
        32
    }
    #[inline(always)]
    fn encode(&self, v: f32) -> u64 {
        let v = if v.is_nan() { 0.0 } else { v.clamp(f32::MIN, f32::MAX) };
        u64::from(v.to_bits())
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> f32 {
        let v = f32::from_bits(code as u32);
        if v.is_nan() {
            0.0
        } else {
            v.clamp(f32::MIN, f32::MAX)
        }
    }
    fn decode_ops(&self) -> u32 {
        // from_bits is free; NaN compare, select, clamp
        3
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::ScalarF32)
    }
}

impl ScalarCodec for ScalarF32 {
    fn error_bound(&self, _v: f32) -> f32 {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_known_values() {
        let u8c = scalar_codec("unorm-8").unwrap();
        assert_eq!(u8c.name(), "unorm-8");
        assert_eq!(u8c.encode(1.0), 255);
        assert_eq!(u8c.encode(0.5), 128);
        assert_eq!(u8c.encode(f32::NAN), 0);
        assert_eq!(u8c.encode(f32::INFINITY), 255);
        assert_eq!(u8c.decode(255), 1.0);
        let lg = scalar_codec("log2-unorm-8").unwrap();
        assert_eq!(lg.decode(lg.encode(1.0)), 1.0);
        assert_eq!(lg.decode(lg.encode(4096.0)), 4096.0);
        assert_eq!(lg.decode(lg.encode(f32::NAN)), 1.0);
        let h = scalar_codec("f16").unwrap();
        assert_eq!(h.decode(h.encode(1e6)), 65504.0);
        assert_eq!(h.decode(h.encode(-1e6)), -65504.0);
        assert_eq!(h.decode(h.encode(1e-9)), 0.0);
        assert_eq!(h.decode(0x7c00), 65504.0);
        for bad in ["unorm-0", "unorm-25", "log2-unorm-1", "f64", "unorm", "unorm-x"] {
            assert!(scalar_codec(bad).is_none(), "{bad}");
        }
    }

    #[test]
    fn snorm_follows_d3d_rules_and_parses_its_range() {
        let s8 = scalar_codec("snorm-8").unwrap();
        assert_eq!(s8.name(), "snorm-8");
        assert_eq!(s8.encode(1.0), 127);
        assert_eq!(s8.encode(-1.0), 0x81);
        assert_eq!(s8.encode(-0.0), 0);
        assert_eq!(s8.encode(f32::NAN), 0);
        assert_eq!(s8.encode(f32::NEG_INFINITY), 0x81);
        assert_eq!(s8.decode(0x80), -1.0);
        assert_eq!(s8.decode(0x81), -1.0);
        assert_eq!(s8.decode(0x17f), 1.0); // bits above 8 ignored
        assert_eq!(s8.decode(s8.encode(0.5)), 64.0 / 127.0);
        let m = scalar_codec("snorm-8:32").unwrap();
        assert_eq!(m.name(), "snorm-8:32");
        assert_eq!(m.domain(), (-32.0, 32.0));
        assert_eq!(m.decode(m.encode(-32.0)), -32.0);
        assert_eq!(m.decode(m.encode(1e9)), 32.0);
        assert!((m.decode(m.encode(3.3)) - 3.3).abs() <= m.error_bound(3.3));
        let s24 = scalar_codec("snorm-24").unwrap();
        assert_eq!(s24.encode(1.0), (1 << 23) - 1);
        for bad in
            ["snorm-1", "snorm-25", "snorm-8:0", "snorm-8:-1", "snorm-8:inf", "snorm-8:nan", "snorm-:2", "snorm-8:"]
        {
            assert!(scalar_codec(bad).is_none(), "{bad}");
        }
    }

    /// The table decode equals `decode` bit for bit on every code of every tabled bit count (and on codes with
    /// bits set above the field), and the codecs above the table still decode per value.
    #[test]
    fn log2_table_decode_equals_decode_on_every_code() {
        for bits in 2..=LOG2_TABLE_BITS + 2 {
            let c = Log2Unorm { inner: Unorm::new(bits, 0.0, 1.0, "") };
            let n = 1u64 << bits.min(14);
            let codes: Vec<u64> = (0..n).chain((0..64).map(|k| (k << bits) | (k % n))).collect();
            let mut out = vec![0.0f32; codes.len()];
            for isa in Isa::available() {
                c.decode_slice_isa(isa, &codes, &mut out);
                for (&code, &v) in codes.iter().zip(&out) {
                    assert_eq!(v.to_bits(), c.decode(code).to_bits(), "log2-unorm-{bits} code {code} on {isa:?}");
                }
            }
            assert_eq!(log2_table(&c).is_some(), bits <= LOG2_TABLE_BITS);
        }
    }

    #[test]
    fn log2_is_relatively_precise_where_direct_is_not() {
        let lg = scalar_codec("log2-unorm-8").unwrap();
        let direct = scalar_codec("specpow-unorm-8").unwrap();
        let p = 4.0;
        let e_log = (lg.decode(lg.encode(p)) - p).abs();
        let e_direct = (direct.decode(direct.encode(p)) - p).abs();
        assert!(e_log < 0.1 && e_direct > 1.0, "log2 {e_log}, direct {e_direct}");
    }
}
