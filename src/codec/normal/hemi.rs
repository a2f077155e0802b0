//! xy with reconstructed z: store n.x and n.y, rebuild `n.z = +√(1 − x² − y²)`. **Hemisphere only.**
//!
//! Source: the classic two-channel normal (e.g. Killzone 2's FP16 normal x/y, Valient, "Deferred Rendering in
//! Killzone 2", Develop 2007; Pranckevičius 2009, method #1). It is only correct on the hemisphere z ≥ 0: a
//! normal with z < 0 decodes mirrored to +z (what the GPU shader does), an error of twice its elevation below
//! the horizon — (0, 0, −1) decodes as +Z. View-space normals of visible surfaces mostly face the camera, but
//! with perspective some visible normals do have z < 0, which is why engines moved away from it.
//!
//! Error bound on the domain z ≥ 0: reconstructing z is ill-conditioned at the horizon, where a radial error h
//! costs acos(1 − h); with the lateral part: acos(1 − h) + h, h = √(hx²+hy²) (xy-hemi-16 ≤ 6.4°).
//! Quantized points with x² + y² > 1 (which rounding does produce near the horizon) decode onto the horizon,
//! renormalised; re-encoding that horizon vector can land on a neighbouring code, so the codec is not
//! idempotent there (the exhaustive test holds the move to the bound instead).

use super::{Projection, Quant};
use glam::{Vec2, Vec3};

/// (n.x, n.y) in [−1, 1]², snorm or f16.
#[derive(Clone, Copy, Debug, Default)]
pub struct XyHemi;

impl Projection for XyHemi {
    fn scheme_name(&self, q: Quant) -> &'static str {
        if q == Quant::F16 {
            "xy-hemi-f16"
        } else {
            "xy-hemi"
        }
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        Vec2::new(n.x, n.y)
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        let p = p.clamp(Vec2::NEG_ONE, Vec2::ONE);
        Vec3::new(p.x, p.y, (1.0 - p.length_squared()).max(0.0).sqrt())
    }
    fn decode_ops(&self) -> u32 {
        // clamp ×2; z = √max(1 − |p|², 0) (2 mul, add, sub, max, sqrt).
        8
    }
    fn bound_rad(&self, hx: f32, hy: f32, _q: Quant) -> f32 {
        let h = hx.hypot(hy);
        (1.0 - h).max(-1.0).acos() + h
    }
    fn in_domain(&self, n: Vec3) -> bool {
        n.z >= 0.0
    }
    fn is_idempotent(&self, _q: Quant) -> bool {
        false
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::XyHemi)
    }
}
