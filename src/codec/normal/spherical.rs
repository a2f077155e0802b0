//! Spherical angles: polar angle θ from +Z and azimuth φ, each stored as unorm.
//!
//! Source: the textbook parameterisation; as a G-buffer encoding, Pranckevičius, "Compact Normal Storage for Small
//! G-Buffers" (2009, method #3). `u = θ/π` with θ = atan2(|n.xy|, n.z) (not acos(n.z), which loses everything
//! near the poles in f32), `v = (φ + π)/(2π)` with φ = atan2(n.y, n.x) (both ±π mean the same direction).
//! At the poles φ is undefined; atan2(±0, ±0) gives a fixed value and the decode is exact regardless (the
//! south-pole row decodes to exactly −Z, and the azimuth seam v = 1 decodes like v = 0), which keeps
//! decode∘encode∘decode = decode exact.
//!
//! Error bound: ∂n/∂u = π, ∂n/∂v = 2π·sin θ ≤ 2π, so the error is ≤ √((π·hu)² + (2π·hv)²)
//! (spherical-16 ≤ 0.79°). Domain: the whole sphere.

use super::{Projection, Quant};
use crate::codec::TRANSCENDENTAL_OPS;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// (θ/π, (φ+π)/2π) in [0, 1]², unorm.
#[derive(Clone, Copy, Debug, Default)]
pub struct Spherical;

impl Projection for Spherical {
    fn scheme_name(&self, _q: Quant) -> &'static str {
        "spherical"
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        let theta = Vec2::new(n.x, n.y).length().atan2(n.z);
        let phi = n.y.atan2(n.x);
        Vec2::new(theta / PI, (phi + PI) / TAU)
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        // sin(π) is not 0 in f32: snap the south pole so that every code on it decodes to exactly −Z.
        if p.x >= 1.0 {
            return Vec3::NEG_Z;
        }
        let theta = p.x.max(0.0) * PI;
        // v = 1 and v = 0 are the same azimuth (±π); decode both through v = 0 so they agree bit for bit.
        let v = if p.y >= 1.0 { 0.0 } else { p.y.max(0.0) };
        let phi = v * TAU - PI;
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        Vec3::new(st * cp, st * sp, ct)
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::Spherical)
    }
    fn decode_ops(&self) -> u32 {
        // South-pole test and its select of x, y, z (4); θ = max(u, 0)·π (2); v: compare, max, select (3);
        // φ = v·2π − π (2); sin and cos of θ and of φ (4 transcendentals); st·cp, st·sp (2).
        4 + 2 + 3 + 2 + 4 * TRANSCENDENTAL_OPS + 2
    }
    fn bound_rad(&self, hx: f32, hy: f32, _q: Quant) -> f32 {
        (PI * hx).hypot(TAU * hy)
    }
}
