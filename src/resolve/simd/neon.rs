//! NEON lanes (aarch64): sixteen lanes as four `float32x4_t`. NEON is part of every aarch64 target (the
//! `neon` feature is on by default), so the kernel uses these lanes with no run-time detection and no
//! `#[target_feature]` wrapper. As on the AVX2 path, nothing in the light loop waits on the divider or the square-root
//! unit: `rsqrt` and `recip` are the hardware estimates (`frsqrte`, `frecpe`: about 2⁻⁸) refined by Newton steps,
//! `log2` looks the sub-interval centre up in the 8-entry tables with `tbl` (the AVX2 scheme), `exp2` adds `i` to
//! the exponent bits of `2^f`.

use super::{Lanes, EXP2_P, LANES, LOG2_INV_C8, LOG2_Q8, LOG2_T8};
use std::arch::aarch64::*;
use std::ops::{Add, Mul, Sub};

// SAFETY (every `unsafe` block in this module): the intrinsics need NEON, which every aarch64 target has (Rust
// still counts a call as unsafe outside a function that enables the feature by attribute). Loads and stores
// check the slice length first.

/// Sixteen lanes in four NEON registers (lanes 0–3, 4–7, 8–11, 12–15).
#[derive(Clone, Copy, Debug)]
pub struct Neon([float32x4_t; 4]);

/// The lanes' bits of a 32-entry byte table, as `tbl` reads it (two registers).
type Table8 = uint8x16x2_t;

impl Neon {
    /// `f` on each quarter.
    #[inline(always)]
    fn map(self, f: impl Fn(float32x4_t) -> float32x4_t) -> Self {
        let a = self.0;
        Neon([f(a[0]), f(a[1]), f(a[2]), f(a[3])])
    }

    /// `f` on each pair of quarters.
    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(float32x4_t, float32x4_t) -> float32x4_t) -> Self {
        let (a, b) = (self.0, o.0);
        Neon([f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])])
    }

    /// `f` on each pair of quarters, giving a mask.
    #[inline(always)]
    fn cmp(self, o: Self, f: impl Fn(float32x4_t, float32x4_t) -> uint32x4_t) -> [uint32x4_t; 4] {
        let (a, b) = (self.0, o.0);
        [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])]
    }

    /// An 8-entry f32 table as `tbl` registers.
    #[inline(always)]
    fn table8(t: &[f32; 8]) -> Table8 {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        unsafe { uint8x16x2_t(vld1q_u8(t.as_ptr().cast()), vld1q_u8(t.as_ptr().add(4).cast())) }
    }

    /// `2^x` for `x` clamped to [−126, `hi`] (`hi` ≤ 126): `x = i + f`, `i` the nearest integer, `|f| ≤ ½`, `2^f` by
    /// the minimax polynomial of the AVX-512 path (in [2^−½, 2^½]), and `i` added to its exponent bits: the
    /// result's exponent stays normal for every clamped `x` (at `i = −126`, `f ≥ 0` and `2^f ≥ 1`).
    #[inline(always)]
    fn exp2_below(self, hi: f32) -> Self {
        let [c0, c1, c2, c3, c4, c5] = EXP2_P;
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        let c = |v: f32| unsafe { vdupq_n_f32(v) };
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.map(|x| unsafe {
            let x = vminq_f32(vmaxq_f32(x, c(-126.0)), c(hi));
            let i = vrndnq_f32(x);
            let f = vsubq_f32(x, i);
            let mut p = vfmaq_f32(c(c4), f, c(c5));
            p = vfmaq_f32(c(c3), p, f);
            p = vfmaq_f32(c(c2), p, f);
            p = vfmaq_f32(c(c1), p, f);
            p = vfmaq_f32(c(c0), p, f);
            let scale = vshlq_n_s32::<23>(vcvtnq_s32_f32(x));
            vreinterpretq_f32_s32(vaddq_s32(vreinterpretq_s32_f32(p), scale))
        })
    }
}

impl Add for Neon {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.zip(o, |x, y| unsafe { vaddq_f32(x, y) })
    }
}
impl Sub for Neon {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.zip(o, |x, y| unsafe { vsubq_f32(x, y) })
    }
}
impl Mul for Neon {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.zip(o, |x, y| unsafe { vmulq_f32(x, y) })
    }
}

impl Lanes for Neon {
    const N: usize = LANES;
    /// One light per step: the four quarters are already four independent dependency chains, and the sixteen
    /// lanes of every per-sample constant take four of the 32 registers, so two or four lights per step spill more
    /// than they gain (docs/RESOLVE.md: instruction counts and llvm-mca estimates of the light loop).
    const INTERLEAVE: usize = 1;
    type Mask = [uint32x4_t; 4];
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        Neon([unsafe { vdupq_n_f32(x) }; 4])
    }
    #[inline(always)]
    fn load(a: &[f32]) -> Self {
        let a = &a[..LANES];
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        let v = unsafe { vld1q_f32_x4(a.as_ptr()) };
        Neon([v.0, v.1, v.2, v.3])
    }
    #[inline(always)]
    fn store(self, a: &mut [f32]) {
        let a = &mut a[..LANES];
        let [x, y, z, w] = self.0;
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        unsafe { vst1q_f32_x4(a.as_mut_ptr(), float32x4x4_t(x, y, z, w)) }
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        let (a, b, c) = (self.0, b.0, c.0);
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        let f = |i: usize| unsafe { vfmaq_f32(c[i], a[i], b[i]) };
        Neon([f(0), f(1), f(2), f(3)])
    }
    #[inline(always)]
    fn nmul_add(self, b: Self, c: Self) -> Self {
        let (a, b, c) = (self.0, b.0, c.0);
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        let f = |i: usize| unsafe { vfmsq_f32(c[i], a[i], b[i]) };
        Neon([f(0), f(1), f(2), f(3)])
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.zip(o, |x, y| unsafe { vmaxq_f32(x, y) })
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.zip(o, |x, y| unsafe { vminq_f32(x, y) })
    }
    #[inline(always)]
    fn rsqrt(self) -> Self {
        // y ≈ 1/√x to about 2⁻⁸ (`frsqrte`); each Newton step y·(3 − x·y²)/2 (`frsqrts` computes (3 − a·b)/2 fused)
        // squares the error: 2⁻¹⁵, then rounding only (≈ 2.5e-7 at worst, tested).
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.map(|x| unsafe {
            let mut y = vrsqrteq_f32(x);
            y = vmulq_f32(y, vrsqrtsq_f32(vmulq_f32(x, y), y));
            vmulq_f32(y, vrsqrtsq_f32(vmulq_f32(x, y), y))
        })
    }
    #[inline(always)]
    fn rsqrt_approx(self) -> Self {
        // The bare estimate is 2⁻⁸, looser than the 2⁻¹⁴ this promises: one Newton step.
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.map(|x| unsafe {
            let y = vrsqrteq_f32(x);
            vmulq_f32(y, vrsqrtsq_f32(vmulq_f32(x, y), y))
        })
    }
    #[inline(always)]
    fn recip(self) -> Self {
        // y ≈ 1/x to about 2⁻⁸ (`frecpe`); one step y·(2 − x·y) (`frecps`) to 2⁻¹⁶, then y + y·(1 − x·y) with the
        // residual fused (about 1 ulp).
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        let one = unsafe { vdupq_n_f32(1.0) };
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.map(|x| unsafe {
            let mut y = vrecpeq_f32(x);
            y = vmulq_f32(y, vrecpsq_f32(x, y));
            let e = vfmsq_f32(one, x, y);
            vfmaq_f32(y, y, e)
        })
    }
    #[inline(always)]
    fn log2(self) -> Self {
        // The AVX2 scheme: x = m·2^e, m in [1, 2) from the bits; m's top three mantissa bits pick one of 8
        // sub-intervals and its centre c (tables [`LOG2_INV_C8`], [`LOG2_T8`], one `tbl` over two registers each,
        // indexed by bytes 4i..4i+3 of lane i): log2 m = −log2(1/c) + log2(1 + r), r = m·(1/c) − 1, |r| ≤ 1/17,
        // log2(1 + r) = r·q(r) with the Taylor terms to r³ (truncation ≤ 2.0e-7 absolute).
        let [q0, q1, q2, q3] = LOG2_Q8;
        let (inv_c8, t8) = (Neon::table8(&LOG2_INV_C8), Neon::table8(&LOG2_T8));
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        let c = |v: f32| unsafe { vdupq_n_f32(v) };
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.map(|x| unsafe {
            let bits = vreinterpretq_u32_f32(x);
            let e = vcvtq_f32_s32(vsubq_s32(vreinterpretq_s32_u32(vshrq_n_u32::<23>(bits)), vdupq_n_s32(127)));
            let m = vreinterpretq_f32_u32(vbslq_u32(vdupq_n_u32(0x007f_ffff), bits, vdupq_n_u32(0x3f80_0000)));
            // 4i in every byte of lane i (i = bits 22..20), plus 0, 1, 2, 3: the byte indices of entry i.
            let i4 = vandq_u32(vshrq_n_u32::<18>(bits), vdupq_n_u32(0x1c));
            let idx = vreinterpretq_u8_u32(vmlaq_u32(vdupq_n_u32(0x0302_0100), i4, vdupq_n_u32(0x0101_0101)));
            let inv_c = vreinterpretq_f32_u8(vqtbl2q_u8(inv_c8, idx));
            let t = vreinterpretq_f32_u8(vqtbl2q_u8(t8, idx));
            let r = vfmaq_f32(c(-1.0), m, inv_c);
            let mut q = vfmaq_f32(c(q2), r, c(q3));
            q = vfmaq_f32(c(q1), q, r);
            q = vfmaq_f32(c(q0), q, r);
            vaddq_f32(vfmaq_f32(t, r, q), e)
        })
    }
    #[inline(always)]
    fn exp2(self) -> Self {
        self.exp2_below(126.0)
    }
    #[inline(always)]
    fn exp2_nonpositive(self) -> Self {
        self.exp2_below(0.0)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.cmp(o, |x, y| unsafe { vcgtq_f32(x, y) })
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self::Mask {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.cmp(o, |x, y| unsafe { vcgeq_f32(x, y) })
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self::Mask {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        self.cmp(o, |x, y| unsafe { vcleq_f32(x, y) })
    }
    #[inline(always)]
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        let f = |i: usize| unsafe { vandq_u32(a[i], b[i]) };
        [f(0), f(1), f(2), f(3)]
    }
    #[inline(always)]
    fn keep(self, m: Self::Mask) -> Self {
        let a = self.0;
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        let f = |i: usize| unsafe { vreinterpretq_f32_u32(vandq_u32(vreinterpretq_u32_f32(a[i]), m[i])) };
        Neon([f(0), f(1), f(2), f(3)])
    }
    #[inline(always)]
    fn count(self, m: Self::Mask) -> Self {
        self + Self::splat(1.0).keep(m)
    }
    #[inline(always)]
    fn any(m: Self::Mask) -> bool {
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        unsafe { vmaxvq_u32(vorrq_u32(vorrq_u32(m[0], m[1]), vorrq_u32(m[2], m[3]))) != 0 }
    }
    #[inline(always)]
    fn bits(m: Self::Mask) -> u64 {
        // The sixteen lanes narrowed to bytes (0 or 0xff, in lane order), each kept as its bit weight, and the
        // weights of each half summed.
        const W: [u8; 16] = [1, 2, 4, 8, 16, 32, 64, 128, 1, 2, 4, 8, 16, 32, 64, 128];
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        unsafe {
            let lo = vuzp1q_u16(vreinterpretq_u16_u32(m[0]), vreinterpretq_u16_u32(m[1]));
            let hi = vuzp1q_u16(vreinterpretq_u16_u32(m[2]), vreinterpretq_u16_u32(m[3]));
            let w = vandq_u8(vuzp1q_u8(vreinterpretq_u8_u16(lo), vreinterpretq_u8_u16(hi)), vld1q_u8(W.as_ptr()));
            u64::from(vaddv_u8(vget_low_u8(w))) | (u64::from(vaddv_u8(vget_high_u8(w))) << 8)
        }
    }
    #[inline(always)]
    fn hmin(self) -> f32 {
        let a = self.0;
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        unsafe { vminvq_f32(vminq_f32(vminq_f32(a[0], a[1]), vminq_f32(a[2], a[3]))) }
    }
    #[inline(always)]
    fn hmax(self) -> f32 {
        let a = self.0;
        // SAFETY: NEON is part of every aarch64 target; slices are sliced to LANES first.
        unsafe { vmaxvq_f32(vmaxq_f32(vmaxq_f32(a[0], a[1]), vmaxq_f32(a[2], a[3]))) }
    }
}
