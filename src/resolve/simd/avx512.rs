//! AVX-512F lanes. Every method is `#[inline(always)]` and only ever inlined into functions compiled with
//! `avx512f` (the kernel's dispatch checks the CPU first), so the intrinsics inline into vector code.
use super::{Lanes, EXP2_P, LANES};
use std::arch::x86_64::*;
use std::ops::{Add, Mul, Sub};

/// `1/c` (rounded to f32) for the 32 sub-intervals `[1 + i/32, 1 + (i+1)/32)` of [1, 2) that [`Avx512::log2`]
/// indexes by bits 22..18 of the mantissa; `c` is each sub-interval's centre. Checked against f64 by a test.
pub(super) const LOG2_INV_C: [f32; 32] = [
    0.9846154, 0.95522386, 0.92753625, 0.90140843, 0.8767123, 0.85333335, 0.83116883, 0.8101266, 0.79012346, 0.7710843,
    0.7529412, 0.7356322, 0.71910113, 0.7032967, 0.68817204, 0.67368424, 0.6597938, 0.64646465, 0.63366336, 0.6213592,
    0.60952383, 0.5981308, 0.58715594, 0.5765766, 0.5663717, 0.5565217, 0.5470086, 0.53781515, 0.5289256, 0.5203252,
    0.512, 0.503937,
];
/// `−log2` of each [`LOG2_INV_C`] entry, rounded to f32.
pub(super) const LOG2_T: [f32; 32] = [
    0.02236781, 0.06608922, 0.10852443, 0.14974715, 0.18982457, 0.22881866, 0.26678655, 0.3037807, 0.33984998,
    0.3750395, 0.4093909, 0.4429435, 0.47573343, 0.5077946, 0.5391588, 0.5698556, 0.5999129, 0.6293566, 0.6582115,
    0.6865005, 0.71424544, 0.74146706, 0.76818436, 0.79441583, 0.820179, 0.8454901, 0.87036467, 0.8948177, 0.9188633,
    0.94251454, 0.9657842, 0.9886847,
];
/// `log2(1 + r)/r ≈ q0 + q1 r + q2 r²` on |r| ≤ 1/64 (the Taylor terms: absolute error of `log2` ≤ 2.2e-8).
pub(super) const LOG2_Q: [f32; 3] = [std::f32::consts::LOG2_E, -0.721_347_5, 0.480_898_35];

/// Sixteen lanes in one AVX-512 register.
#[derive(Clone, Copy, Debug)]
pub struct Avx512(__m512);

// SAFETY (all `unsafe` blocks in this module): the intrinsics need AVX-512F, and `Avx512` values are only
// created inside functions the kernel dispatch enters after `Isa::detect()` found AVX-512. Loads and
// stores check the slice length first.

impl Add for Avx512 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_add_ps(self.0, o.0)) }
    }
}
impl Sub for Avx512 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_sub_ps(self.0, o.0)) }
    }
}
impl Mul for Avx512 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_mul_ps(self.0, o.0)) }
    }
}

impl Lanes for Avx512 {
    const N: usize = LANES;
    const INTERLEAVE: usize = 4;
    type Mask = __mmask16;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_set1_ps(x)) }
    }
    #[inline(always)]
    fn load(a: &[f32]) -> Self {
        let a = &a[..LANES];
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_loadu_ps(a.as_ptr())) }
    }
    #[inline(always)]
    fn store(self, a: &mut [f32]) {
        let a = &mut a[..LANES];
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { _mm512_storeu_ps(a.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_fmadd_ps(self.0, b.0, c.0)) }
    }
    #[inline(always)]
    fn nmul_add(self, b: Self, c: Self) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_fnmadd_ps(self.0, b.0, c.0)) }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_max_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_min_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn rsqrt(self) -> Self {
        // y ≈ 1/√x to 2⁻¹⁴; one Newton step y·(1.5 − ½x·y²) brings it to about 2⁻²³.
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe {
            let y = _mm512_rsqrt14_ps(self.0);
            let hx = _mm512_mul_ps(self.0, _mm512_set1_ps(0.5));
            let yy = _mm512_mul_ps(y, y);
            let t = _mm512_fnmadd_ps(hx, yy, _mm512_set1_ps(1.5));
            Avx512(_mm512_mul_ps(y, t))
        }
    }
    #[inline(always)]
    fn rsqrt_approx(self) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_rsqrt14_ps(self.0)) }
    }
    #[inline(always)]
    fn recip(self) -> Self {
        // y ≈ 1/x to 2⁻¹⁴; Newton y + y·(1 − x·y).
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe {
            let y = _mm512_rcp14_ps(self.0);
            let e = _mm512_fnmadd_ps(self.0, y, _mm512_set1_ps(1.0));
            Avx512(_mm512_fmadd_ps(y, e, y))
        }
    }
    #[inline(always)]
    fn log2(self) -> Self {
        // x = m·2^e with m in [1, 2) (vgetmantps) and e exact (vgetexpps); m's top five mantissa bits pick one
        // of 32 sub-intervals of width 1/32 and its centre c (tables [`LOG2_INV_C`], [`LOG2_T`]):
        // log2 m = −log2(1/c) + log2(1 + r), r = m·(1/c) − 1 exact to one rounding, |r| ≤ 1/64, and
        // log2(1 + r) = r·q(r) with q of degree 2 (Horner: ten instructions in all). Just below 1 (m near 2,
        // e = −1) the sum loses to cancellation about one rounding of a value near 1: ≈ 6e-8 absolute.
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe {
            let m = _mm512_getmant_ps::<_MM_MANT_NORM_1_2, _MM_MANT_SIGN_ZERO>(self.0);
            let e = Avx512(_mm512_getexp_ps(self.0));
            // Bits 22..18 of m; vpermt2ps reads only the low five bits of each index.
            let idx = _mm512_srli_epi32::<18>(_mm512_castps_si512(m));
            let lo = |t: &[f32; 32]| _mm512_loadu_ps(t.as_ptr());
            let hi = |t: &[f32; 32]| _mm512_loadu_ps(t.as_ptr().add(16));
            let inv_c = _mm512_permutex2var_ps(lo(&LOG2_INV_C), idx, hi(&LOG2_INV_C));
            let t = _mm512_permutex2var_ps(lo(&LOG2_T), idx, hi(&LOG2_T));
            let r = Avx512(_mm512_fmsub_ps(m, inv_c, _mm512_set1_ps(1.0)));
            let c = |v: f32| Avx512::splat(v);
            let [q0, q1, q2] = LOG2_Q;
            let q = r.mul_add(r.mul_add(c(q2), c(q1)), c(q0));
            r.mul_add(q, Avx512(t)) + e
        }
    }
    #[inline(always)]
    fn exp2(self) -> Self {
        // 2^x = 2^i · 2^f, i = round(x), |f| ≤ ½, 2^f by a degree-5 minimax polynomial (Horner; relative error
        // 3e-7 in f32); vscalefps applies 2^i and underflows to 0 (not 2^−126) far below −126.
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe {
            let x = self.0;
            let i = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(x);
            let f = Avx512(_mm512_sub_ps(x, i));
            let c = |v: f32| Avx512::splat(v);
            let [c0, c1, c2, c3, c4, c5] = EXP2_P;
            let p = f.mul_add(c(c5), c(c4)).mul_add(f, c(c3)).mul_add(f, c(c2)).mul_add(f, c(c1)).mul_add(f, c(c0));
            Avx512(_mm512_scalef_ps(p.0, i))
        }
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self::Mask {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { _mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self::Mask {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
        a & b
    }
    #[inline(always)]
    fn keep(self, m: Self::Mask) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_maskz_mov_ps(m, self.0)) }
    }
    #[inline(always)]
    fn count(self, m: Self::Mask) -> Self {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { Avx512(_mm512_mask_add_ps(self.0, m, self.0, _mm512_set1_ps(1.0))) }
    }
    #[inline(always)]
    fn any(m: Self::Mask) -> bool {
        m != 0
    }
    #[inline(always)]
    fn bits(m: Self::Mask) -> u64 {
        u64::from(m)
    }
    #[inline(always)]
    fn compress_indices(m: Self::Mask, base: u32, out: &mut [u32]) -> usize {
        // One compress in a register and a whole-vector store instead of a loop over the set bits (whose trip
        // count the branch predictor cannot know). Not the compressing store to memory: AMD's Zen 4
        // microcodes it (≈ 1.8× the AVX2 path's whole tile culling, docs/RESOLVE.md); the lanes past the count
        // are written too, and the caller's next group or its truncation overwrites them.
        let out = &mut out[..LANES];
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe {
            let iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
            let idx = _mm512_add_epi32(_mm512_set1_epi32(base as i32), iota);
            _mm512_storeu_si512(out.as_mut_ptr().cast(), _mm512_maskz_compress_epi32(m, idx));
        }
        m.count_ones() as usize
    }
    #[inline(always)]
    fn hmin(self) -> f32 {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { _mm512_reduce_min_ps(self.0) }
    }
    #[inline(always)]
    fn hmax(self) -> f32 {
        // SAFETY: AVX-512F is present (only the dispatch after `Isa::detect` creates `Avx512`); slices sliced to LANES.
        unsafe { _mm512_reduce_max_ps(self.0) }
    }
}
