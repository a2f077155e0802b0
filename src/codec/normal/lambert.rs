//! Lambert azimuthal equal-area projection centred on +Z (the view-facing direction).
//!
//! Sources: J. P. Snyder, "Map Projections — A Working Manual", USGS 1987, p. 182; used for G-buffer normals by
//! Pranckevičius, "Compact Normal Storage for Small G-Buffers" (2009, method #4). We scale the disc of radius 2
//! to the unit disc: `q = normalize(n.xy)·√((1−n.z)/2)` (computed as `n.xy/√(2(1+n.z))` on z ≥ 0, where it
//! is the same value without cancellation), decode `s = |q|²`, `n = (2·q·√(1−s), 1−2s)`.
//! It equals the CryEngine 3 spheremap of the z-mirrored normal (`lambert(n) = cry(n.x, n.y, −n.z)`), tested.
//!
//! Error bound: the equal-area map's radial stretch grows without limit at the rim, which here is −Z (facing away
//! from the camera, rarely visible); on the front hemisphere z ≥ 0 the stretch is ≤ 2√2. Bound over the whole
//! sphere: 2·acos(1−h) + 2h with h = √(hx²+hy²) (lambert-16 ≤ 12.7°, measured 11.3° near −Z but only 0.89° on z ≥ 0).
//! −Z encodes to q = (1, 0) (its direction is undefined, we pick +X) and decodes exactly.
//! Domain: the whole sphere.

use super::spheremap::equal_area_bound;
use super::{normalize2_or_x, Projection, Quant};
use glam::{Vec2, Vec3};

/// Lambert azimuthal equal-area centred on +Z (plane coordinates in the unit disc, snorm or f16).
#[derive(Clone, Copy, Debug, Default)]
pub struct Lambert;

impl Lambert {
    /// Unit vector → point in the unit disc.
    #[inline(always)]
    #[must_use]
    pub fn project(n: Vec3) -> Vec2 {
        let xy = Vec2::new(n.x, n.y);
        if n.z >= 0.0 {
            // Same value, but stable near +Z where 1 − z has lost every digit: |q| = |xy| / √(2(1+z)).
            xy / (2.0 * (1.0 + n.z)).sqrt()
        } else {
            normalize2_or_x(xy) * ((1.0 - n.z) * 0.5).max(0.0).sqrt()
        }
    }

    /// Point in the unit disc → unit vector (outside the disc counts as the rim).
    #[inline(always)]
    #[must_use]
    pub fn unproject(q: Vec2) -> Vec3 {
        let s = q.length_squared().min(1.0);
        let xy = q * (2.0 * (1.0 - s).sqrt());
        Vec3::new(xy.x, xy.y, 1.0 - 2.0 * s)
    }
}

impl Projection for Lambert {
    fn scheme_name(&self, q: Quant) -> &'static str {
        if q == Quant::F16 {
            "lambert-f16"
        } else {
            "lambert"
        }
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        Lambert::project(n)
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        Lambert::unproject(p)
    }
    fn decode_ops(&self) -> u32 {
        // s = min(|q|², 1) (4); q·2√(1 − s) (sub, sqrt, mul, 2 mul: 5); 1 − 2s (2).
        11
    }
    fn bound_rad(&self, hx: f32, hy: f32, _q: Quant) -> f32 {
        equal_area_bound(hx.hypot(hy))
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::Lambert)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::normal::{angle_deg, finish, sanitize, SpheremapCry};

    /// f32 rounding of the two formulations (see the spheremap agreement test for why this size).
    const AGREE_DEG: f32 = 0.05;
    /// Mittring's literal `sqrt(n.z·0.5+0.5)` cancels near its centre: an f32 rounding δ ≈ 6e-8 under the
    /// root is up to √δ ≈ 2.4e-4 in |g|.
    const PLANE_AGREE: f32 = 3e-4;

    #[test]
    fn lambert_is_the_z_mirrored_cry_spheremap() {
        let mut rng = crate::base::rng::SplitMix64::new(11);
        for _ in 0..50_000 {
            let n = sanitize(Vec3::new(rng.range_f32(-1., 1.), rng.range_f32(-1., 1.), rng.range_f32(-1., 1.)));
            let mirrored = Vec3::new(n.x, n.y, -n.z);
            let q = Lambert::project(n);
            let g = SpheremapCry::project(mirrored);
            assert!((q - g).length() < PLANE_AGREE, "{n}: lambert {q} vs cry {g}");
            let a = finish(Lambert::unproject(q));
            let b = finish(SpheremapCry::unproject(q));
            assert!(angle_deg(a, Vec3::new(b.x, b.y, -b.z)) < AGREE_DEG, "{q}: {a} vs mirrored {b}");
            assert!(angle_deg(a, n) < AGREE_DEG, "{n}: round trip {a}");
        }
    }

    #[test]
    fn poles() {
        assert_eq!(finish(Lambert::unproject(Lambert::project(Vec3::Z))), Vec3::Z);
        assert_eq!(finish(Lambert::unproject(Lambert::project(Vec3::NEG_Z))), Vec3::NEG_Z);
    }
}
