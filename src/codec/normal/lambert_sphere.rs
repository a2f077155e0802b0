//! Full-sphere Lambert equal-area map: each hemisphere by the Lambert azimuthal equal-area projection around its
//! own pole onto a disc, the disc onto the diamond |x| + |y| ≤ 1 by the concentric (Shirley–Chiu) map, and the
//! lower hemisphere folded over the diamond's edge into the square's corners as in octahedral encoding. Every
//! code cell covers the same solid angle.
//!
//! Sources: Lambert azimuthal equal-area, J. P. Snyder, "Map Projections — A Working Manual", USGS 1987,
//! pp. 182–190; the disc → square step, P. Shirley, K. Chiu, "A Low Distortion Map Between Disk and Square",
//! JGT 2(3), 1997; the whole construction (equal-area octahedral layout of the sphere) is the one of P. Clarberg,
//! "Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD", JGT 13(3), 2008. Cigolle et al., "A Survey of
//! Efficient Representations for Independent Unit Vectors", JCGT 3(2), 2014, evaluate a full-sphere "Lambert
//! equal-area" representation; we did not find their construction, and this one's worst case at 16 bits
//! (0.965°, every code cell enumerated by `codec::eval::cell_sweep`) is 4% below the 1.007° quoted for it
//! (docs/CODECS.md).
//!
//! Encode (n unit): `t = |n.xy| / √(1 + |n.z|)` (equal to √(1 − |n.z|), written without the cancellation near
//! the poles: the cap 1 − |z| ≤ t² is the fraction t² of its hemisphere, as the diamond of radius t is of the
//! diamond), `s = atan2(|n.y|, |n.x|)·2/π`, diamond point `t·(1 − s, s)` with the signs of n.x, n.y; fold if
//! n.z < 0. Decode: `t = |x| + |y|`, `φ = (π/2)·|y|/t`, `n = (t·√(2 − t²)·(cos φ, sin φ), ±(1 − t²))`, with
//! cos φ computed as sin((π/2)·|x|/t).
//!
//! Error bound: the decode map's largest stretch (largest singular value of its Jacobian, radians per unit of
//! plane distance) is L with L² = (8 + π²/4)/2 + √(((8 − π²/4)/2)² + π²), L ≈ 3.0691, reached on the equator
//! where it meets an axis (the diamond's vertices); the fold is an isometry, so a plane error (hx, hy) moves
//! the normal by at most L·√(hx² + hy²) (lambert-sphere-16 ≤ 0.979°). Domain: the whole sphere.
//! Zero, NaN and infinite input are cleaned by [`super::sanitize`] first (zero and NaN → +Z, the plane centre);
//! ±Z have no azimuth and take s = 0; −0.0 folds like +0.0 (`signNotZero`); −Z is the corner (1, 1) and
//! decodes exactly. Every code decodes to a finite unit vector.

use super::oct::Diamond;
use super::{sign_not_zero, Projection, Quant};
use crate::codec::TRANSCENDENTAL_OPS;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_2_PI, FRAC_PI_2};

/// Largest stretch of the [`LambertSphere`] decode map (radians per unit of plane distance), rounded up; see the
/// module doc for its closed form.
pub const LAMBERT_SPHERE_MAX_STRETCH: f32 = 3.0692;

/// Full-sphere Lambert equal-area map (plane coordinates in [−1, 1]², snorm).
#[derive(Clone, Copy, Debug, Default)]
pub struct LambertSphere;

impl LambertSphere {
    /// Unit vector → square point.
    #[inline(always)]
    #[must_use]
    pub fn project(n: Vec3) -> Vec2 {
        let (ax, ay) = (n.x.abs(), n.y.abs());
        let t = (n.x * n.x + n.y * n.y).sqrt() / (1.0 + n.z.abs()).sqrt();
        // f32 atan2 can give π/2 a hair above its true value: keep s in [0, 1].
        let s = (ay.atan2(ax) * FRAC_2_PI).min(1.0);
        Diamond { a: t * (1.0 - s), b: t * s, sx: sign_not_zero(n.x), sy: sign_not_zero(n.y), lower: n.z < 0.0 }
            .to_square()
    }

    /// Square point → (unit up to rounding) vector.
    #[inline(always)]
    #[must_use]
    pub fn unproject(p: Vec2) -> Vec3 {
        let d = Diamond::of_square(p);
        let t = (d.a + d.b).min(1.0);
        // cos φ as sin(π/2 − φ) = sin((π/2)·a/t): exact 0 and 1 on the axes (f32 cos(π/2) is −4e-8), and the
        // map is symmetric under swapping x and y bit for bit. At the pole the azimuth is undefined (r = 0).
        let (fa, fb) = if t > 0.0 { (d.a / t, d.b / t) } else { (0.0, 0.0) };
        let (cos, sin) = ((fa * FRAC_PI_2).sin(), (fb * FRAC_PI_2).sin());
        let t2 = t * t;
        let r = t * (2.0 - t2).sqrt();
        let z = 1.0 - t2;
        Vec3::new(d.sx * r * cos, d.sy * r * sin, if d.lower { -z } else { z })
    }
}

impl Projection for LambertSphere {
    fn scheme_name(&self, _q: Quant) -> &'static str {
        "lambert-sphere"
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        LambertSphere::project(n)
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        LambertSphere::unproject(p)
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::LambertSphere)
    }
    fn decode_ops(&self) -> u32 {
        // The fold (Diamond::OF_SQUARE_OPS); t = min(a + b, 1) (2); a/t, b/t behind t > 0 (2 div, compare,
        // 2 selects: 5); ·π/2 (2 mul); two sines (2 transcendentals); t², r = t·√(2 − t²) (mul, sub, sqrt,
        // mul: 4); z = 1 − t² and its sign select (sub, neg, select: 3); x = sx·r·cos, y = sy·r·sin (4 mul).
        Diamond::OF_SQUARE_OPS + 2 + 5 + 2 + 2 * TRANSCENDENTAL_OPS + 4 + 3 + 4
    }
    fn bound_rad(&self, hx: f32, hy: f32, _q: Quant) -> f32 {
        LAMBERT_SPHERE_MAX_STRETCH * hx.hypot(hy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::normal::{angle_deg, finish, sanitize};

    /// f32 round trip of the continuous map (no quantization), degrees.
    const ROUND_TRIP_DEG: f32 = 2e-3;

    #[test]
    fn closed_form_stretch_matches_the_constant() {
        let (a, c, b) = (8.0f64, std::f64::consts::PI.powi(2) / 4.0, std::f64::consts::PI);
        let l = ((a + c) / 2.0 + (((a - c) / 2.0).powi(2) + b * b).sqrt()).sqrt();
        assert!(l <= f64::from(LAMBERT_SPHERE_MAX_STRETCH) && l > f64::from(LAMBERT_SPHERE_MAX_STRETCH) - 1e-4, "{l}");
    }

    #[test]
    fn poles_equator_and_folds() {
        super::super::oct::assert_octahedral_layout(LambertSphere::project, LambertSphere::unproject);
    }

    #[test]
    fn round_trip_of_the_continuous_map() {
        let mut rng = crate::base::rng::SplitMix64::new(21);
        for _ in 0..50_000 {
            let n = sanitize(Vec3::new(rng.range_f32(-1., 1.), rng.range_f32(-1., 1.), rng.range_f32(-1., 1.)));
            let p = LambertSphere::project(n);
            assert!(p.abs().max_element() <= 1.0, "{n} → {p}");
            let back = finish(LambertSphere::unproject(p));
            assert!(angle_deg(n, back) < ROUND_TRIP_DEG, "{n} → {p} → {back}");
        }
    }

    /// Equal area: on a regular grid of the square every cell's image has the same solid angle (4π / cells).
    /// Each cell is measured as a fine mesh of geodesic triangles, which follows its curved edges.
    #[test]
    fn every_cell_covers_the_same_solid_angle() {
        let (g, sub) = (16, 24);
        let n = g * sub;
        let at = |i: usize, j: usize| {
            let p = Vec2::new(i as f32, j as f32) / n as f32 * 2.0 - 1.0;
            finish(LambertSphere::unproject(p)).as_dvec3()
        };
        let tri = |a: glam::DVec3, b: glam::DVec3, c: glam::DVec3| {
            2.0 * a.dot(b.cross(c)).abs().atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a))
        };
        let expected = 4.0 * std::f64::consts::PI / (g * g) as f64;
        let (mut total, mut worst) = (0.0, 0.0f64);
        for ci in 0..g {
            for cj in 0..g {
                let mut area = 0.0;
                for i in ci * sub..(ci + 1) * sub {
                    for j in cj * sub..(cj + 1) * sub {
                        let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                        area += tri(a, b, c) + tri(a, c, d);
                    }
                }
                total += area;
                worst = worst.max((area / expected - 1.0).abs());
            }
        }
        assert!((total / (4.0 * std::f64::consts::PI) - 1.0).abs() < 1e-4, "total {total}");
        assert!(worst < 2e-3, "cell areas vary by {worst}");
    }

    /// The largest stretch, measured by finite differences on a fine grid, stays under the constant and
    /// comes close to it (so the bound is not loose).
    #[test]
    fn measured_stretch_is_under_the_constant() {
        let eps = 1e-3f64;
        let dec = |u: f64, v: f64| finish(LambertSphere::unproject(Vec2::new(u as f32, v as f32))).as_dvec3();
        let mut most = 0.0f64;
        let g = 200;
        for i in 0..=g {
            for j in 0..=g {
                let (u, v) = (-1.0 + 2.0 * i as f64 / g as f64, -1.0 + 2.0 * j as f64 / g as f64);
                let c = dec(u, v);
                for k in 0..64 {
                    let a = k as f64 * std::f64::consts::PI / 32.0;
                    let (du, dv) = (eps * a.cos(), eps * a.sin());
                    let (pu, pv) = (u + du, v + dv);
                    if pu.abs() > 1.0 || pv.abs() > 1.0 {
                        continue;
                    }
                    let d = dec(pu, pv);
                    most = most.max(c.cross(d).length().atan2(c.dot(d)) / eps);
                }
            }
        }
        assert!(most <= f64::from(LAMBERT_SPHERE_MAX_STRETCH) * 1.001, "stretch {most}");
        assert!(most > f64::from(LAMBERT_SPHERE_MAX_STRETCH) * 0.97, "stretch {most}");
    }
}
