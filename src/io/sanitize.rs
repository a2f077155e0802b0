//! The sanitize pass every loader ends with: NaN and ±Inf are counted per attribute and replaced by finite values,
//! so that no stage downstream sees them and no user is left unaware of them.
//!
//! Replacements: NaN → 0, +Inf → `f32::MAX`, −Inf → `−f32::MAX` (the sign and "huge" survive, the arithmetic stays
//! finite). Background samples are included: a loader that wants sky to carry +Inf depth must mark it uncovered and
//! zero it first (they all do).

use crate::gbuffer::{Attribute, GBuffer, PlaneSlot};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

fn fix(v: &mut f32, nan: &mut u64, inf: &mut u64) {
    if v.is_nan() {
        *nan += 1;
        *v = 0.0;
    } else if v.is_infinite() {
        *inf += 1;
        *v = if *v > 0.0 { f32::MAX } else { -f32::MAX };
    }
}

/// Items per parallel chunk: large enough that a chunk's count costs more than its task.
const CHUNK: usize = 1 << 14;

/// Fixes every f32 of `p` (a plane viewed as its components), in parallel chunks; returns (NaN, Inf) counts.
fn floats(p: &mut [f32]) -> (u64, u64) {
    p.par_chunks_mut(CHUNK).map(fix_run).reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
}

/// The sanitising of one run of values, on this thread (a chunk of a plane here; a row as the ISPC reader converts
/// it): NaN → 0, ±Inf → ±`f32::MAX`; returns (NaN, Inf) counts.
pub(crate) fn fix_run(c: &mut [f32]) -> (u64, u64) {
    // A run of finite values (all of a well-formed dump) is only read, by a test that runs in vector lanes; the
    // fix, which branches and writes per value, runs on the runs that need it. On a 1280×720 `.bin` this pass was
    // 15% of a 1-thread `gbuf resolve`.
    if crate::base::isa::run(crate::base::isa::Isa::detect(), AllFinite(c)) {
        return (0, 0);
    }
    let (mut nan, mut inf) = (0, 0);
    c.iter_mut().for_each(|v| fix(v, &mut nan, &mut inf));
    (nan, inf)
}

/// Whether every value is finite, compiled for the widest instruction set the CPU has.
struct AllFinite<'a>(&'a [f32]);

impl crate::base::isa::Kernel for AllFinite<'_> {
    type Output = bool;
    #[inline(always)]
    fn run(self, _: crate::base::isa::Isa) -> bool {
        self.0.iter().fold(true, |ok, v| ok & v.is_finite())
    }
}

fn scalars(p: &mut [f32]) -> (u64, u64) {
    floats(p)
}

fn vec2s(p: &mut [Vec2]) -> (u64, u64) {
    floats(bytemuck::cast_slice_mut(p))
}

fn vec3s(p: &mut [Vec3]) -> (u64, u64) {
    floats(bytemuck::cast_slice_mut(p))
}

/// Replaces every NaN and ±Inf value (per component) in the float attributes of `gb` and returns, for each
/// attribute that had any, `(name, NaN count, Inf count)` in canonical attribute order.
pub fn sanitize(gb: &mut GBuffer) -> Vec<(&'static str, u64, u64)> {
    let mut out = Vec::new();
    for attr in Attribute::ALL {
        let counts = match gb.slot(attr) {
            PlaneSlot::F32(p) => p.as_deref_mut().map(scalars),
            PlaneSlot::Vec2(p) => p.as_deref_mut().map(vec2s),
            PlaneSlot::Vec3(p) => p.as_deref_mut().map(vec3s),
            PlaneSlot::U32(_) => None,
        };
        if let Some((nan, inf)) = counts.filter(|c| c.0 + c.1 > 0) {
            out.push((attr.name(), nan, inf));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_replaces_per_component() {
        let mut gb = GBuffer::new(2, 1, 2).unwrap();
        gb.depth = Some(vec![1.0, f32::NAN, f32::INFINITY, 2.0]);
        gb.normal = Some(vec![Vec3::new(f32::NAN, f32::NEG_INFINITY, f32::NAN), Vec3::Z, Vec3::Z, Vec3::Z]);
        gb.albedo = Some(vec![Vec3::ONE; 4]);
        let s = sanitize(&mut gb);
        assert_eq!(s, vec![("depth", 1, 1), ("normal", 2, 1)]);
        assert_eq!(gb.depth.as_ref().unwrap(), &vec![1.0, 0.0, f32::MAX, 2.0]);
        assert_eq!(gb.normal.as_ref().unwrap()[0], Vec3::new(0.0, -f32::MAX, 0.0));
        assert!(sanitize(&mut gb).is_empty(), "a second pass finds nothing");
    }

    /// Values in a few chunks of a plane of many: those chunks are fixed and counted, every other value is left as
    /// it was, bit for bit.
    #[test]
    fn fixes_only_the_chunks_that_need_it_and_counts_exactly() {
        let n = 5 * CHUNK + 77;
        let clean: Vec<f32> = (0..n).map(|i| (i as f32 * 0.37).sin() * 1e3).collect();
        let mut v = clean.clone();
        let bad =
            [(3, f32::NAN), (2 * CHUNK + 5, f32::INFINITY), (2 * CHUNK + 6, f32::NAN), (n - 1, f32::NEG_INFINITY)];
        for &(i, x) in &bad {
            v[i] = x;
        }
        assert_eq!(floats(&mut v), (2, 2));
        for i in 0..n {
            let want = match bad.iter().find(|b| b.0 == i) {
                Some((_, x)) if x.is_nan() => 0.0,
                Some((_, x)) => f32::MAX.copysign(*x),
                None => clean[i],
            };
            assert_eq!(v[i].to_bits(), want.to_bits(), "value {i}");
        }
        assert_eq!(floats(&mut v), (0, 0));
    }
}
