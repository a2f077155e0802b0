//! Sixteen-lane f32 vectors for the shading kernel, one type per instruction set, so the kernel is written once
//! (generic over [`Lanes`]) and compiled three times:
//!
//! - [`Avx512`]: one `__m512`; `rsqrt` is `vrsqrt14ps` plus a Newton step, `log2` uses `vgetexpps`/`vgetmantps`,
//!   `exp2` uses `vscalefps` — no divider, no square root unit in the light loop;
//! - [`Portable`]`<true>`: sixteen `f32`s in an array, lane loops the compiler turns into AVX2 + FMA code (the
//!   kernel copy compiled with those features);
//! - [`Portable`]`<false>`: the same without FMA, for any other CPU.
//!
//! Accuracy (tests below, against f64): `rsqrt` within [`RSQRT_MAX_REL_ERROR`]; `log2` and `exp2` within the
//! bounds of `fastmath.rs` on every path. Results differ between paths by rounding only (fused vs separate
//! multiply-add, refined vs exact reciprocal square root); within one run the same path shades every tile, so
//! images do not depend on culling, tile size or thread count.

use super::fastmath;
use std::ops::{Add, Mul, Sub};

/// Lanes per machine vector of the base types ([`Portable`], [`Avx512`]).
pub const LANES: usize = 16;
/// Work lists are padded to a multiple of this many items (the kernel's step).
pub const BLOCK: usize = LANES;

/// Relative error bound of [`Lanes::rsqrt`] on normal positive inputs (the refined `vrsqrt14ps` path; the portable
/// path is `1/√x`, within 2 ulp).
pub const RSQRT_MAX_REL_ERROR: f32 = 4e-7;

/// A vector of [`LANES`] f32 lanes with the operations the shading kernel needs.
pub trait Lanes: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {
    /// Number of lanes.
    const N: usize;
    /// Lane mask (the result of a comparison).
    type Mask: Copy;
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// Lanes `a[0..N]` (panics if `a` is shorter).
    fn load(a: &[f32]) -> Self;
    /// Writes the lanes to `a[0..N]` (panics if `a` is shorter).
    fn store(self, a: &mut [f32]);
    /// `self · b + c` (fused where the CPU has FMA).
    fn mul_add(self, b: Self, c: Self) -> Self;
    /// Lane-wise maximum (`max(NaN, x) = x` is not relied on: inputs are finite).
    fn max(self, o: Self) -> Self;
    /// Lane-wise minimum.
    fn min(self, o: Self) -> Self;
    /// `1/√self` for positive finite lanes.
    fn rsqrt(self) -> Self;
    /// `1/self` for positive finite lanes, accurate to about 1 ulp.
    fn recip(self) -> Self;
    /// `log2` of positive normal lanes (error bound of [`fastmath::log2`]).
    fn log2(self) -> Self;
    /// `2^self`, clamped to [−126, 126] (error bound of [`fastmath::exp2`]).
    fn exp2(self) -> Self;
    /// Lanes where `self > o`.
    fn gt(self, o: Self) -> Self::Mask;
    /// Lanes where `self >= o`.
    fn ge(self, o: Self) -> Self::Mask;
    /// Lanes where `self <= o`.
    fn le(self, o: Self) -> Self::Mask;
    /// Lanes where both masks are set.
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `self` where `m`, else 0.
    fn keep(self, m: Self::Mask) -> Self;
    /// `self + 1` where `m`, else `self` (counters kept in f32: exact below 2²⁴).
    fn count(self, m: Self::Mask) -> Self;
    /// True when some lane of `m` is set.
    fn any(m: Self::Mask) -> bool;
    /// Smallest lane.
    fn hmin(self) -> f32;
    /// Largest lane.
    fn hmax(self) -> f32;

    /// `clamp(self, 0, 1)`.
    #[inline(always)]
    fn saturate(self) -> Self {
        self.max(Self::splat(0.0)).min(Self::splat(1.0))
    }
}

/// Portable lanes: an array the compiler vectorises for whatever features the calling function has. `FMA` selects
/// fused multiply-add (only worth it when the CPU has it: otherwise it is a library call per lane).
#[derive(Clone, Copy, Debug)]
pub struct Portable<const FMA: bool>(pub [f32; LANES]);

macro_rules! lanewise {
    ($a:expr, $b:expr, |$x:ident, $y:ident| $e:expr) => {{
        let (a, b) = ($a, $b);
        let mut out = [0.0f32; LANES];
        for j in 0..LANES {
            let ($x, $y) = (a[j], b[j]);
            out[j] = $e;
        }
        out
    }};
}

impl<const FMA: bool> Add for Portable<FMA> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Portable(lanewise!(self.0, o.0, |x, y| x + y))
    }
}
impl<const FMA: bool> Sub for Portable<FMA> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Portable(lanewise!(self.0, o.0, |x, y| x - y))
    }
}
impl<const FMA: bool> Mul for Portable<FMA> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Portable(lanewise!(self.0, o.0, |x, y| x * y))
    }
}

impl<const FMA: bool> Portable<FMA> {
    /// `f` applied to every lane (a plain loop: `array::map` is not vectorised).
    #[inline(always)]
    fn each(self, f: impl Fn(f32) -> f32) -> Self {
        let mut out = self.0;
        for o in &mut out {
            *o = f(*o);
        }
        Portable(out)
    }

    /// Lane-wise comparison.
    #[inline(always)]
    fn cmp(self, o: Self, f: impl Fn(f32, f32) -> bool) -> [bool; LANES] {
        let mut out = [false; LANES];
        for ((m, &x), &y) in out.iter_mut().zip(&self.0).zip(&o.0) {
            *m = f(x, y);
        }
        out
    }
}

impl<const FMA: bool> Lanes for Portable<FMA> {
    const N: usize = LANES;
    type Mask = [bool; LANES];
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Portable([x; LANES])
    }
    #[inline(always)]
    fn load(a: &[f32]) -> Self {
        let mut out = [0.0; LANES];
        out.copy_from_slice(&a[..LANES]);
        Portable(out)
    }
    #[inline(always)]
    fn store(self, a: &mut [f32]) {
        a[..LANES].copy_from_slice(&self.0);
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        let mut out = self.0;
        for ((o, &y), &z) in out.iter_mut().zip(&b.0).zip(&c.0) {
            *o = if FMA { o.mul_add(y, z) } else { *o * y + z };
        }
        Portable(out)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Portable(lanewise!(self.0, o.0, |x, y| if x > y { x } else { y }))
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Portable(lanewise!(self.0, o.0, |x, y| if x < y { x } else { y }))
    }
    #[inline(always)]
    fn rsqrt(self) -> Self {
        self.each(|x| 1.0 / x.sqrt())
    }
    #[inline(always)]
    fn recip(self) -> Self {
        self.each(|x| 1.0 / x)
    }
    #[inline(always)]
    fn log2(self) -> Self {
        self.each(fastmath::log2)
    }
    #[inline(always)]
    fn exp2(self) -> Self {
        self.each(fastmath::exp2)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        self.cmp(o, |x, y| x > y)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self::Mask {
        self.cmp(o, |x, y| x >= y)
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self::Mask {
        self.cmp(o, |x, y| x <= y)
    }
    #[inline(always)]
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
        let mut out = a;
        for (o, &y) in out.iter_mut().zip(&b) {
            *o &= y;
        }
        out
    }
    #[inline(always)]
    fn keep(self, m: Self::Mask) -> Self {
        let mut out = self.0;
        for (o, &k) in out.iter_mut().zip(&m) {
            *o = if k { *o } else { 0.0 };
        }
        Portable(out)
    }
    #[inline(always)]
    fn count(self, m: Self::Mask) -> Self {
        let mut out = self.0;
        for (o, &k) in out.iter_mut().zip(&m) {
            *o += f32::from(u8::from(k));
        }
        Portable(out)
    }
    #[inline(always)]
    fn any(m: Self::Mask) -> bool {
        m.iter().fold(false, |a, &b| a | b)
    }
    #[inline(always)]
    fn hmin(self) -> f32 {
        self.0.iter().fold(f32::INFINITY, |a, &b| a.min(b))
    }
    #[inline(always)]
    fn hmax(self) -> f32 {
        self.0.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b))
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx512::Avx512;

#[cfg(target_arch = "x86_64")]
mod avx512 {
    //! AVX-512F lanes. Every method is `#[inline(always)]` and only ever inlined into functions compiled with
    //! `avx512f` (the kernel's dispatch checks the CPU first), so the intrinsics inline into vector code.
    use super::{Lanes, LANES};
    use std::arch::x86_64::*;
    use std::ops::{Add, Mul, Sub};

    /// Sixteen lanes in one AVX-512 register.
    #[derive(Clone, Copy, Debug)]
    pub struct Avx512(__m512);

    // SAFETY (all `unsafe` blocks in this module): the intrinsics need AVX-512F, and `Avx512` values are only
    // created inside functions the kernel dispatch enters after `is_x86_feature_detected!("avx512f")`. Loads and
    // stores check the slice length first.

    impl Add for Avx512 {
        type Output = Self;
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            unsafe { Avx512(_mm512_add_ps(self.0, o.0)) }
        }
    }
    impl Sub for Avx512 {
        type Output = Self;
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            unsafe { Avx512(_mm512_sub_ps(self.0, o.0)) }
        }
    }
    impl Mul for Avx512 {
        type Output = Self;
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            unsafe { Avx512(_mm512_mul_ps(self.0, o.0)) }
        }
    }

    impl Lanes for Avx512 {
        const N: usize = LANES;
        type Mask = __mmask16;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            unsafe { Avx512(_mm512_set1_ps(x)) }
        }
        #[inline(always)]
        fn load(a: &[f32]) -> Self {
            let a = &a[..LANES];
            unsafe { Avx512(_mm512_loadu_ps(a.as_ptr())) }
        }
        #[inline(always)]
        fn store(self, a: &mut [f32]) {
            let a = &mut a[..LANES];
            unsafe { _mm512_storeu_ps(a.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn mul_add(self, b: Self, c: Self) -> Self {
            unsafe { Avx512(_mm512_fmadd_ps(self.0, b.0, c.0)) }
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            unsafe { Avx512(_mm512_max_ps(self.0, o.0)) }
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            unsafe { Avx512(_mm512_min_ps(self.0, o.0)) }
        }
        #[inline(always)]
        fn rsqrt(self) -> Self {
            // y ≈ 1/√x to 2⁻¹⁴; one Newton step y·(1.5 − ½x·y²) brings it to about 2⁻²³.
            unsafe {
                let y = _mm512_rsqrt14_ps(self.0);
                let hx = _mm512_mul_ps(self.0, _mm512_set1_ps(0.5));
                let yy = _mm512_mul_ps(y, y);
                let t = _mm512_fnmadd_ps(hx, yy, _mm512_set1_ps(1.5));
                Avx512(_mm512_mul_ps(y, t))
            }
        }
        #[inline(always)]
        fn recip(self) -> Self {
            // y ≈ 1/x to 2⁻¹⁴; Newton y + y·(1 − x·y).
            unsafe {
                let y = _mm512_rcp14_ps(self.0);
                let e = _mm512_fnmadd_ps(self.0, y, _mm512_set1_ps(1.0));
                Avx512(_mm512_fmadd_ps(y, e, y))
            }
        }
        #[inline(always)]
        fn log2(self) -> Self {
            // x = m·2^e with m in [0.75, 1.5); log2 m = 2·atanh(s)/ln 2, s = (m − 1)/(m + 1), |s| ≤ 0.2.
            unsafe {
                let m = _mm512_getmant_ps::<_MM_MANT_NORM_P75_1P5, _MM_MANT_SIGN_ZERO>(self.0);
                // getexp(x) = floor(log2 x); getexp(m) is −1 when m < 1, which moved one factor 2 into e.
                let e = _mm512_sub_ps(_mm512_getexp_ps(self.0), _mm512_getexp_ps(m));
                let one = _mm512_set1_ps(1.0);
                let s = Avx512(_mm512_sub_ps(m, one)) * Avx512(_mm512_add_ps(m, one)).recip();
                let s2 = s * s;
                let c = |v: f32| Avx512::splat(v);
                // Estrin's scheme (shorter dependency chain than Horner): 1 + s²/3 + s⁴/5 + s⁶/7 + s⁸/9.
                let s4 = s2 * s2;
                let lo = s2.mul_add(c(1.0 / 3.0), c(1.0));
                let hi = s2.mul_add(c(1.0 / 7.0), c(1.0 / 5.0));
                let poly = s4.mul_add(s4 * c(1.0 / 9.0), s4.mul_add(hi, lo));
                let ln_m = (s + s) * poly;
                ln_m.mul_add(c(std::f32::consts::LOG2_E), Avx512(e))
            }
        }
        #[inline(always)]
        fn exp2(self) -> Self {
            // 2^x = 2^i · e^(f·ln 2), i = round(x), |f| ≤ ½; degree-7 Taylor series as fastmath::exp2.
            unsafe {
                let x = _mm512_min_ps(_mm512_max_ps(self.0, _mm512_set1_ps(-126.0)), _mm512_set1_ps(126.0));
                let i = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(x);
                let f = Avx512(_mm512_sub_ps(x, i)) * Avx512::splat(std::f32::consts::LN_2);
                let c = |v: f32| Avx512::splat(v);
                // Estrin's scheme for Σ fᵏ/k!, k ≤ 7: pairs, then quads.
                let f2 = f * f;
                let f4 = f2 * f2;
                let p01 = f.mul_add(c(1.0), c(1.0));
                let p23 = f.mul_add(c(1.0 / 6.0), c(0.5));
                let p45 = f.mul_add(c(1.0 / 120.0), c(1.0 / 24.0));
                let p67 = f.mul_add(c(1.0 / 5040.0), c(1.0 / 720.0));
                let p = f4.mul_add(f2.mul_add(p67, p45), f2.mul_add(p23, p01));
                Avx512(_mm512_scalef_ps(p.0, i))
            }
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Self::Mask {
            unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn ge(self, o: Self) -> Self::Mask {
            unsafe { _mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn le(self, o: Self) -> Self::Mask {
            unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
            a & b
        }
        #[inline(always)]
        fn keep(self, m: Self::Mask) -> Self {
            unsafe { Avx512(_mm512_maskz_mov_ps(m, self.0)) }
        }
        #[inline(always)]
        fn count(self, m: Self::Mask) -> Self {
            unsafe { Avx512(_mm512_mask_add_ps(self.0, m, self.0, _mm512_set1_ps(1.0))) }
        }
        #[inline(always)]
        fn any(m: Self::Mask) -> bool {
            m != 0
        }
        #[inline(always)]
        fn hmin(self) -> f32 {
            unsafe { _mm512_reduce_min_ps(self.0) }
        }
        #[inline(always)]
        fn hmax(self) -> f32 {
            unsafe { _mm512_reduce_max_ps(self.0) }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::SplitMix64;

    fn inputs(rng: &mut SplitMix64, lo: f32, hi: f32) -> Vec<f32> {
        (0..LANES * 64).map(|_| rng.range_f32(lo, hi)).collect()
    }

    /// Checks every operation of `V` against f64 on random lanes.
    fn check<V: Lanes>() {
        let mut rng = SplitMix64::new(11);
        let mut out = vec![0.0f32; V::N];
        let pos = inputs(&mut rng, 1e-6, 1e6);
        for c in pos.chunks(V::N) {
            V::load(c).rsqrt().store(&mut out);
            for (x, y) in c.iter().zip(out.iter().copied()) {
                let want = 1.0 / f64::from(*x).sqrt();
                assert!(((f64::from(y) - want) / want).abs() < f64::from(RSQRT_MAX_REL_ERROR), "rsqrt({x}) = {y}");
            }
            V::load(c).recip().store(&mut out);
            for (x, y) in c.iter().zip(out.iter().copied()) {
                let want = 1.0 / f64::from(*x);
                assert!(((f64::from(y) - want) / want).abs() < 3e-7, "recip({x}) = {y}");
            }
            V::load(c).log2().store(&mut out);
            for (x, y) in c.iter().zip(out.iter().copied()) {
                let want = f64::from(*x).log2();
                let tol = f64::from(fastmath::LOG2_MAX_ABS_ERROR) + want.abs() * f64::from(f32::EPSILON);
                assert!((f64::from(y) - want).abs() < tol, "log2({x}) = {y}, want {want}");
            }
        }
        let ex = inputs(&mut rng, -130.0, 130.0);
        for c in ex.chunks(V::N) {
            V::load(c).exp2().store(&mut out);
            for (x, y) in c.iter().zip(out.iter().copied()) {
                let want = f64::from(x.clamp(-126.0, 126.0)).exp2();
                let rel = (f64::from(y) - want).abs() / want;
                assert!(rel < f64::from(fastmath::EXP2_MAX_REL_ERROR), "exp2({x}) = {y}, want {want}");
            }
        }
        let a = V::load(&ex[..V::N]);
        let b = V::load(&ex[V::N..2 * V::N]);
        a.mul_add(b, a).store(&mut out);
        for j in 0..V::N {
            let want = f64::from(ex[j]) * f64::from(ex[V::N + j]) + f64::from(ex[j]);
            assert!((f64::from(out[j]) - want).abs() <= want.abs() * 1e-6 + 1e-3, "mul_add");
        }
        a.keep(a.gt(b)).store(&mut out);
        V::splat(0.0).count(a.le(b)).count(V::and(a.ge(b), a.le(b))).store(&mut out);
        for j in 0..V::N {
            let (x, y) = (ex[j], ex[V::N + j]);
            assert_eq!(out[j], f32::from(u8::from(x <= y)) + f32::from(u8::from(x == y)));
        }
        assert!(V::any(V::splat(1.0).gt(V::splat(0.0))));
        assert!(!V::any(V::splat(1.0).gt(V::splat(1.0))));
        assert_eq!(a.hmin(), ex[..V::N].iter().fold(f32::INFINITY, |m, &x| m.min(x)));
        assert_eq!(a.hmax(), ex[..V::N].iter().fold(f32::NEG_INFINITY, |m, &x| m.max(x)));
        V::splat(-3.0).saturate().store(&mut out);
        assert!(out.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn portable_lanes_are_accurate() {
        check::<Portable<false>>();
    }

    #[test]
    fn avx512_lanes_are_accurate_where_supported() {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx512f") {
            #[target_feature(enable = "avx512f")]
            fn run() {
                check::<Avx512>();
            }
            // SAFETY: the CPU has AVX-512F (checked above).
            unsafe {
                run();
            }
        }
    }
}
