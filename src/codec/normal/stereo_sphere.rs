//! Full-sphere stereographic map: each hemisphere by the stereographic projection from the opposite pole onto
//! the unit disc, the disc onto the diamond |x| + |y| ≤ 1 by stretching each radius (the direction is kept), and
//! the lower hemisphere folded over the diamond's edge into the square's corners as in octahedral encoding.
//! No trigonometry either way.
//!
//! Sources: the stereographic projection, J. P. Snyder, "Map Projections — A Working Manual", USGS 1987,
//! pp. 154–163 (as a G-buffer encoding of the front hemisphere: Pranckevičius 2009, method #7, our `stereo`);
//! the fold, Meyer et al. 2010 / Cigolle et al. 2014 (see [`super::Oct`]). Cigolle et al., "A Survey of
//! Efficient Representations for Independent Unit Vectors", JCGT 3(2), 2014, evaluate a full-sphere stereographic
//! representation whose 16-bit worst case is quoted as 1.008°; we did not find their construction. This one was
//! chosen among the candidates (disc → diamond radially or concentrically, docs/CODECS.md) because its worst
//! case at 16 bits, every code cell enumerated by `codec::eval::cell_sweep`, is 1.004°, within 0.4% of it.
//!
//! Encode (n unit): `t = |n.xy| / (1 + |n.z|)` (= tan(θ/2), θ the angle from the nearer pole, ≤ 90°, so
//! t ≤ 1), diamond point `t·(|n.x|, |n.y|) / (|n.x| + |n.y|)` with the signs of n.x, n.y; fold if n.z < 0.
//! Decode: `t = |x| + |y|`, direction `d = (x, y)/|(x, y)|`, `n ∝ (2t·d, ±(1 − t²))` (length 1 + t²; the
//! final normalisation every decoder does replaces the division).
//!
//! Error bound: the decode map's largest stretch (largest singular value of its Jacobian) is 2/(1 + t²) from
//! the projection times the radial stretch's √(8/3) (reached where (cos α + sin α)² = 4/3 for the azimuth α
//! within the quadrant), so L = 4·√(2/3) ≈ 3.2660 at the poles; the fold is an isometry, so a plane error
//! (hx, hy) moves the normal by at most L·√(hx² + hy²) (stereo-sphere-16 ≤ 1.042°). Domain: the whole sphere.
//! Zero, NaN and infinite input are cleaned by [`super::sanitize`] first (zero and NaN → +Z, the plane centre);
//! ±Z have no direction and go to the centre / the corner (1, 1); −0.0 folds like +0.0 (`signNotZero`). Every
//! code decodes to a finite unit vector.

use super::oct::Diamond;
use super::{sign_not_zero, Projection, Quant};
use glam::{Vec2, Vec3};

/// Largest stretch of the [`StereoSphere`] decode map, 4·√(2/3), rounded up.
pub const STEREO_SPHERE_MAX_STRETCH: f32 = 3.2660;

/// Full-sphere stereographic map (plane coordinates in [−1, 1]², snorm).
#[derive(Clone, Copy, Debug, Default)]
pub struct StereoSphere;

impl StereoSphere {
    /// Unit vector → square point.
    #[inline(always)]
    #[must_use]
    pub fn project(n: Vec3) -> Vec2 {
        let (ax, ay) = (n.x.abs(), n.y.abs());
        let l1 = ax + ay;
        let t = (n.x * n.x + n.y * n.y).sqrt() / (1.0 + n.z.abs());
        // ±Z (l1 = 0) have no direction: the centre of the diamond.
        let k = if l1 > 0.0 { t / l1 } else { 0.0 };
        Diamond { a: ax * k, b: ay * k, sx: sign_not_zero(n.x), sy: sign_not_zero(n.y), lower: n.z < 0.0 }.to_square()
    }

    /// Square point → vector of length 1 + t² (up to rounding).
    #[inline(always)]
    #[must_use]
    pub fn unproject(p: Vec2) -> Vec3 {
        let d = Diamond::of_square(p);
        let t = (d.a + d.b).min(1.0);
        let rr = (d.a * d.a + d.b * d.b).sqrt();
        let k = if rr > 0.0 { 2.0 * t / rr } else { 0.0 };
        let z = 1.0 - t * t;
        Vec3::new(d.sx * d.a * k, d.sy * d.b * k, if d.lower { -z } else { z })
    }
}

impl Projection for StereoSphere {
    fn scheme_name(&self, _q: Quant) -> &'static str {
        "stereo-sphere"
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        StereoSphere::project(n)
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        StereoSphere::unproject(p)
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::StereoSphere)
    }
    fn decode_ops(&self) -> u32 {
        // The fold (Diamond::OF_SQUARE_OPS); t = min(a + b, 1) (2); |(a, b)| (2 mul, add, sqrt: 4);
        // k = 2t/|(a, b)| behind > 0 (mul, div, compare, select: 4); x = sx·a·k, y = sy·b·k (4 mul);
        // z = 1 − t² and its sign select (mul, sub, neg, select: 4).
        Diamond::OF_SQUARE_OPS + 2 + 4 + 4 + 4 + 4
    }
    fn bound_rad(&self, hx: f32, hy: f32, _q: Quant) -> f32 {
        STEREO_SPHERE_MAX_STRETCH * hx.hypot(hy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::normal::{angle_deg, finish, sanitize};

    /// f32 round trip of the continuous map (no quantization), degrees.
    const ROUND_TRIP_DEG: f32 = 2e-3;

    #[test]
    fn stretch_constant_is_the_closed_form() {
        let l = 4.0 * (2.0f64 / 3.0).sqrt();
        assert!(l <= f64::from(STEREO_SPHERE_MAX_STRETCH) && l > f64::from(STEREO_SPHERE_MAX_STRETCH) - 1e-4, "{l}");
    }

    #[test]
    fn poles_equator_and_folds() {
        super::super::oct::assert_octahedral_layout(StereoSphere::project, StereoSphere::unproject);
        // Stereographic: 60° from the pole is at radius tan(30°).
        let n = Vec3::new(60f32.to_radians().sin(), 0.0, 60f32.to_radians().cos());
        assert!((StereoSphere::project(n).x - 30f32.to_radians().tan()).abs() < 1e-6);
    }

    #[test]
    fn round_trip_of_the_continuous_map() {
        let mut rng = crate::base::rng::SplitMix64::new(22);
        for _ in 0..50_000 {
            let n = sanitize(Vec3::new(rng.range_f32(-1., 1.), rng.range_f32(-1., 1.), rng.range_f32(-1., 1.)));
            let p = StereoSphere::project(n);
            assert!(p.abs().max_element() <= 1.0, "{n} → {p}");
            let back = finish(StereoSphere::unproject(p));
            assert!(angle_deg(n, back) < ROUND_TRIP_DEG, "{n} → {p} → {back}");
        }
    }

    /// The largest stretch, by finite differences on a fine grid, stays under the constant and comes close to
    /// it near the poles.
    #[test]
    fn measured_stretch_is_under_the_constant() {
        let eps = 1e-3f64;
        let dec = |u: f64, v: f64| finish(StereoSphere::unproject(Vec2::new(u as f32, v as f32))).as_dvec3();
        let mut most = 0.0f64;
        let g = 200;
        for i in 0..=g {
            for j in 0..=g {
                let (u, v) = (-1.0 + 2.0 * i as f64 / g as f64, -1.0 + 2.0 * j as f64 / g as f64);
                let c = dec(u, v);
                for k in 0..64 {
                    let a = k as f64 * std::f64::consts::PI / 32.0;
                    let (pu, pv) = (u + eps * a.cos(), v + eps * a.sin());
                    if pu.abs() > 1.0 || pv.abs() > 1.0 {
                        continue;
                    }
                    let d = dec(pu, pv);
                    most = most.max(c.cross(d).length().atan2(c.dot(d)) / eps);
                }
            }
        }
        assert!(most <= f64::from(STEREO_SPHERE_MAX_STRETCH) * 1.001, "stretch {most}");
        assert!(most > f64::from(STEREO_SPHERE_MAX_STRETCH) * 0.97, "stretch {most}");
    }
}
