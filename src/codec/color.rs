//! Colour codecs (linear RGB in, linear RGB out). Channel 0 (red) sits in the low bits.
//!
//! | name | bits | domain per channel | error bound per channel | source |
//! |---|---|---|---|---|
//! | `unorm8`, `unorm-N` (N = 1..=16) | 3N | [0, 1] | 0.5/(2^N−1) | D3D/Vulkan UNORM |
//! | `srgb8` | 24 | [0, 1] | 0.5/255 × the sRGB decode slope (≤ 0.0047) | IEC 61966-2-1 transfer function |
//! | `r11g11b10f` | 32 | [0, 65024] (b: 64512) | c·2^-7 + 2^-21 (b: c·2^-6 + 2^-20) | D3D `DXGI_FORMAT_R11G11B10_FLOAT`, Vulkan `B10G11R11_UFLOAT_PACK32` |
//! | `rgb9e5` | 32 | [0, 65408] | max(r,g,b)·2^-9 + 2^-25 | `EXT_texture_shared_exponent` (GL), D3D `R9G9B9E5_SHAREDEXP` |
//! | `f16` | 48 | [−65504, 65504] | |c|·2^-11 + 2^-25 | IEEE binary16 |
//! | `f32` | 96 | finite f32 | 0 | IEEE binary32 |
//!
//! Defined results: NaN channels encode as 0; ±Inf and out-of-range values clamp to the domain (the unsigned
//! floats take negatives to 0, never to NaN or Inf). Decoders return finite values for every code (Inf/NaN bit
//! patterns of the float formats decode to the largest finite value / 0).

use super::normal::{f16_to_finite, round_in_range, F16_MAX, F16_TO_FINITE_OPS};
use super::simd::{f32_to_f16_bits, run, Element, MapKernel};
use super::{mask, split_bits, Codec, ColorCodec, TRANSCENDENTAL_OPS};
use crate::base::isa::Isa;
use crate::base::lut::CodeLut;
use crate::base::picture::{srgb_decode, srgb_encode};
use glam::Vec3;
use std::sync::OnceLock;

/// Every valid name pattern (for error messages).
pub const VALID_NAMES: &[&str] = &["unorm8", "unorm-N (1..=16)", "srgb8", "r11g11b10f", "rgb9e5", "f16", "f32"];

/// Looks a colour codec up by name (see the module table).
#[must_use]
pub fn color_codec(name: &str) -> Option<Box<dyn ColorCodec>> {
    match name {
        "unorm8" => Some(Box::new(UnormRgb { bits: 8, srgb: false })),
        "srgb8" => Some(Box::new(UnormRgb { bits: 8, srgb: true })),
        "r11g11b10f" => Some(Box::new(R11G11B10F)),
        "rgb9e5" => Some(Box::new(Rgb9e5)),
        "f16" => Some(Box::new(RgbF16)),
        "f32" => Some(Box::new(RgbF32)),
        _ => match split_bits(name)? {
            ("unorm", n) if (1..=16).contains(&n) => Some(Box::new(UnormRgb { bits: n, srgb: false })),
            _ => None,
        },
    }
}

#[inline(always)]
fn clean(v: f32, lo: f32, hi: f32) -> f32 {
    if v.is_nan() {
        0.0f32.clamp(lo, hi)
    } else {
        v.clamp(lo, hi)
    }
}

/// Three unorm channels, linear or sRGB-encoded.
#[derive(Clone, Copy, Debug)]
pub struct UnormRgb {
    bits: u32,
    srgb: bool,
}

impl UnormRgb {
    /// srgb8's threshold table, looked up once per call or slice rather than per colour.
    fn encode_table(&self) -> Option<&'static CodeLut> {
        (self.srgb && self.bits == 8).then(srgb8_encode_table)
    }

    /// `lut`: [`UnormRgb::encode_table`] (only sRGB uses it).
    #[inline(always)]
    fn encode_with<const SRGB: bool>(&self, c: Vec3, lut: Option<&CodeLut>) -> u64 {
        let m = mask(self.bits) as f32;
        let q = |v: f32| {
            let v = clean(v, 0.0, 1.0);
            if let Some(lut) = lut {
                // srgb8: the formula below through its threshold table, without a `powf` (equal, tested).
                return u64::from(lut.encode_unit(v));
            }
            let v = if SRGB { srgb_encode(v) } else { v };
            // ≤ 65535: i32 lanes hold it (and vectorise).
            round_in_range(v * m) as u64
        };
        q(c.x) | (q(c.y) << self.bits) | (q(c.z) << (2 * self.bits))
    }
    #[inline(always)]
    fn decode_with<const SRGB: bool>(&self, code: u64) -> Vec3 {
        let m = mask(self.bits) as f32;
        let d = |c: u64| {
            let c = c & mask(self.bits);
            if SRGB {
                // srgb8 only: the curve of each of the 256 codes, computed once by the formula below.
                srgb8_decode_table()[c as usize & 0xff]
            } else {
                c as u32 as f32 / m
            }
        };
        Vec3::new(d(code), d(code >> self.bits), d(code >> (2 * self.bits)))
    }
}

/// srgb8's encode of one channel: `round(srgb_encode(v) · 255)`, `v` clamped to [0, 1] (NaN → 0).
fn srgb8_formula(v: f32) -> u8 {
    round_in_range(srgb_encode(clean(v, 0.0, 1.0)) * 255.0) as u8
}

/// [`srgb8_formula`] by its thresholds ([`CodeLut`]), built once per process.
fn srgb8_encode_table() -> &'static CodeLut {
    static TABLE: OnceLock<CodeLut> = OnceLock::new();
    TABLE.get_or_init(|| CodeLut::build(srgb8_formula))
}

/// `srgb_decode(c / 255)` for every 8-bit code (what the srgb8 decoder returns, bit for bit).
fn srgb8_decode_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|c| srgb_decode(c as f32 / 255.0)))
}

struct UnormRgbEnc<const SRGB: bool>(UnormRgb, Option<&'static CodeLut>);
impl<const SRGB: bool> Element<Vec3, u64> for UnormRgbEnc<SRGB> {
    #[inline(always)]
    fn apply(&self, c: &Vec3) -> u64 {
        self.0.encode_with::<SRGB>(*c, self.1)
    }
}

struct UnormRgbDec<const SRGB: bool>(UnormRgb);
impl<const SRGB: bool> Element<u64, Vec3> for UnormRgbDec<SRGB> {
    #[inline(always)]
    fn apply(&self, c: &u64) -> Vec3 {
        self.0.decode_with::<SRGB>(*c)
    }
}

impl Codec for UnormRgb {
    type Value = Vec3;
    fn name(&self) -> String {
        match (self.srgb, self.bits) {
            (true, _) => "srgb8".into(),
            (false, 8) => "unorm8".into(),
            (false, n) => format!("unorm-{n}"),
        }
    }
    fn bits(&self) -> u32 {
        3 * self.bits
    }
    #[inline(always)]
    fn encode(&self, c: Vec3) -> u64 {
        if self.srgb {
            self.encode_with::<true>(c, self.encode_table())
        } else {
            self.encode_with::<false>(c, None)
        }
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> Vec3 {
        if self.srgb {
            self.decode_with::<true>(code)
        } else {
            self.decode_with::<false>(code)
        }
    }
    fn decode_ops(&self) -> u32 {
        // two shifts split the code; per channel and, then int→float and div (linear) or and 0xff and a
        // table lookup (sRGB): 2 + 3 × 3
        11
    }
    fn recipe(&self) -> Option<super::Recipe> {
        if !self.srgb {
            return Some(super::Recipe::ColorUnorm { bits: self.bits });
        }
        let thresholds = super::code_thresholds(8, 0.0, 1.0, |v| self.encode(Vec3::splat(v)) & 0xff);
        let decoded = srgb8_decode_table().to_vec();
        Some(super::Recipe::ColorSrgb8 { thresholds, decoded })
    }
    fn encode_slice_isa(&self, isa: Isa, input: &[Vec3], out: &mut [u64]) {
        assert_eq!(input.len(), out.len(), "encode_slice: {} colours into {} codes", input.len(), out.len());
        // One loop per curve, so the linear one has no libm call in it and vectorises.
        if self.srgb {
            run(isa, MapKernel { input, out, f: UnormRgbEnc::<true>(*self, self.encode_table()) });
        } else {
            run(isa, MapKernel { input, out, f: UnormRgbEnc::<false>(*self, None) });
        }
    }
    fn decode_slice_isa(&self, isa: Isa, codes: &[u64], out: &mut [Vec3]) {
        assert_eq!(codes.len(), out.len(), "decode_slice: {} codes into {} colours", codes.len(), out.len());
        if self.srgb {
            run(isa, MapKernel { input: codes, out, f: UnormRgbDec::<true>(*self) });
        } else {
            run(isa, MapKernel { input: codes, out, f: UnormRgbDec::<false>(*self) });
        }
    }
}

impl ColorCodec for UnormRgb {
    fn domain(&self) -> (f32, f32) {
        (0.0, 1.0)
    }
    fn error_bound(&self, c: Vec3) -> Vec3 {
        let half = 0.5 / mask(self.bits) as f32;
        if !self.srgb {
            return Vec3::splat(half + 2f32.powi(-23));
        }
        // Largest slope of the sRGB decode over the half step around the encoded value (it grows with e).
        c.map(|l| {
            let e = (srgb_encode(clean(l, 0.0, 1.0)) + half).min(1.0);
            let slope = if e <= 0.040_45 { 1.0 / 12.92 } else { 2.4 / 1.055 * ((e + 0.055) / 1.055).powf(1.4) };
            slope * half + 2f32.powi(-20)
        })
    }
}

/// An unsigned small float with a 5-bit exponent (bias 15) and `m` mantissa bits, as in R11G11B10F.
#[inline]
fn encode_ufloat(v: f32, m: u32) -> u32 {
    let max = ufloat_max(m);
    if v.is_nan() || v <= 0.0 {
        return 0; // NaN, zero, negatives
    }
    let v = f64::from(v.min(max));
    // Exponent of the leading bit, floored at the denormal exponent −14.
    let e = (v.log2().floor() as i32).max(-14);
    let scale = 2f64.powi(e - m as i32);
    let mut mant = (v / scale).round() as u32;
    let mut e = e;
    if mant >= 2 << m {
        // Rounding carried into the next binade.
        mant >>= 1;
        e += 1;
    }
    if mant < 1 << m {
        debug_assert_eq!(e, -14);
        return mant; // denormal: exponent field 0
    }
    (((e + 15) as u32) << m) | (mant - (1 << m))
}

/// [`Codec::decode_ops`] of [`decode_ufloat`], both arms counted: shift, and, and (3); exponent compares (2);
/// denormal `mant·2^(−14−m)` (int→float, mul: 2); normal `(1 + mant/2^m)·2^(e−15)` (int→float, div, add, sub, powi
/// — a libm call with a variable exponent —, mul: 5 + [`TRANSCENDENTAL_OPS`]); two selects (2).
const UFLOAT_DECODE_OPS: u32 = 3 + 2 + 2 + 5 + TRANSCENDENTAL_OPS + 2;

#[inline]
fn decode_ufloat(bits: u32, m: u32) -> f32 {
    let exp = (bits >> m) & 31;
    let mant = bits & ((1 << m) - 1);
    match exp {
        0 => mant as f32 * 2f32.powi(-14 - m as i32),
        31 => ufloat_max(m), // Inf/NaN patterns: the largest finite value
        e => (1.0 + mant as f32 / (1 << m) as f32) * 2f32.powi(e as i32 - 15),
    }
}

/// Largest finite value of the small float with `m` mantissa bits.
fn ufloat_max(m: u32) -> f32 {
    (2.0 - 2f32.powi(-(m as i32))) * 2f32.powi(15)
}

/// `R11G11B10_FLOAT`: unsigned floats, 6/6/5 mantissa bits, shared nothing.
#[derive(Clone, Copy, Debug)]
pub struct R11G11B10F;

impl Codec for R11G11B10F {
    type Value = Vec3;
    fn name(&self) -> String {
        "r11g11b10f".into()
    }
    fn bits(&self) -> u32 {
        32
    }
    #[inline(always)]
    fn encode(&self, c: Vec3) -> u64 {
        let r = encode_ufloat(c.x, 6);
        let g = encode_ufloat(c.y, 6);
        let b = encode_ufloat(c.z, 5);
        u64::from(r | (g << 11) | (b << 22))
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> Vec3 {
        let code = code as u32;
        Vec3::new(decode_ufloat(code & 0x7ff, 6), decode_ufloat((code >> 11) & 0x7ff, 6), decode_ufloat(code >> 22, 5))
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::ColorR11G11B10F)
    }
    fn decode_ops(&self) -> u32 {
        // and, shift + and, shift split the code; decode_ufloat per channel
        4 + 3 * UFLOAT_DECODE_OPS
    }
}

impl ColorCodec for R11G11B10F {
    fn domain(&self) -> (f32, f32) {
        (0.0, ufloat_max(6))
    }
    fn error_bound(&self, c: Vec3) -> Vec3 {
        // Relative half-ulp for normals, half the denormal step 2^(−14−m) near zero.
        let b = |v: f32, m: i32| clean(v, 0.0, ufloat_max(m as u32)) * 2f32.powi(-m - 1) + 2f32.powi(-15 - m);
        Vec3::new(b(c.x, 6), b(c.y, 6), b(c.z, 5))
    }
}

/// `RGB9E5`: three 9-bit mantissas sharing a 5-bit exponent (bias 15), no implicit leading one.
#[derive(Clone, Copy, Debug)]
pub struct Rgb9e5;

/// Largest RGB9E5 channel value: (511/512)·2^16.
pub const RGB9E5_MAX: f32 = 65408.0;

impl Codec for Rgb9e5 {
    type Value = Vec3;
    fn name(&self) -> String {
        "rgb9e5".into()
    }
    fn bits(&self) -> u32 {
        32
    }
    #[inline(always)]
    fn encode(&self, c: Vec3) -> u64 {
        // EXT_texture_shared_exponent, section "RGB9E5", with round-to-nearest mantissas.
        let c = c.map(|v| clean(v, 0.0, RGB9E5_MAX));
        let maxc = c.max_element();
        if maxc < 2f32.powi(-25) {
            return 0;
        }
        let mut exp = (f64::from(maxc).log2().floor() as i32).max(-16) + 1 + 15;
        let mut denom = 2f64.powi(exp - 15 - 9);
        if (f64::from(maxc) / denom).round() as u32 == 512 {
            exp += 1;
            denom *= 2.0;
        }
        let q = |v: f32| ((f64::from(v) / denom).round() as u32).min(511);
        u64::from(q(c.x) | (q(c.y) << 9) | (q(c.z) << 18) | ((exp as u32) << 27))
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> Vec3 {
        let code = code as u32;
        let scale = 2f32.powi((code >> 27) as i32 - 15 - 9);
        Vec3::new((code & 511) as f32, ((code >> 9) & 511) as f32, ((code >> 18) & 511) as f32) * scale
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::ColorRgb9e5)
    }
    fn decode_ops(&self) -> u32 {
        // shift, sub for the exponent; 2^e through powi (a libm call); and, 2 × (shift + and) for
        // the mantissas; 3 int→float; 3 mul
        2 + TRANSCENDENTAL_OPS + 5 + 3 + 3
    }
}

impl ColorCodec for Rgb9e5 {
    fn domain(&self) -> (f32, f32) {
        (0.0, RGB9E5_MAX)
    }
    fn error_bound(&self, c: Vec3) -> Vec3 {
        let maxc = c.map(|v| clean(v, 0.0, RGB9E5_MAX)).max_element();
        Vec3::splat(maxc * 2f32.powi(-9) + 2f32.powi(-25))
    }
}

/// Three half floats.
#[derive(Clone, Copy, Debug)]
pub struct RgbF16;

impl Codec for RgbF16 {
    type Value = Vec3;
    fn name(&self) -> String {
        "f16".into()
    }
    fn bits(&self) -> u32 {
        48
    }
    #[inline(always)]
    fn encode(&self, c: Vec3) -> u64 {
        let h = |v: f32| u64::from(f32_to_f16_bits(clean(v, -F16_MAX, F16_MAX)));
        h(c.x) | (h(c.y) << 16) | (h(c.z) << 32)
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> Vec3 {
        let d = |c: u64| f16_to_finite((c & 0xffff) as u16);
        Vec3::new(d(code), d(code >> 16), d(code >> 32))
    }
    fn decode_ops(&self) -> u32 {
        // two shifts; per channel and, f16_to_finite
        2 + 3 * (1 + F16_TO_FINITE_OPS)
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::ColorF16)
    }
}

impl ColorCodec for RgbF16 {
    fn domain(&self) -> (f32, f32) {
        (-F16_MAX, F16_MAX)
    }
    fn error_bound(&self, c: Vec3) -> Vec3 {
        c.abs() * 2f32.powi(-11) + 2f32.powi(-25)
    }
}

/// Three single floats (96 bits): exact for finite input. The 96-bit code only fits the wide methods
/// ([`ColorCodec::encode_wide`]); the narrow `encode` keeps red and green and `decode` reads blue as 0.
#[derive(Clone, Copy, Debug)]
pub struct RgbF32;

impl Codec for RgbF32 {
    type Value = Vec3;
    fn name(&self) -> String {
        "f32".into()
    }
    fn bits(&self) -> u32 {
        96
    }
    #[inline(always)]
    fn encode(&self, c: Vec3) -> u64 {
        self.encode_wide(c) as u64
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> Vec3 {
        self.decode_wide(u128::from(code))
    }
    fn decode_ops(&self) -> u32 {
        // two shifts (from_bits is free); per channel NaN compare, select, clamp
        2 + 3 * 3
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::ColorF32)
    }
}

impl ColorCodec for RgbF32 {
    fn encode_wide(&self, c: Vec3) -> u128 {
        let f = |v: f32| u128::from(clean(v, f32::MIN, f32::MAX).to_bits());
        f(c.x) | (f(c.y) << 32) | (f(c.z) << 64)
    }
    fn decode_wide(&self, code: u128) -> Vec3 {
        let f = |c: u128| clean(f32::from_bits(c as u32), f32::MIN, f32::MAX);
        Vec3::new(f(code), f(code >> 32), f(code >> 64))
    }
    fn error_bound(&self, _c: Vec3) -> Vec3 {
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_bit_patterns() {
        // 1.0 in the 11-bit float: exponent 15, mantissa 0.
        assert_eq!(encode_ufloat(1.0, 6), 15 << 6);
        assert_eq!(decode_ufloat(15 << 6, 6), 1.0);
        assert_eq!(ufloat_max(6), 65024.0);
        assert_eq!(ufloat_max(5), 64512.0);
        assert_eq!(decode_ufloat(1, 6), 2f32.powi(-20)); // smallest denormal
        assert_eq!(encode_ufloat(-1.0, 6), 0);
        assert_eq!(encode_ufloat(f32::NAN, 6), 0);
        assert_eq!(encode_ufloat(f32::INFINITY, 6), (30 << 6) | 63);
        let c = Rgb9e5;
        assert_eq!(c.decode(c.encode(Vec3::new(1.0, 0.5, 0.25))), Vec3::new(1.0, 0.5, 0.25));
        assert_eq!(c.decode(c.encode(Vec3::splat(1e9))), Vec3::splat(RGB9E5_MAX));
        assert_eq!(c.decode(c.encode(Vec3::splat(f32::NAN))), Vec3::ZERO);
        assert!((srgb_decode(srgb_encode(0.2)) - 0.2).abs() < 1e-6);
        assert_eq!(color_codec("srgb8").unwrap().encode(Vec3::ONE), 0xff_ffff);
    }

    #[test]
    fn srgb8_table_equals_the_formula() {
        let lut = srgb8_encode_table();
        // Every threshold and 64 bit patterns either side, every 97th bit pattern of [0, 1] (about 11 M values),
        // the ends and out-of-range input.
        let diff = lut.first_difference(|x| lut.encode_unit(clean(x, 0.0, 1.0)), srgb8_formula, 64, 97);
        assert_eq!(diff, None, "the table and the formula differ at {diff:?}");
        // The codec, through its slice path on this CPU, gives the formula's code for each channel.
        let codec = color_codec("srgb8").unwrap();
        let xs: Vec<f32> = (0..=1.0f32.to_bits()).step_by(9973).map(f32::from_bits).collect();
        let values: Vec<Vec3> = xs.chunks(3).filter(|c| c.len() == 3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        let mut codes = vec![0u64; values.len()];
        codec.encode_slice(&values, &mut codes);
        for (v, code) in values.iter().zip(&codes) {
            let want = u64::from(srgb8_formula(v.x))
                | u64::from(srgb8_formula(v.y)) << 8
                | u64::from(srgb8_formula(v.z)) << 16;
            assert_eq!(*code, want, "{v}");
        }
    }
}
