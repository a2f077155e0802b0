//! 8-bit codes of a monotone transfer curve without evaluating it: the LDR gamma-2.2 output
//! (`image::Gamma22Lut`) and the `srgb8` colour codec (`codec::color`) each paid a `powf` per channel.
//!
//! For a formula `f: [0, 1] → 0..=255` that grows with `x`, the code of `x` is the number of thresholds
//! `t_1 ≤ … ≤ t_255` at or below it, where `t_k` is the smallest f32 with `f(t_k) ≥ k`, found once by bisection
//! over f32 bit patterns with the formula itself. A table indexed by the top bits of `x`'s bit pattern (buckets
//! as fine, relative to `x`, as 1/256 of a binade) holds the code at each bucket's start and the next threshold;
//! no bucket holds two thresholds (checked when the table is built), so one compare finishes the code, without a
//! branch. The result equals the formula's wherever the formula is monotone; each user's test sweeps every
//! threshold's neighbourhood and a dense grid of [0, 1] against its formula.

/// The thresholds and buckets of one formula.
pub struct CodeLut {
    /// `t[k]` for k in 1..=255 (`t[0]` = 0): what the users' tests check the table against.
    #[cfg_attr(not(test), allow(dead_code))]
    thresholds: [f32; 256],
    /// The bucket of `t_1` (every bucket below it has code 0 and the same next threshold): bucket `b` of an input
    /// is `max(bits >> SHIFT, low) − low`.
    low: u32,
    /// The code at each bucket's start.
    start: Vec<u8>,
    /// The smallest threshold above each bucket's start (+∞ when none).
    next: Vec<f32>,
}

impl CodeLut {
    /// A bucket is the bit patterns sharing all but their low `SHIFT` bits: 1/256 of a binade.
    const SHIFT: u32 = 15;

    /// The table of `formula`, which must give 0 at 0, 255 at 1 and grow with `x` in between.
    ///
    /// # Panics
    /// When `formula(0) != 0` or `formula(1) != 255`, or two of its thresholds are closer than a bucket (a code
    /// narrower than 1/256 of its input's binade): a programming error in the caller's formula.
    pub fn build(formula: impl Fn(f32) -> u8) -> CodeLut {
        assert_eq!((formula(0.0), formula(1.0)), (0, 255), "CodeLut: the formula must map [0, 1] onto 0..=255");
        let mut thresholds = [0.0f32; 256];
        for (k, t) in thresholds.iter_mut().enumerate().skip(1) {
            // Smallest bit pattern in [0, 1.0] whose code is ≥ k (positive floats order like their bits).
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if usize::from(formula(f32::from_bits(mid))) >= k {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            *t = f32::from_bits(lo);
        }
        let low = thresholds[1].to_bits() >> Self::SHIFT;
        let (mut start, mut next) = (Vec::new(), Vec::new());
        for b in low..=1.0f32.to_bits() >> Self::SHIFT {
            let (first, end) = (b << Self::SHIFT, (b + 1) << Self::SHIFT);
            // Thresholds at or below the bucket's first input, and inside it.
            let code = thresholds[1..].partition_point(|t| t.to_bits() <= first);
            let inside = thresholds[1..].partition_point(|t| t.to_bits() < end) - code;
            assert!(inside <= 1, "CodeLut: {inside} thresholds in the bucket from {}", f32::from_bits(first));
            start.push(code as u8);
            next.push(thresholds.get(code + 1).copied().unwrap_or(f32::INFINITY));
        }
        CodeLut { thresholds, low, start, next }
    }

    /// The code of `x`, which the caller has clamped to [0, 1] (NaN replaced).
    #[inline]
    #[must_use]
    pub fn encode_unit(&self, x: f32) -> u8 {
        debug_assert!((0.0..=1.0).contains(&x), "{x}");
        // The sign bit cleared: −0 is 0. `b` is then at most the bucket of 1.0, the tables' last.
        let b = (((x.to_bits() & 0x7fff_ffff) >> Self::SHIFT).max(self.low) - self.low) as usize;
        self.start[b] + u8::from(x >= self.next[b])
    }

    /// [`CodeLut::encode_unit`] of each of `xs` clamped to [0, 1] (NaN → 0), into `out`: one branch-free loop.
    pub fn encode_clamped(&self, xs: &[f32], out: &mut [u8]) {
        let (start, next, low) = (&self.start[..], &self.next[..], self.low);
        for (o, &x) in out.iter_mut().zip(xs) {
            // Compares, not `max`/`min`: a NaN fails `x >= 0` and becomes 0. (`f32::max` may turn a signalling NaN
            // into a quiet NaN instead of ignoring it: glibc's `fmaxf`, which debug builds call, does.)
            let x = if x >= 0.0 { x } else { 0.0 };
            let x = if x <= 1.0 { x } else { 1.0 };
            let b = (((x.to_bits() & 0x7fff_ffff) >> Self::SHIFT).max(low) - low) as usize;
            *o = start[b] + u8::from(x >= next[b]);
        }
    }

    /// `t_1 … t_255`: the smallest input of each code, for the users' tests.
    #[cfg(test)]
    pub(crate) fn thresholds(&self) -> &[f32] {
        &self.thresholds[1..]
    }

    /// Checks the table against `formula` (already clamping and replacing NaN, as the caller's encode does) at
    /// every threshold and `near` bit patterns either side of it, every `step`-th bit pattern of [0, 1], and
    /// out-of-range and non-finite inputs; returns the first input where they differ. The users' tests call it.
    #[cfg(test)]
    pub(crate) fn first_difference(
        &self,
        encode: impl Fn(f32) -> u8,
        formula: impl Fn(f32) -> u8,
        near: u32,
        step: usize,
    ) -> Option<f32> {
        let differs = |x: f32| encode(x) != formula(x);
        for &t in self.thresholds() {
            for d in 0..near {
                for x in [f32::from_bits(t.to_bits().saturating_sub(d)), f32::from_bits(t.to_bits() + d)] {
                    if differs(x) {
                        return Some(x);
                    }
                }
            }
        }
        let grid = (0..=1.0f32.to_bits()).step_by(step.max(1)).map(f32::from_bits);
        let special = [0.0, 1.0, -0.0, -1.0, 2.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE];
        grid.chain(special).find(|&x| differs(x))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_formula_is_reproduced_and_a_wrong_table_is_caught() {
        let formula = |x: f32| {
            let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
            (x * 255.0 + 0.5) as u8
        };
        let lut = CodeLut::build(formula);
        let encode = |x: f32| lut.encode_unit(if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) });
        assert_eq!(lut.first_difference(encode, formula, 16, 9973), None);
        // The check can fail: a formula off by one code above 0.5 is found.
        let other = |x: f32| formula(x).saturating_add(u8::from(x > 0.5 && x < 1.0));
        assert!(lut.first_difference(encode, other, 16, 9973).is_some());
    }
}
