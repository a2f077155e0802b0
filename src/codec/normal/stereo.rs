//! Stereographic projection from the −Z pole onto the plane z = 0.
//!
//! Sources: Snyder 1987 (p. 154); as a G-buffer encoding, Pranckevičius, "Compact Normal Storage for Small
//! G-Buffers" (2009, method #7), scale 1.7777. `P = n.xy / (1 + n.z)` (|P| = tan(θ/2), θ from +Z),
//! stored as `P / S`; decode `n = (2P, 1 − |P|²) / (1 + |P|²)`. We compute |P| as `(1 − z)/|xy|` on the lower
//! hemisphere, which stays accurate near −Z.
//!
//! Two storages: `stereo-N` (snorm, S = 1.7777): the square covers θ ≤ 2·atan(S) (z ≥ −0.52, the domain)
//! fully; points further back are moved radially onto the square's edge (defined, but off by up to 180° at −Z).
//! Inside the domain the map is conformal with stretch ≤ 2S, so the error is ≤ 2S·√(hx²+hy²)
//! (stereo-16 ≤ 1.13°). `stereo-f16-32` (S = 1, no clamp below 65504): the whole sphere, error ≤ 2^-11·√2 rad
//! plus 2/65504 rad for the last sliver around −Z.

use super::{normalize2_or_x, Projection, Quant, F16_MAX};
use glam::{Vec2, Vec3};

/// Stereographic projection with a scale.
#[derive(Clone, Copy, Debug)]
pub struct Stereo {
    scale: f32,
}

impl Stereo {
    /// Pranckevičius's scale 1.7777, for snorm storage.
    pub const SCALED: Stereo = Stereo { scale: 1.7777 };
    /// Unit scale, for f16 storage.
    pub const UNSCALED: Stereo = Stereo { scale: 1.0 };

    /// tan(θ/2) along the direction of n.xy, divided by the scale (unclamped; may be huge near −Z).
    #[inline(always)]
    #[must_use]
    pub fn project_unclamped(self, n: Vec3) -> Vec2 {
        let xy = Vec2::new(n.x, n.y);
        let r = xy.length();
        let front = xy / ((1.0 + n.z) * self.scale);
        let back = normalize2_or_x(xy) * ((1.0 - n.z) / r / self.scale).min(F16_MAX);
        if n.z >= 0.0 {
            front
        } else if r > 0.0 {
            back
        } else {
            Vec2::new(F16_MAX, 0.0)
        }
    }
}

impl Projection for Stereo {
    fn scheme_name(&self, q: Quant) -> &'static str {
        if q == Quant::F16 {
            "stereo-f16"
        } else {
            "stereo"
        }
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        let p = self.project_unclamped(n);
        // Radial clamp onto the square [-1, 1]² for the snorm variant (scale ≠ 1), onto f16 range otherwise.
        let limit = if self.scale == 1.0 { F16_MAX } else { 1.0 };
        let m = p.abs().max_element();
        if m > limit {
            p * (limit / m)
        } else {
            p
        }
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        let p = p * self.scale;
        let r2 = p.length_squared();
        let d = 1.0 + r2;
        let v = Vec3::new(2.0 * p.x / d, 2.0 * p.y / d, (1.0 - r2) / d);
        if r2.is_finite() {
            v
        } else {
            Vec3::NEG_Z
        }
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::Stereo { scaled: self.scale != 1.0 })
    }
    fn decode_ops(&self) -> u32 {
        // p·S (2); r² (3); d = 1 + r² (1); 2x/d, 2y/d (4); (1 − r²)/d (2); is_finite and its select of x, y, z (4).
        16
    }
    fn bound_rad(&self, hx: f32, hy: f32, q: Quant) -> f32 {
        if q == Quant::F16 {
            // Relative rounding: |dP| ≤ |P|·2^-11·√2 and the angular stretch at |P| is 2/(1+|P|²).
            2f32.powi(-11) * std::f32::consts::SQRT_2 + 2.0 / F16_MAX
        } else {
            2.0 * self.scale * hx.hypot(hy)
        }
    }
    fn in_domain(&self, n: Vec3) -> bool {
        if self.scale == 1.0 {
            return true;
        }
        // θ ≤ 2·atan(S)  ⇔  z ≥ (1 − S²)/(1 + S²).
        let s2 = self.scale * self.scale;
        n.z >= (1.0 - s2) / (1.0 + s2) + 1e-4
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::normal::{angle_deg, finish, sanitize};

    #[test]
    fn unclamped_round_trip_is_accurate_even_near_the_back_pole() {
        let s = Stereo::UNSCALED;
        for z in [-1.0 + 1e-7, -0.999_999, -0.9, 0.0, 0.5, 1.0] {
            let n = sanitize(Vec3::new((1.0f32 - z * z).max(0.0).sqrt(), 0.0, z));
            let back = finish(s.decode_plane(s.encode_plane(n)));
            assert!(angle_deg(n, back) < 0.01, "{n}: {back}");
        }
        assert_eq!(finish(s.decode_plane(s.encode_plane(Vec3::NEG_Z))).z, -1.0);
    }
}
