//! The one branch-free `log2`, `exp2` and `pow` of the crate, for the shading kernel and FLIP. `f32::powf` is a libm
//! call, which stops the compiler from vectorising a loop; these use only arithmetic, comparisons and bit casts, so
//! they do (the resolve's explicit SIMD paths, `resolve::simd`, are these formulas lane by lane).
//!
//! Accuracy (checked by the tests below against f64): `log2` within [`LOG2_MAX_ABS_ERROR`] plus one f32 epsilon
//! of the result for normal inputs, `exp2` within [`EXP2_MAX_REL_ERROR`] relative on [−126, 126]. `pow_clamped(x, p)` takes `x` in
//! [0, 1] (clamped to [`POW_MIN_BASE`] so that `0^p` is about 0 for `p > 0` and exactly 1 for `p = 0`).

/// Absolute error bound of [`log2`] for normal positive inputs.
#[cfg_attr(not(test), allow(dead_code))] // the bound / scalar path the tests check against
pub const LOG2_MAX_ABS_ERROR: f32 = 2e-6;
/// Relative error bound of [`exp2`] on [−126, 126].
#[cfg_attr(not(test), allow(dead_code))] // the bound / scalar path the tests check against
pub const EXP2_MAX_REL_ERROR: f32 = 2e-6;
/// Smallest base [`pow_clamped`] uses (`log2` of it is about −99.7).
pub const POW_MIN_BASE: f32 = 1e-30;

/// `log2(x)` for normal positive `x` (range-reduced to [√½, √2), then the atanh series).
#[inline(always)]
#[must_use]
pub fn log2(x: f32) -> f32 {
    let bits = x.to_bits();
    let mut e = ((bits >> 23) & 0xff) as i32 - 127;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let big = m > std::f32::consts::SQRT_2;
    m = if big { m * 0.5 } else { m };
    e += i32::from(big);
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    // 2·atanh(s) = ln(m); |s| ≤ 0.1716 so the s¹¹ term is below 1e-9.
    let ln_m = 2.0 * s * (1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0)))));
    e as f32 + ln_m * std::f32::consts::LOG2_E
}

/// `2^x`, with `x` clamped to [−126, 126] (round to nearest integer, then a degree-7 Taylor series of e^(f·ln2)
/// for |f| ≤ ½).
#[inline(always)]
#[must_use]
pub fn exp2(x: f32) -> f32 {
    exp2_below(x, 126.0)
}

/// `2^min(x, 0)`, in [0, 1]: [`exp2`] with its upper clamp at 0 instead of 126 (the same two comparisons, so a
/// power known to be at most 1 — `(N·H)^p` with N·H ≤ 1 — costs nothing extra to keep finite).
#[inline(always)]
#[must_use]
pub fn exp2_nonpositive(x: f32) -> f32 {
    exp2_below(x, 0.0)
}

/// `log2(x)` for every finite `x > 0`, subnormals included (scaled by 2²⁴ into the normal range first): FLIP's
/// colour and distance terms reach below `f32::MIN_POSITIVE`, the kernel's clamped bases never do.
#[inline(always)]
#[must_use]
pub fn log2_any(x: f32) -> f32 {
    let sub = x < f32::MIN_POSITIVE;
    let scaled = if sub { x * 16_777_216.0 } else { x };
    log2(scaled) - if sub { 24.0 } else { 0.0 }
}

/// [`exp2`] with `x` clamped to [−126, `hi`] (`hi` ≤ 127, where the result is still finite).
#[inline(always)]
#[must_use]
pub fn exp2_below(x: f32, hi: f32) -> f32 {
    let x = x.clamp(-126.0, hi);
    // Round to nearest with the 1.5·2²³ trick: adding it leaves round(x) in the low mantissa bits. Unlike `floor`
    // (a libm call on baseline x86_64) or a saturating `as i32` (NaN/overflow fix-ups), this is plain vector
    // arithmetic.
    const MAGIC: f32 = 12_582_912.0;
    let shifted = x + MAGIC;
    let i = shifted.to_bits() as i32 - MAGIC.to_bits() as i32;
    let f = (x - (shifted - MAGIC)) * std::f32::consts::LN_2;
    let p = 1.0
        + f * (1.0
            + f * (1.0 / 2.0
                + f * (1.0 / 6.0 + f * (1.0 / 24.0 + f * (1.0 / 120.0 + f * (1.0 / 720.0 + f * (1.0 / 5040.0)))))));
    p * f32::from_bits(((i + 127) as u32) << 23)
}

/// `x^p` for `x` in [0, 1] and `p ≥ 0`: `exp2(p · log2(max(x, POW_MIN_BASE)))`.
#[inline(always)]
#[must_use]
#[cfg_attr(not(test), allow(dead_code))] // the bound / scalar path the tests check against
pub fn pow_clamped(x: f32, p: f32) -> f32 {
    exp2(p * log2(x.max(POW_MIN_BASE)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log2_matches_f64_over_many_decades() {
        let mut x = 1e-30f32;
        while x < 1e30 {
            for m in [1.0f32, 1.2, std::f32::consts::SQRT_2 * 0.9999, std::f32::consts::SQRT_2 * 1.0001, 1.7, 1.999] {
                let v = x * m;
                let want = f64::from(v).log2();
                let got = f64::from(log2(v));
                let tol = f64::from(LOG2_MAX_ABS_ERROR) + want.abs() * f64::from(f32::EPSILON);
                assert!((got - want).abs() < tol, "log2({v}) = {got}, want {want}");
            }
            x *= 7.3;
        }
        assert_eq!(log2(1.0), 0.0);
        // Subnormals: the same bound through the scaling.
        for v in [1e-45f32, 3e-42, 1e-39, f32::MIN_POSITIVE * 0.999, f32::MIN_POSITIVE, 1e-30, 5.0] {
            let want = f64::from(v).log2();
            let got = f64::from(log2_any(v));
            let tol = f64::from(LOG2_MAX_ABS_ERROR) + want.abs() * f64::from(f32::EPSILON);
            assert!((got - want).abs() < tol, "log2_any({v}) = {got}, want {want}");
        }
        assert!(exp2_below(127.0, 127.0).is_finite() && exp2_below(1e9, 127.0) > 1e38);
    }

    #[test]
    fn exp2_matches_f64() {
        let mut x = -126.0f32;
        while x <= 126.0 {
            let want = f64::from(x).exp2();
            let got = f64::from(exp2(x));
            assert!(((got - want) / want).abs() < f64::from(EXP2_MAX_REL_ERROR), "exp2({x}) = {got}, want {want}");
            x += 0.173;
        }
        assert_eq!(exp2(0.0), 1.0);
        assert!(exp2(-1e9) >= 0.0 && exp2(-1e9) < 1e-37);
        assert!(exp2(1e9).is_finite());
        assert_eq!(exp2_nonpositive(0.0), 1.0);
        assert_eq!(exp2_nonpositive(1e30), 1.0);
        assert_eq!(exp2_nonpositive(-3.0), exp2(-3.0));
    }

    #[test]
    fn pow_handles_the_stiff_exponents() {
        assert_eq!(pow_clamped(0.0, 0.0), 1.0);
        assert_eq!(pow_clamped(0.3, 0.0), 1.0);
        assert!(pow_clamped(0.0, 1.0) < 1e-29);
        assert!(pow_clamped(0.999, 1e4) < 1e-4 && pow_clamped(0.999, 1e4) > 0.0);
        assert!(pow_clamped(0.9, 1e6) >= 0.0);
        for (x, p) in [(0.5f32, 2.0f32), (0.9, 32.0), (0.99, 500.0), (1.0, 1e4)] {
            let want = f64::from(x).powf(f64::from(p));
            let got = f64::from(pow_clamped(x, p));
            assert!((got - want).abs() <= 1e-4 * want + 1e-12, "{x}^{p} = {got}, want {want}");
        }
    }
}
