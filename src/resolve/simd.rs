//! Sixteen-lane f32 vectors for the shading kernel, one type per instruction set, so the kernel is written once
//! (generic over [`Lanes`]) and compiled for each (three times on x86-64, twice on aarch64):
//!
//! - [`Avx512`]: one `__m512`; `rsqrt` is `vrsqrt14ps` plus a Newton step, `log2` uses `vgetexpps`/`vgetmantps`,
//!   `exp2` uses `vscalefps` — no divider, no square root unit in the light loop;
//! - [`Avx2`]: two `__m256`; `rsqrt` and `recip` are `vrsqrtps`/`vrcpps` plus a Newton step, `log2` divides by a
//!   refined reciprocal, `exp2` builds `2^i` in the exponent bits — no divider, no square root unit either;
//! - `Neon` (aarch64 only, `simd/neon.rs`): four `float32x4_t`, the AVX2 scheme with NEON's estimates (`frsqrte`,
//!   `frecpe` and Newton steps) and a `tbl` lookup for `log2`'s table;
//! - [`Portable`]`<false>`: sixteen `f32`s in an array, lane loops the compiler vectorises for whatever the target
//!   has (x86-64 without AVX2, and every other architecture); `Portable<true>` is the same with fused
//!   multiply-adds.
//!
//! Accuracy (tests below, against f64): `rsqrt` within [`RSQRT_MAX_REL_ERROR`]; `log2` and `exp2` within the
//! bounds of `fastmath.rs` on every path. Results differ between paths by rounding only (fused vs separate
//! multiply-add, refined vs exact reciprocal square root); within one run the same path shades every tile, so
//! images do not depend on culling, tile size or thread count.

use crate::base::fastmath;
use std::ops::{Add, Mul, Sub};

/// Lanes per machine vector of the base types ([`Portable`], [`Avx512`]).
pub const LANES: usize = 16;
/// Work lists are padded to a multiple of this many items (the kernel's step).
pub const BLOCK: usize = LANES;

/// Relative error bound of [`Lanes::rsqrt`] on normal positive inputs (the refined `vrsqrt14ps` path; the portable
/// path is `1/√x`, within 2 ulp).
#[cfg_attr(not(test), allow(dead_code))] // the bound / scalar path the tests check against
pub const RSQRT_MAX_REL_ERROR: f32 = 4e-7;
/// Relative error bound of [`Lanes::rsqrt_approx`] (`vrsqrt14ps`: 2⁻¹⁴).
#[cfg_attr(not(test), allow(dead_code))] // the bound / scalar path the tests check against
pub const RSQRT_APPROX_REL_ERROR: f32 = 1.0 / 16384.0;
/// Relative error bound of [`Lanes::rsqrt_estimate`] (AVX2's `vrsqrtps`: 1.5·2⁻¹², Intel's documented bound).
#[cfg_attr(not(test), allow(dead_code))] // the bound the tests check against
pub const RSQRT_ESTIMATE_REL_ERROR: f32 = 1.5 / 4096.0;

/// `2^f ≈ Σ cₖ fᵏ` on |f| ≤ ½ (minimax, relative error 7.5e-8 in exact arithmetic, with its constant term
/// 1.0000001 rounded to 1 so that `2^0 = 1` exactly: 1.8e-7 — `exp2_nonpositive` must never exceed 1, and
/// `exp2` of the −126 clamp must not exceed 2⁻¹²⁶).
const EXP2_P: [f32; 6] = [1.0, 0.693_146_97, 0.240_221_2, 0.055_507_13, 0.009_675_542, 0.001_327_647_2];

/// `1/c` (rounded to f32) for the 8 sub-intervals `[1 + i/8, 1 + (i+1)/8)` of [1, 2) that the AVX2 and NEON
/// `log2` index by bits 22..20 of the mantissa; `c` is each sub-interval's centre. Checked against f64 by a test.
const LOG2_INV_C8: [f32; 8] =
    [0.941_176_5, 0.842_105_27, 0.761_904_8, 0.695_652_2, 0.64, 0.592_592_6, 0.551_724_14, 0.516_129];
/// `−log2` of each [`LOG2_INV_C8`] entry, rounded to f32.
const LOG2_T8: [f32; 8] =
    [0.087_462_835, 0.247_927_5, 0.392_317_38, 0.523_561_95, 0.643_856_2, 0.754_887_46, 0.857_981, 0.954_196_33];
/// `log2(1 + r)/r ≈ q0 + q1 r + q2 r² + q3 r³` on |r| ≤ 1/17 (Taylor terms).
const LOG2_Q8: [f32; 4] = [std::f32::consts::LOG2_E, -0.721_347_5, 0.480_898_35, -0.360_673_76];

/// A vector of [`LANES`] f32 lanes with the operations the shading kernel needs.
pub trait Lanes: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {
    /// Number of lanes.
    const N: usize;
    /// Lights the kernel shades per step (1, 2 or 4): 4 for [`Avx512`] (their dependency chains interleave, see
    /// [`Two`]); 1 for [`Portable`], whose four-light code is sixteen-lane arrays four times over and takes the
    /// compiler tens of minutes at `opt-level = 1` (the AVX2 path measured 2.2 ns per pair with 4, 2.7 with 1), and
    /// for `Neon`, whose four quarters already interleave (more lights spill more registers).
    const INTERLEAVE: usize = 1;
    /// [`Lanes::INTERLEAVE`] for the GGX kernel, whose step holds more values live: [`Avx2`] (two registers per
    /// value in 16 ymm registers) shades one light at a time there (2.42 → 1.99 ns per pair on Zen 4, while Lambert
    /// and Blinn-Phong stay fastest with 4: 0.58 against 0.82, 1.72 against 2.00; `kernel_pair_throughput`).
    const INTERLEAVE_GGX: usize = Self::INTERLEAVE;
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
    /// `c − self · b` (fused where the CPU has FMA).
    fn nmul_add(self, b: Self, c: Self) -> Self;
    /// Lane-wise maximum (`max(NaN, x) = x` is not relied on: inputs are finite).
    fn max(self, o: Self) -> Self;
    /// Lane-wise minimum.
    fn min(self, o: Self) -> Self;
    /// `1/√self` for positive finite lanes.
    fn rsqrt(self) -> Self;
    /// `1/√self` for positive finite lanes to within [`RSQRT_APPROX_REL_ERROR`] (AVX-512: the hardware estimate,
    /// one instruction; the portable lanes compute it exactly).
    fn rsqrt_approx(self) -> Self;
    /// `1/√self` for positive finite lanes to within [`RSQRT_ESTIMATE_REL_ERROR`]: the cheapest estimate the
    /// instruction set has (AVX2: `vrsqrtps` alone; elsewhere [`Lanes::rsqrt_approx`]), for callers that take the
    /// estimate's error out themselves (Blinn-Phong's half vector, corrected in the log domain).
    #[inline(always)]
    fn rsqrt_estimate(self) -> Self {
        self.rsqrt_approx()
    }
    /// `1/self` for positive finite lanes, accurate to about 1 ulp.
    fn recip(self) -> Self;
    /// `log2` of positive normal lanes (error bound of [`fastmath::log2`]).
    fn log2(self) -> Self;
    /// `2^self` for finite `self`, within the relative error bound of [`fastmath::exp2`] on [−126, 126]; below −126
    /// any value in [0, 2⁻¹²⁶], above 126 any value ≥ 2¹²⁶ (the portable lanes clamp there, AVX-512 overflows to
    /// +∞ above 128).
    fn exp2(self) -> Self;
    /// `2^min(self, 0)`: [`Lanes::exp2`] of a non-positive exponent, in [0, 1] for any finite lane (the portable
    /// lanes fold the bound into `exp2`'s own clamp; AVX-512 takes the minimum first).
    #[inline(always)]
    fn exp2_nonpositive(self) -> Self {
        self.min(Self::splat(0.0)).exp2()
    }
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
    #[cfg_attr(not(test), allow(dead_code))] // used by the tests
    fn any(m: Self::Mask) -> bool;
    /// The mask as bits (lane `j` → bit `j`).
    fn bits(m: Self::Mask) -> u64;
    /// Writes `base + j` for every lane `j` set in `m`, in increasing order, to the start of `out` (at least `N`
    /// long); returns how many. The first `N` entries of `out` past those may be overwritten.
    #[inline(always)]
    fn compress_indices(m: Self::Mask, base: u32, out: &mut [u32]) -> usize {
        let mut bits = Self::bits(m);
        let mut n = 0;
        while bits != 0 {
            out[n] = base + bits.trailing_zeros();
            n += 1;
            bits &= bits - 1;
        }
        n
    }
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
    fn nmul_add(self, b: Self, c: Self) -> Self {
        let mut out = self.0;
        for ((o, &y), &z) in out.iter_mut().zip(&b.0).zip(&c.0) {
            *o = if FMA { (-*o).mul_add(y, z) } else { z - *o * y };
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
    fn rsqrt_approx(self) -> Self {
        self.rsqrt()
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
    fn exp2_nonpositive(self) -> Self {
        self.each(fastmath::exp2_nonpositive)
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
    fn bits(m: Self::Mask) -> u64 {
        let mut b = 0u64;
        for (j, &x) in m.iter().enumerate() {
            b |= u64::from(x) << j;
        }
        b
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

/// Two vectors that step together: the kernel shades two lights at once, one per half, so the two lights'
/// independent dependency chains are interleaved instruction by instruction (the light loop is latency-bound:
/// one light's chain — rsqrt, log2, exp2 — is far longer than its throughput cost). Per-sample values are
/// `Two(x, x)`: both halves are the same register. Every operation applies to both halves; the lane count is the
/// base type's (`N` is per half).
#[derive(Clone, Copy, Debug)]
pub struct Two<V>(pub V, pub V);

impl<V: Lanes> Add for Two<V> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Two(self.0 + o.0, self.1 + o.1)
    }
}
impl<V: Lanes> Sub for Two<V> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Two(self.0 - o.0, self.1 - o.1)
    }
}
impl<V: Lanes> Mul for Two<V> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Two(self.0 * o.0, self.1 * o.1)
    }
}

impl<V: Lanes> Two<V> {
    /// The same vector in both halves.
    #[inline(always)]
    pub fn both(v: V) -> Self {
        Two(v, v)
    }
}

impl<V: Lanes> Lanes for Two<V> {
    const N: usize = V::N;
    type Mask = (V::Mask, V::Mask);
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Two::both(V::splat(x))
    }
    /// Both halves from `a` (the same lanes).
    #[inline(always)]
    fn load(a: &[f32]) -> Self {
        Two::both(V::load(a))
    }
    /// The first half (the second is the other light's).
    #[inline(always)]
    fn store(self, a: &mut [f32]) {
        self.0.store(a);
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        Two(self.0.mul_add(b.0, c.0), self.1.mul_add(b.1, c.1))
    }
    #[inline(always)]
    fn nmul_add(self, b: Self, c: Self) -> Self {
        Two(self.0.nmul_add(b.0, c.0), self.1.nmul_add(b.1, c.1))
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Two(self.0.max(o.0), self.1.max(o.1))
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Two(self.0.min(o.0), self.1.min(o.1))
    }
    #[inline(always)]
    fn rsqrt(self) -> Self {
        Two(self.0.rsqrt(), self.1.rsqrt())
    }
    #[inline(always)]
    fn rsqrt_approx(self) -> Self {
        Two(self.0.rsqrt_approx(), self.1.rsqrt_approx())
    }
    #[inline(always)]
    fn rsqrt_estimate(self) -> Self {
        Two(self.0.rsqrt_estimate(), self.1.rsqrt_estimate())
    }
    #[inline(always)]
    fn recip(self) -> Self {
        Two(self.0.recip(), self.1.recip())
    }
    #[inline(always)]
    fn log2(self) -> Self {
        Two(self.0.log2(), self.1.log2())
    }
    #[inline(always)]
    fn exp2(self) -> Self {
        Two(self.0.exp2(), self.1.exp2())
    }
    #[inline(always)]
    fn exp2_nonpositive(self) -> Self {
        Two(self.0.exp2_nonpositive(), self.1.exp2_nonpositive())
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        (self.0.gt(o.0), self.1.gt(o.1))
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self::Mask {
        (self.0.ge(o.0), self.1.ge(o.1))
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self::Mask {
        (self.0.le(o.0), self.1.le(o.1))
    }
    #[inline(always)]
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
        (V::and(a.0, b.0), V::and(a.1, b.1))
    }
    #[inline(always)]
    fn keep(self, m: Self::Mask) -> Self {
        Two(self.0.keep(m.0), self.1.keep(m.1))
    }
    #[inline(always)]
    fn count(self, m: Self::Mask) -> Self {
        Two(self.0.count(m.0), self.1.count(m.1))
    }
    #[inline(always)]
    fn any(m: Self::Mask) -> bool {
        V::any(m.0) || V::any(m.1)
    }
    /// The first half's bits.
    #[inline(always)]
    fn bits(m: Self::Mask) -> u64 {
        V::bits(m.0)
    }
    #[inline(always)]
    fn hmin(self) -> f32 {
        self.0.hmin().min(self.1.hmin())
    }
    #[inline(always)]
    fn hmax(self) -> f32 {
        self.0.hmax().max(self.1.hmax())
    }
}

/// The lanes the baseline level runs on: NEON on aarch64 (part of every aarch64 target), else the portable lanes.
#[cfg(target_arch = "aarch64")]
pub type BaselineLanes = Neon;
/// The lanes the baseline level runs on: NEON on aarch64 (part of every aarch64 target), else the portable lanes.
#[cfg(not(target_arch = "aarch64"))]
pub type BaselineLanes = Portable<false>;

/// `$e` with `$V` the lane type of `$isa`: [`Avx512`], [`Avx2`], or `$baseline` below them (and on every other
/// architecture). Written inside a [`crate::base::isa::Kernel`]'s `run`, whose `isa` is the constant its
/// `#[target_feature]` wrapper was compiled for: the match folds away and the lanes' intrinsics inline into the
/// wrapper. The resolve's one way to pick lanes, under `base::isa::run`, the crate's one ISA dispatch.
macro_rules! lanes_for {
    ($isa:expr, $baseline:ty, |$V:ident| $e:expr) => {
        match $isa {
            #[cfg(target_arch = "x86_64")]
            $crate::base::isa::Isa::Avx512 => {
                type $V = $crate::resolve::simd::Avx512;
                $e
            }
            #[cfg(target_arch = "x86_64")]
            $crate::base::isa::Isa::Avx2 => {
                type $V = $crate::resolve::simd::Avx2;
                $e
            }
            _ => {
                type $V = $baseline;
                $e
            }
        }
    };
}
pub(crate) use lanes_for;

#[cfg(target_arch = "aarch64")]
mod neon;
#[cfg(target_arch = "aarch64")]
pub use neon::Neon;

#[cfg(target_arch = "x86_64")]
pub use avx512::Avx512;

#[cfg(target_arch = "x86_64")]
mod avx512;

#[cfg(target_arch = "x86_64")]
pub use avx2::Avx2;

#[cfg(target_arch = "x86_64")]
mod avx2;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

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
            V::load(c).rsqrt_approx().store(&mut out);
            for (x, y) in c.iter().zip(out.iter().copied()) {
                let want = 1.0 / f64::from(*x).sqrt();
                assert!(
                    ((f64::from(y) - want) / want).abs() <= f64::from(RSQRT_APPROX_REL_ERROR),
                    "rsqrt_approx({x}) = {y}"
                );
            }
            V::load(c).rsqrt_estimate().store(&mut out);
            for (x, y) in c.iter().zip(out.iter().copied()) {
                let want = 1.0 / f64::from(*x).sqrt();
                assert!(
                    ((f64::from(y) - want) / want).abs() <= f64::from(RSQRT_ESTIMATE_REL_ERROR),
                    "rsqrt_estimate({x}) = {y}"
                );
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
                if *x < -126.0 {
                    // Below the clamp: anything in [0, 2^−126] (vscalefps underflows gradually to 0).
                    assert!((0.0..=f32::MIN_POSITIVE).contains(&y), "exp2({x}) = {y}");
                    continue;
                }
                if *x > 126.0 {
                    // 2^126 exactly (not `powi`, which Miri evaluates with a deliberate last-bit error).
                    assert!(y >= f32::from_bits((126 + 127) << 23), "exp2({x}) = {y}");
                    continue;
                }
                let want = f64::from(*x).exp2();
                let rel = (f64::from(y) - want).abs() / want;
                assert!(rel < f64::from(fastmath::EXP2_MAX_REL_ERROR), "exp2({x}) = {y}, want {want}");
            }
        }
        for c in ex.chunks(V::N) {
            // The bounded form equals exp2 of the clamped exponent on every path, and never exceeds 1.
            V::load(c).exp2_nonpositive().store(&mut out);
            let mut want = vec![0.0f32; V::N];
            let clamped: Vec<f32> = c.iter().map(|x| x.min(0.0)).collect();
            V::load(&clamped).exp2().store(&mut want);
            assert_eq!(out, want, "exp2_nonpositive({c:?})");
            assert!(out.iter().all(|&y| (0.0..=1.0).contains(&y)));
        }
        let a = V::load(&ex[..V::N]);
        let b = V::load(&ex[V::N..2 * V::N]);
        a.mul_add(b, a).store(&mut out);
        for j in 0..V::N {
            let want = f64::from(ex[j]) * f64::from(ex[V::N + j]) + f64::from(ex[j]);
            assert!((f64::from(out[j]) - want).abs() <= want.abs() * 1e-6 + 1e-3, "mul_add");
        }
        a.nmul_add(b, a).store(&mut out);
        for j in 0..V::N {
            let want = f64::from(ex[j]) - f64::from(ex[j]) * f64::from(ex[V::N + j]);
            assert!((f64::from(out[j]) - want).abs() <= want.abs() * 1e-6 + 1e-3, "nmul_add");
        }
        a.keep(a.gt(b)).store(&mut out);
        V::splat(0.0).count(a.le(b)).count(V::and(a.ge(b), a.le(b))).store(&mut out);
        for j in 0..V::N {
            let (x, y) = (ex[j], ex[V::N + j]);
            assert_eq!(out[j], f32::from(u8::from(x <= y)) + f32::from(u8::from(x == y)));
        }
        let m = a.gt(b);
        let mut idx = [0u32; 64];
        let n = V::compress_indices(m, 100, &mut idx);
        let want: Vec<u32> = (0..V::N).filter(|&j| ex[j] > ex[V::N + j]).map(|j| 100 + j as u32).collect();
        assert_eq!(&idx[..n], &want[..], "compress_indices");
        assert!(V::any(V::splat(1.0).gt(V::splat(0.0))));
        assert!(!V::any(V::splat(1.0).gt(V::splat(1.0))));
        assert_eq!(a.hmin(), ex[..V::N].iter().fold(f32::INFINITY, |m, &x| m.min(x)));
        assert_eq!(a.hmax(), ex[..V::N].iter().fold(f32::NEG_INFINITY, |m, &x| m.max(x)));
        V::splat(-3.0).saturate().store(&mut out);
        assert!(out.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn log2_tables8_are_the_subinterval_centres() {
        for i in 0..8 {
            let (lo, w) = (1.0 + i as f64 / 8.0, 1.0 / 8.0);
            let inv = (1.0 / (lo + w / 2.0)) as f32;
            assert_eq!(LOG2_INV_C8[i], inv, "1/c[{i}]");
            assert_eq!(LOG2_T8[i], (-f64::from(inv).log2()) as f32, "T[{i}]");
            // The index the AVX2 and NEON paths compute (bits 22..20 of m) selects this sub-interval at both ends.
            for m in [lo, lo + w * 0.999_99] {
                assert_eq!(((m as f32).to_bits() >> 20) & 7, i as u32, "m = {m}");
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn log2_tables_are_the_subinterval_centres() {
        use super::avx512::{LOG2_INV_C, LOG2_T};
        for i in 0..32 {
            let (lo, w) = (1.0 + i as f64 / 32.0, 1.0 / 32.0);
            let inv = (1.0 / (lo + w / 2.0)) as f32;
            assert_eq!(LOG2_INV_C[i], inv, "1/c[{i}]");
            assert_eq!(LOG2_T[i], (-f64::from(inv).log2()) as f32, "T[{i}]");
            // The index the kernel computes (bits 22..18 of m) selects this sub-interval at both ends.
            for m in [lo, lo + w * 0.999_99] {
                assert_eq!(((m as f32).to_bits() >> 18) & 31, i as u32, "m = {m}");
            }
        }
    }

    #[test]
    fn portable_lanes_are_accurate() {
        check::<Portable<false>>();
        // `Two` applies every operation to both halves; `load` fills both, `store` writes the first.
        check::<Two<Portable<false>>>();
    }

    /// `check` on the lanes of `isa`, compiled for it ([`crate::base::isa::run`]; capped at the CPU's level).
    fn check_at(isa: crate::base::isa::Isa) {
        struct Check;
        impl crate::base::isa::Kernel for Check {
            type Output = ();
            #[inline(always)]
            fn run(self, isa: crate::base::isa::Isa) {
                lanes_for!(isa, Portable<false>, |V| {
                    check::<V>();
                    check::<Two<V>>();
                });
            }
        }
        crate::base::isa::run(isa, Check);
    }

    #[test]
    fn avx2_lanes_are_accurate_where_supported() {
        check_at(crate::base::isa::Isa::Avx2);
    }

    #[cfg(target_arch = "aarch64")]
    #[test]
    fn neon_lanes_are_accurate() {
        check::<Neon>();
        check::<Two<Neon>>();
    }

    #[test]
    fn avx512_lanes_are_accurate_where_supported() {
        check_at(crate::base::isa::Isa::Avx512);
    }
}
