//! Batch (slice) machinery shared by the codecs: runtime instruction-set dispatch, a branch-free f32 ↔ f16
//! conversion, and rayon-parallel slices.
//!
//! Every cheap codec writes its per-element work once, as an `#[inline(always)]` branch-free body that the
//! scalar `encode`/`decode` call too. The slice paths run that body in a plain loop (which LLVM auto-vectorises)
//! compiled three times: at the x86-64 baseline, inside an `avx2,fma` `#[target_feature]` wrapper, and inside an
//! AVX-512 one. [`crate::base::isa::Isa::detect`] picks the widest the CPU has at run time. No path uses fused multiply-add or any
//! other contraction (Rust never contracts `a*b + c`), so every path computes the same IEEE operations in the
//! same order and the results are bit-identical to the scalar path — `tests/codec_slices.rs` checks it for every
//! codec × bit count × instruction set on adversarial and random input.
//!
//! [`par_encode`] and [`par_decode`] split large slices into chunks of [`PAR_CHUNK`] over the rayon pool; each
//! chunk runs the codec's single-threaded slice path.

use super::Codec;
use rayon::prelude::*;

pub use crate::base::isa::{run, Kernel};

/// A per-element function for [`MapKernel`]: implemented by small wrappers around a codec reference whose
/// `apply` is `#[inline(always)]`, so the codec's per-element body is compiled into the `#[target_feature]`
/// wrapper (a closure would stay an out-of-line call there).
pub trait Element<A, B> {
    /// The function.
    fn apply(&self, a: &A) -> B;
}

/// The default slice body: `out[i] = f.apply(&input[i])`, run under [`run`] (it saves the per-element virtual
/// call and compiles the codec's body for the wider instruction set; it vectorises when that body is
/// branch-free).
pub struct MapKernel<'a, A, B, F> {
    /// Input elements.
    pub input: &'a [A],
    /// Output elements (same length).
    pub out: &'a mut [B],
    /// The per-element function.
    pub f: F,
}

impl<A, B, F: Element<A, B>> Kernel for MapKernel<'_, A, B, F> {
    type Output = ();
    #[inline(always)]
    fn run(self, _: crate::base::isa::Isa) {
        for (o, i) in self.out.iter_mut().zip(self.input) {
            *o = self.f.apply(i);
        }
    }
}

/// [`Codec::encode`] as an [`Element`].
pub struct Encode<'c, C: ?Sized>(pub &'c C);

impl<C: Codec + ?Sized> Element<C::Value, u64> for Encode<'_, C> {
    #[inline(always)]
    fn apply(&self, v: &C::Value) -> u64 {
        self.0.encode(*v)
    }
}

/// [`Codec::decode`] as an [`Element`].
pub struct Decode<'c, C: ?Sized>(pub &'c C);

impl<C: Codec + ?Sized> Element<u64, C::Value> for Decode<'_, C> {
    #[inline(always)]
    fn apply(&self, c: &u64) -> C::Value {
        self.0.decode(*c)
    }
}

/// A per-element function with a second body for a whole block of [`BLOCK`] elements (which copies the block into
/// structure-of-arrays form so the arithmetic runs on unit-stride lanes); run by [`BlockKernel`].
pub trait BlockElement<A, B> {
    /// One element (the remainder after the last whole block).
    fn apply(&self, a: &A) -> B;
    /// `out[j] = self.apply(&input[j])` for the `BLOCK` elements of one block, bit-identically.
    fn apply_block(&self, input: &[A], out: &mut [B]);
}

/// The blocked slice body over a [`MapKernel`]'s slices: whole blocks of [`BLOCK`] through
/// [`BlockElement::apply_block`], the remainder element by element. Run under [`run`].
pub struct BlockKernel<'a, A, B, F>(pub MapKernel<'a, A, B, F>);

impl<A, B, F: BlockElement<A, B>> Kernel for BlockKernel<'_, A, B, F> {
    type Output = ();
    #[inline(always)]
    fn run(self, _: crate::base::isa::Isa) {
        let MapKernel { input, out, f } = self.0;
        let mut ins = input.chunks_exact(BLOCK);
        let mut outs = out.chunks_exact_mut(BLOCK);
        for (i, o) in (&mut ins).zip(&mut outs) {
            f.apply_block(i, o);
        }
        for (i, o) in ins.remainder().iter().zip(outs.into_remainder()) {
            *o = f.apply(i);
        }
    }
}

/// Elements per block of the blocked kernels: input is copied into stack arrays of this many lanes (SoA) so the
/// arithmetic loop has unit-stride operands; a multiple of every vector width.
pub const BLOCK: usize = 64;

/// Elements per rayon work item of the `par_*` functions (and the smallest slice they split).
pub const PAR_CHUNK: usize = 1 << 14;

/// f32 → IEEE binary16 bits, round to nearest even, branch-free. Equal to `half::f16::from_f32(v).to_bits()` for
/// every input except NaN, whose payload may differ (callers replace NaN first); tested exhaustively.
#[inline(always)]
#[must_use]
pub fn f32_to_f16_bits(v: f32) -> u16 {
    // Fabian Giesen's float_to_half_fast3_rtne (public domain), with the branches turned into selects.
    const F32_INFTY: u32 = 255 << 23;
    const F16_MAX_AS_F32: u32 = (127 + 16) << 23;
    const DENORM_MAGIC: u32 = ((127 - 15) + (23 - 10) + 1) << 23;
    let bits = v.to_bits();
    let sign = bits & 0x8000_0000;
    let x = bits ^ sign;
    // Overflow to Inf, NaN to a quiet NaN.
    let big = if x > F32_INFTY { 0x7e00 } else { 0x7c00 };
    // Subnormal results: let the FPU round by adding a magic number whose ulp is the f16 subnormal step.
    let sub = (f32::from_bits(x) + f32::from_bits(DENORM_MAGIC)).to_bits().wrapping_sub(DENORM_MAGIC);
    // Normal results: rebias, round to nearest even by adding 0xfff plus the lowest kept mantissa bit.
    let odd = (x >> 13) & 1;
    let norm = x.wrapping_add(((15u32.wrapping_sub(127)) << 23).wrapping_add(0xfff)).wrapping_add(odd) >> 13;
    let o = if x >= F16_MAX_AS_F32 {
        big
    } else if x < (113 << 23) {
        sub
    } else {
        norm
    };
    (o | (sign >> 16)) as u16
}

/// IEEE binary16 bits → f32 (exact), branch-free; equal to `half::f16::from_bits(h).to_f32()` (NaN payloads
/// aside). Tested on all 65,536 codes.
#[inline(always)]
#[must_use]
pub fn f16_bits_to_f32(h: u16) -> f32 {
    // Giesen's half_to_float, branch-free.
    const SHIFTED_EXP: u32 = 0x7c00 << 13;
    let h = u32::from(h);
    let o = (h & 0x7fff) << 13;
    let exp = SHIFTED_EXP & o;
    let o = o + ((127 - 15) << 23);
    let inf_nan = o + ((128 - 16) << 23);
    let sub = (f32::from_bits(o + (1 << 23)) - f32::from_bits(113 << 23)).to_bits();
    let o = if exp == SHIFTED_EXP {
        inf_nan
    } else if exp == 0 {
        sub
    } else {
        o
    };
    f32::from_bits(o | ((h & 0x8000) << 16))
}

fn par_zip<A: Sync, B: Send>(input: &[A], out: &mut [B], f: impl Fn(&[A], &mut [B]) + Sync + Send) {
    assert_eq!(input.len(), out.len(), "slice lengths differ");
    if input.len() <= PAR_CHUNK {
        f(input, out);
        return;
    }
    input.par_chunks(PAR_CHUNK).zip(out.par_chunks_mut(PAR_CHUNK)).for_each(|(i, o)| f(i, o));
}

/// [`Codec::encode_slice`] over the rayon pool (chunks of [`PAR_CHUNK`]), for any codec (`&dyn NormalCodec`,
/// `&dyn ScalarCodec`, …). Panics if the lengths differ.
pub fn par_encode<C: Codec + ?Sized>(codec: &C, input: &[C::Value], out: &mut [u64]) {
    par_zip(input, out, |i, o| codec.encode_slice(i, o));
}

/// [`Codec::decode_slice`] over the rayon pool. Panics if the lengths differ.
pub fn par_decode<C: Codec + ?Sized>(codec: &C, codes: &[u64], out: &mut [C::Value]) {
    par_zip(codes, out, |i, o| codec.decode_slice(i, o));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::isa::Isa;

    #[test]
    fn f16_decode_matches_half_on_every_code() {
        for h in 0..=u16::MAX {
            let want = half::f16::from_bits(h).to_f32();
            let got = f16_bits_to_f32(h);
            if want.is_nan() {
                assert!(got.is_nan(), "{h:#06x}");
            } else {
                assert_eq!(got.to_bits(), want.to_bits(), "{h:#06x}");
            }
        }
    }

    /// Every 3721st f32 bit pattern (1.15 million, all exponents and both signs) plus the neighbourhoods of
    /// every f16 rounding boundary; the exhaustive sweep is `f16_encode_matches_half_exhaustively`.
    #[test]
    fn f16_encode_matches_half_on_a_dense_sweep() {
        let check = |b: u32| {
            let v = f32::from_bits(b);
            let want = half::f16::from_f32(v).to_bits();
            let got = f32_to_f16_bits(v);
            if v.is_nan() {
                assert_eq!(got & 0x7c00, 0x7c00, "{b:#010x}");
                assert_ne!(got & 0x3ff, 0, "{b:#010x}");
            } else {
                assert_eq!(got, want, "{b:#010x} = {v:e}");
            }
        };
        let mut b = 0u32;
        while let Some(next) = b.checked_add(61 * 61) {
            check(b);
            b = next;
        }
        for h in 0..0x7c00u32 {
            // Midpoints between consecutive halves and their f32 neighbours.
            let lo = f64::from(half::f16::from_bits(h as u16).to_f32());
            let hi = f64::from(half::f16::from_bits(h as u16 + 1).to_f32());
            let mid = ((lo + hi) / 2.0) as f32;
            for d in [-2i32, -1, 0, 1, 2] {
                let m = mid.to_bits().wrapping_add_signed(d);
                check(m);
                check(m | 0x8000_0000);
            }
        }
    }

    #[test]
    #[ignore = "4 billion conversions; run with --release -- --ignored"]
    fn f16_encode_matches_half_exhaustively() {
        (0..=u32::MAX).into_par_iter().for_each(|b| {
            let v = f32::from_bits(b);
            if !v.is_nan() {
                assert_eq!(f32_to_f16_bits(v), half::f16::from_f32(v).to_bits(), "{b:#010x}");
            }
        });
    }

    #[test]
    fn detected_isa_is_available_and_run_clamps() {
        let av = Isa::available();
        assert_eq!(av[0], Isa::Baseline);
        assert_eq!(*av.last().unwrap(), Isa::detect());
        struct Add<'a>(&'a mut [u32]);
        impl Kernel for Add<'_> {
            type Output = ();
            #[inline(always)]
            fn run(self, _: Isa) {
                for v in self.0.iter_mut() {
                    *v += 1;
                }
            }
        }
        let mut v = vec![0u32; 100];
        for isa in Isa::ALL {
            run(isa, Add(&mut v));
        }
        assert!(v.iter().all(|x| *x == 3));
    }
}
