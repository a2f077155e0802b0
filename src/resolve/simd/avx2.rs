//! AVX2 + FMA lanes: sixteen lanes as two `__m256`. Every method is `#[inline(always)]` and only ever inlined
//! into functions compiled with `avx2,fma` (the dispatch checks the CPU first). What the portable lanes compute
//! with a divider and a square root unit (exact `1/√x`, `log2`'s `(m − 1)/(m + 1)`) is done here with the
//! hardware estimates (`vrsqrtps`, `vrcpps`, 2⁻¹² relative) and one Newton step, and `exp2` applies `2^i` by
//! adding to the exponent bits, so the light loop never waits on the divider.
use super::{Lanes, EXP2_P, LANES, LOG2_INV_C8, LOG2_Q8, LOG2_T8};
use std::arch::x86_64::*;
use std::ops::{Add, Mul, Sub};

/// Sixteen lanes in two AVX registers (lanes 0–7, 8–15).
#[derive(Clone, Copy, Debug)]
pub struct Avx2(__m256, __m256);

// SAFETY (all `unsafe` blocks in this module): the intrinsics need AVX2 and FMA, and `Avx2` values are only
// created inside functions the dispatch enters after `Isa::detect()` found them. Loads and stores check the
// slice length first.

/// The expression on both halves, written out twice: not a closure, whose body would be compiled without the
/// caller's `avx2` feature and call every intrinsic out of line (Blinn-Phong measured 30 ns per pair so).
macro_rules! both {
    ($a:expr, |$x:ident| $e:expr) => {{
        let a = $a;
        #[allow(unused_unsafe)]
        let lo = {
            let $x = a.0;
            // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
            unsafe { $e }
        };
        #[allow(unused_unsafe)]
        let hi = {
            let $x = a.1;
            // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
            unsafe { $e }
        };
        Avx2(lo, hi)
    }};
    ($a:expr, $b:expr, |$x:ident, $y:ident| $e:expr) => {{
        let (a, b) = ($a, $b);
        #[allow(unused_unsafe)]
        let lo = {
            let ($x, $y) = (a.0, b.0);
            // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
            unsafe { $e }
        };
        #[allow(unused_unsafe)]
        let hi = {
            let ($x, $y) = (a.1, b.1);
            // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
            unsafe { $e }
        };
        Avx2(lo, hi)
    }};
}

impl Add for Avx2 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        both!(self, o, |x, y| _mm256_add_ps(x, y))
    }
}
impl Sub for Avx2 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        both!(self, o, |x, y| _mm256_sub_ps(x, y))
    }
}
impl Mul for Avx2 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        both!(self, o, |x, y| _mm256_mul_ps(x, y))
    }
}

impl Avx2 {
    /// The lanes' bits as integers, each half.
    #[inline(always)]
    fn int(x: __m256) -> __m256i {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { _mm256_castps_si256(x) }
    }
    /// `2^x` for `x` clamped to [−126, `hi`]: `x = i + f`, `i` the nearest integer, `|f| ≤ ½`, `2^f` by the
    /// minimax polynomial of the AVX-512 path, `2^i` built in the exponent bits (normal for every clamped `i`).
    #[inline(always)]
    fn exp2_below(self, hi: f32) -> Self {
        let [c0, c1, c2, c3, c4, c5] = EXP2_P;
        both!(self, |x| {
            let x = _mm256_min_ps(_mm256_max_ps(x, _mm256_set1_ps(-126.0)), _mm256_set1_ps(hi));
            let i = _mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(x);
            let f = _mm256_sub_ps(x, i);
            let c = _mm256_set1_ps;
            let mut p = _mm256_fmadd_ps(f, c(c5), c(c4));
            p = _mm256_fmadd_ps(p, f, c(c3));
            p = _mm256_fmadd_ps(p, f, c(c2));
            p = _mm256_fmadd_ps(p, f, c(c1));
            p = _mm256_fmadd_ps(p, f, c(c0));
            let scale = _mm256_slli_epi32::<23>(_mm256_add_epi32(_mm256_cvtps_epi32(i), _mm256_set1_epi32(127)));
            _mm256_mul_ps(p, _mm256_castsi256_ps(scale))
        })
    }
}

impl Lanes for Avx2 {
    const N: usize = LANES;
    const INTERLEAVE: usize = 4;
    const INTERLEAVE_GGX: usize = 1;
    type Mask = (__m256, __m256);
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { Avx2(_mm256_set1_ps(x), _mm256_set1_ps(x)) }
    }
    #[inline(always)]
    fn load(a: &[f32]) -> Self {
        let a = &a[..LANES];
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { Avx2(_mm256_loadu_ps(a.as_ptr()), _mm256_loadu_ps(a.as_ptr().add(8))) }
    }
    #[inline(always)]
    fn store(self, a: &mut [f32]) {
        let a = &mut a[..LANES];
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe {
            _mm256_storeu_ps(a.as_mut_ptr(), self.0);
            _mm256_storeu_ps(a.as_mut_ptr().add(8), self.1);
        }
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { Avx2(_mm256_fmadd_ps(self.0, b.0, c.0), _mm256_fmadd_ps(self.1, b.1, c.1)) }
    }
    #[inline(always)]
    fn nmul_add(self, b: Self, c: Self) -> Self {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { Avx2(_mm256_fnmadd_ps(self.0, b.0, c.0), _mm256_fnmadd_ps(self.1, b.1, c.1)) }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        both!(self, o, |x, y| _mm256_max_ps(x, y))
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        both!(self, o, |x, y| _mm256_min_ps(x, y))
    }
    #[inline(always)]
    fn rsqrt(self) -> Self {
        // y ≈ 1/√x to 1.5·2⁻¹²; one Newton step y·(1.5 − ½x·y²) brings it to about 2⁻²².
        both!(self, |x| {
            let y = _mm256_rsqrt_ps(x);
            let hx = _mm256_mul_ps(x, _mm256_set1_ps(0.5));
            let t = _mm256_fnmadd_ps(hx, _mm256_mul_ps(y, y), _mm256_set1_ps(1.5));
            _mm256_mul_ps(y, t)
        })
    }
    #[inline(always)]
    fn rsqrt_approx(self) -> Self {
        // The bare estimate is 2⁻¹², looser than the 2⁻¹⁴ this promises: refine it.
        self.rsqrt()
    }
    #[inline(always)]
    fn rsqrt_estimate(self) -> Self {
        both!(self, |x| _mm256_rsqrt_ps(x))
    }
    #[inline(always)]
    fn recip(self) -> Self {
        // y ≈ 1/x to 1.5·2⁻¹²; Newton y + y·(1 − x·y).
        both!(self, |x| {
            let y = _mm256_rcp_ps(x);
            let e = _mm256_fnmadd_ps(x, y, _mm256_set1_ps(1.0));
            _mm256_fmadd_ps(y, e, y)
        })
    }
    #[inline(always)]
    fn log2(self) -> Self {
        // x = m·2^e, m in [1, 2) from the bits; m's top three mantissa bits pick one of 8 sub-intervals of
        // width 1/8 and its centre c (tables [`LOG2_INV_C8`], [`LOG2_T8`], one `vpermps` each):
        // log2 m = −log2(1/c) + log2(1 + r), r = m·(1/c) − 1, |r| ≤ 1/17, log2(1 + r) = r·q(r), q the Taylor
        // terms to r³ (truncation ≤ 2.0e-7 absolute) — the AVX-512 path's scheme with an 8-entry table.
        let [q0, q1, q2, q3] = LOG2_Q8;
        both!(self, |x| {
            let bits = Avx2::int(x);
            let e = _mm256_cvtepi32_ps(_mm256_sub_epi32(_mm256_srli_epi32::<23>(bits), _mm256_set1_epi32(127)));
            let m = _mm256_castsi256_ps(_mm256_or_si256(
                _mm256_and_si256(bits, _mm256_set1_epi32(0x007f_ffff)),
                _mm256_set1_epi32(0x3f80_0000),
            ));
            // vpermps reads the low three bits of each index: bits 22..20 of m.
            let idx = _mm256_srli_epi32::<20>(bits);
            let inv_c = _mm256_permutevar8x32_ps(_mm256_loadu_ps(LOG2_INV_C8.as_ptr()), idx);
            let t = _mm256_permutevar8x32_ps(_mm256_loadu_ps(LOG2_T8.as_ptr()), idx);
            let r = _mm256_fmsub_ps(m, inv_c, _mm256_set1_ps(1.0));
            let c = _mm256_set1_ps;
            let mut q = _mm256_fmadd_ps(r, c(q3), c(q2));
            q = _mm256_fmadd_ps(q, r, c(q1));
            q = _mm256_fmadd_ps(q, r, c(q0));
            _mm256_add_ps(_mm256_fmadd_ps(r, q, t), e)
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
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { (_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0), _mm256_cmp_ps::<_CMP_GT_OQ>(self.1, o.1)) }
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self::Mask {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { (_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0), _mm256_cmp_ps::<_CMP_GE_OQ>(self.1, o.1)) }
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self::Mask {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { (_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0), _mm256_cmp_ps::<_CMP_LE_OQ>(self.1, o.1)) }
    }
    #[inline(always)]
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { (_mm256_and_ps(a.0, b.0), _mm256_and_ps(a.1, b.1)) }
    }
    #[inline(always)]
    fn keep(self, m: Self::Mask) -> Self {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { Avx2(_mm256_and_ps(self.0, m.0), _mm256_and_ps(self.1, m.1)) }
    }
    #[inline(always)]
    fn count(self, m: Self::Mask) -> Self {
        let one = Self::splat(1.0);
        self + one.keep(m)
    }
    #[inline(always)]
    fn any(m: Self::Mask) -> bool {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { _mm256_movemask_ps(_mm256_or_ps(m.0, m.1)) != 0 }
    }
    #[inline(always)]
    fn bits(m: Self::Mask) -> u64 {
        // SAFETY: AVX2 and FMA are present (only the dispatch after `Isa::detect` creates `Avx2`); slices sliced to LANES.
        unsafe { (_mm256_movemask_ps(m.0) as u64) | ((_mm256_movemask_ps(m.1) as u64) << 8) }
    }
    #[inline(always)]
    fn hmin(self) -> f32 {
        let mut a = [0.0f32; LANES];
        self.min(Avx2(self.1, self.0)).store(&mut a);
        a[..8].iter().fold(f32::INFINITY, |m, &x| m.min(x))
    }
    #[inline(always)]
    fn hmax(self) -> f32 {
        let mut a = [0.0f32; LANES];
        self.max(Avx2(self.1, self.0)).store(&mut a);
        a[..8].iter().fold(f32::NEG_INFINITY, |m, &x| m.max(x))
    }
}
