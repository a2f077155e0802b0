//! Distance and cone attenuation of punctual lights, written once in f64 as the reference definition; the batched
//! f32 kernel (`kernel.rs`) evaluates the same formulas with per-light constants precomputed in `lights.rs`.
//!
//! - `gltf` (KHR_lights_punctual): `clamp(1 − (d/range)⁴, 0, 1)² / d²`; an unbounded light (`range = ∞`) is a
//!   plain inverse square.
//! - `linear` (the 2010 tiled-deferred demo and the ISPC `deferred` example):
//!   `clamp((end − d)/(end − begin), 0, 1)` with `end` = the light's range; zero at and beyond `end`. When
//!   `begin = end` the ramp would divide by zero: its width is floored at [`MIN_RAMP_FRACTION`] × `end`, which makes
//!   it a step (full intensity inside `end`, as the demo's `min(x/0, 1)` does). Unbounded lights get no falloff.
//! - spot cones (glTF): `clamp((cos θ − cos outer)/max(cos inner − cos outer, 0.001), 0, 1)²`.
//!
//! Every distance is first clamped to [`MIN_DISTANCE`] so a light sitting on a surface gives a large but finite
//! value, never Inf or NaN.

use super::config::Falloff;

/// Smallest light-to-surface distance used in the falloff (view-space units). A light closer than this behaves as
/// if it were at this distance; this bounds the inverse square at 10⁸ · intensity.
pub const MIN_DISTANCE: f32 = 1e-4;

/// The linear ramp's width is at least this fraction of `end` (so `begin = end` is a step, not a division by 0).
pub const MIN_RAMP_FRACTION: f32 = 1e-6;

/// glTF's minimum `cos inner − cos outer` (KHR_lights_punctual reference code).
pub const MIN_CONE_COS_DELTA: f32 = 0.001;

/// Reference glTF falloff at distance `d` (already ≥ [`MIN_DISTANCE`]) for a light of `range` (may be ∞).
#[must_use]
#[cfg_attr(not(test), allow(dead_code))] // the definition the reference's lanes are tested against
pub fn gltf(d: f64, range: f64) -> f64 {
    let inv_r4 = if range.is_finite() { 1.0 / range.powi(4) } else { 0.0 };
    let window = (1.0 - d.powi(4) * inv_r4).clamp(0.0, 1.0);
    window * window / (d * d)
}

/// Reference linear falloff at distance `d` between `begin` and `end` (may be ∞: no falloff).
#[must_use]
#[cfg_attr(not(test), allow(dead_code))] // the definition the reference's lanes are tested against
pub fn linear(d: f64, begin: f64, end: f64) -> f64 {
    if !end.is_finite() {
        return 1.0;
    }
    let width = (end - begin).max(end * f64::from(MIN_RAMP_FRACTION));
    ((end - d) / width).clamp(0.0, 1.0)
}

/// Reference distance falloff for `falloff`; `d` is clamped to [`MIN_DISTANCE`] here.
#[must_use]
#[cfg_attr(not(test), allow(dead_code))] // the definition the reference's lanes are tested against
pub fn attenuation(falloff: Falloff, d: f64, begin: f64, end: f64) -> f64 {
    let d = d.max(f64::from(MIN_DISTANCE));
    match falloff {
        Falloff::Gltf => gltf(d, end),
        Falloff::Linear => linear(d, begin, end),
    }
}

/// glTF spot-cone constants `(scale, offset)`: the factor is `clamp(cos θ · scale + offset, 0, 1)²`.
#[must_use]
pub fn cone_constants(inner: f32, outer: f32) -> (f32, f32) {
    let (ci, co) = (inner.cos(), outer.cos());
    let scale = 1.0 / (ci - co).max(MIN_CONE_COS_DELTA);
    (scale, -co * scale)
}

/// Reference spot factor for the cosine of the angle between the spot axis and the light-to-surface direction.
#[must_use]
#[cfg_attr(not(test), allow(dead_code))] // the definition the reference's lanes are tested against
pub fn spot(cos_theta: f64, scale: f64, offset: f64) -> f64 {
    let t = (cos_theta * scale + offset).clamp(0.0, 1.0);
    t * t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gltf_is_inverse_square_inside_and_zero_outside_range() {
        let near = gltf(1.0, 100.0);
        assert!((near - 1.0).abs() < 1e-7, "{near}");
        assert!((gltf(2.0, f64::INFINITY) - 0.25).abs() < 1e-15);
        assert_eq!(gltf(100.0, 100.0), 0.0);
        assert_eq!(gltf(150.0, 100.0), 0.0);
        let a = attenuation(Falloff::Gltf, 0.0, 0.0, 5.0);
        assert!(a.is_finite() && a > 1e7, "{a}");
    }

    #[test]
    fn linear_ramps_and_steps() {
        assert_eq!(linear(0.5, 1.0, 3.0), 1.0);
        assert!((linear(2.0, 1.0, 3.0) - 0.5).abs() < 1e-12);
        assert_eq!(linear(3.0, 1.0, 3.0), 0.0);
        assert_eq!(linear(9.0, 1.0, 3.0), 0.0);
        // begin = end: a step at end, finite everywhere.
        assert_eq!(linear(2.999, 3.0, 3.0), 1.0);
        assert_eq!(linear(3.0, 3.0, 3.0), 0.0);
        assert_eq!(linear(1e9, 0.0, f64::INFINITY), 1.0);
        assert!(attenuation(Falloff::Linear, 0.0, 2.0, 2.0).is_finite());
    }

    #[test]
    fn spot_cone_is_one_inside_inner_and_zero_outside_outer() {
        let (s, o) = cone_constants(0.3, 0.5);
        let (s, o) = (f64::from(s), f64::from(o));
        assert!((spot(0.2f64.cos(), s, o) - 1.0).abs() < 1e-6);
        assert_eq!(spot(0.6f64.cos(), s, o), 0.0);
        let mid = spot(0.4f64.cos(), s, o);
        assert!(mid > 0.0 && mid < 1.0);
        // inner = outer does not divide by zero.
        let (s, o) = cone_constants(0.4, 0.4);
        assert!(s.is_finite() && o.is_finite());
    }
}
