//! The spheremap transform as CryEngine 3 ships it, and the same map as Intel's ISPC deferred sample decodes it.
//!
//! Source: Martin Mittring, "A bit more Deferred – CryEngine 3", Triangle Game Conference 2009:
//! encode `g = normalize(n.xy)·sqrt(n.z·0.5+0.5)`, decode `n.z = |g|²·2−1`, `n.xy = normalize(g)·sqrt(1−n.z²)`.
//! It is the Lambert azimuthal equal-area projection centred on **−Z**, scaled into the unit disc
//! (`g(n) = lambert(n.x, n.y, −n.z)`, see [`super::Lambert`]): +Z (facing the camera) lands on the rim |g| = 1,
//! −Z on the centre. ISPC (Lauritzen, "Deferred Rendering for Current and Future Rendering Pipelines",
//! SIGGRAPH 2010, `deferred` sample, `ComputeNormal`) stores `e = g·0.5+0.5` as unorm and decodes
//! `f = (x−x²)+(y−y²)`, `m = √(4f−1)`, `n = (m(4x−2), m(4y−2), 3−8f)` — algebraically the same map.
//!
//! Orientation matters: Mittring's view space is Direct3D's (+Z forward), where visible normals have n.z < 0 and
//! land near the well-conditioned centre. In gbuf's view space (−Z forward, see [`crate::gbuffer`]) the literal
//! formula puts the visible normals on the rim, where it is worst; the z-mirrored map, which is what CryEngine
//! effectively gets, is our [`super::Lambert`] (0.89° max on z ≥ 0 at 16 bits instead of 11.6°).
//!
//! We keep Mittring's formulas literally; in f32 they cancel near −Z (`n.z·0.5+0.5`, `1−n.z²`): a decoded
//! (3e-4, 0, −0.99999994) re-encodes to exactly −Z. Snorm codes never get that close to the centre; the f16
//! storage does, and is therefore not exactly idempotent there (within the bound).
//!
//! Singularities and defined results: `normalize(n.xy)` is undefined at both poles; we use +X there (so +Z
//! encodes to g = (1, 0) and decodes exactly, and −Z to g = 0). The decoder at g = 0 returns exactly −Z.
//!
//! Error bound: the azimuthal stretch is ≤ 2, but the radial one grows without limit at the rim (the
//! view-facing direction): a radial error h there costs 2·acos(1−h). Bound: 2·acos(1−h) + 2h with
//! h = √(hx²+hy²) — loose away from +Z; e.g. spheremap-cry-16 ≤ 12.7°, measured 11.6° near +Z (see
//! docs/CODECS.md). Domain: the whole sphere.

use super::{normalize2_or_x, Projection, Quant, NORMALIZE2_OPS};
use glam::{Vec2, Vec3};

/// CryEngine 3 spheremap (plane coordinates g in the unit disc, snorm or f16).
#[derive(Clone, Copy, Debug, Default)]
pub struct SpheremapCry;

impl SpheremapCry {
    /// Mittring's encode, with +X as the direction where `normalize(n.xy)` is undefined.
    #[inline(always)]
    #[must_use]
    pub fn project(n: Vec3) -> Vec2 {
        normalize2_or_x(Vec2::new(n.x, n.y)) * (n.z * 0.5 + 0.5).max(0.0).sqrt()
    }

    /// Mittring's decode (g outside the unit disc is treated as on the rim).
    #[inline(always)]
    #[must_use]
    pub fn unproject(g: Vec2) -> Vec3 {
        let z = (g.length_squared() * 2.0 - 1.0).clamp(-1.0, 1.0);
        let r = (1.0 - z * z).max(0.0).sqrt();
        let xy = normalize2_or_x(g) * r;
        if g == Vec2::ZERO {
            Vec3::NEG_Z
        } else {
            Vec3::new(xy.x, xy.y, z)
        }
    }
}

/// The rim-dominated bound shared by the two equal-area spheremaps (radians; see the module doc).
#[must_use]
pub fn equal_area_bound(h: f32) -> f32 {
    2.0 * (1.0 - h).max(-1.0).acos() + 2.0 * h
}

impl Projection for SpheremapCry {
    fn scheme_name(&self, q: Quant) -> &'static str {
        if q == Quant::F16 {
            "spheremap-cry-f16"
        } else {
            "spheremap-cry"
        }
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        SpheremapCry::project(n)
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        SpheremapCry::unproject(p)
    }
    fn decode_ops(&self) -> u32 {
        // z = clamp(2|g|² − 1) (6: 2 mul, add, mul, sub, clamp); r = √max(1 − z², 0) (4); normalize2_or_x(g)·r
        // (NORMALIZE2_OPS + 2 mul); the g = 0 test (2 compares, and) and its select of x, y, z (3).
        6 + 4 + NORMALIZE2_OPS + 2 + 3 + 3
    }
    fn bound_rad(&self, hx: f32, hy: f32, _q: Quant) -> f32 {
        equal_area_bound(hx.hypot(hy))
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::SpheremapCry)
    }
}

/// ISPC's encode: the CryEngine 3 `g` remapped to [0, 1]² (`g·0.5+0.5`).
#[inline]
#[must_use]
pub fn ispc_spheremap_encode(n: Vec3) -> Vec2 {
    SpheremapCry::project(n) * 0.5 + 0.5
}

/// ISPC's decode of `e` in [0, 1]², exactly as the sample writes it: `f = (x−x²)+(y−y²)`, `m = √(4f−1)`,
/// `n = (m(4x−2), m(4y−2), 3−8f)`. Points outside the disc (4f−1 < 0) take m = 0 and come out as +Z after
/// normalisation. It has no singularity: e = (½, ½) gives exactly −Z.
#[inline]
#[must_use]
pub fn ispc_spheremap_decode(e: Vec2) -> Vec3 {
    let (x, y) = (e.x, e.y);
    let f = (x - x * x) + (y - y * y);
    let m = (4.0 * f - 1.0).max(0.0).sqrt();
    Vec3::new(m * (4.0 * x - 2.0), m * (4.0 * y - 2.0), 3.0 - 8.0 * f)
}

/// The spheremap stored as unorm `g·0.5+0.5` and decoded with [`ispc_spheremap_decode`] (the ISPC layout).
#[derive(Clone, Copy, Debug, Default)]
pub struct SpheremapIspc;

impl Projection for SpheremapIspc {
    fn scheme_name(&self, _q: Quant) -> &'static str {
        "spheremap-ispc"
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        ispc_spheremap_encode(n)
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        ispc_spheremap_decode(p)
    }
    fn decode_ops(&self) -> u32 {
        // f = (x − x²) + (y − y²) (5); m = √max(4f − 1, 0) (4); m·(4x − 2), m·(4y − 2) (6); 3 − 8f (2).
        17
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::SpheremapIspc)
    }
    fn bound_rad(&self, hx: f32, hy: f32, _q: Quant) -> f32 {
        // Unorm steps in e are half as large in g = 2e − 1 units... the other way: twice as large.
        equal_area_bound(2.0 * hx.hypot(hy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::normal::{angle_deg, finish, sanitize};

    #[test]
    fn poles_are_exact() {
        assert_eq!(SpheremapCry::project(Vec3::Z), Vec2::X);
        assert_eq!(SpheremapCry::project(Vec3::NEG_Z), Vec2::ZERO);
        assert_eq!(finish(SpheremapCry::unproject(Vec2::X)), Vec3::Z);
        assert_eq!(finish(SpheremapCry::unproject(Vec2::ZERO)), Vec3::NEG_Z);
        assert_eq!(finish(ispc_spheremap_decode(Vec2::splat(0.5))), Vec3::NEG_Z);
    }

    /// Agreement between the formulations: near +Z the f32 rim arithmetic (z = 2|g|²−1 with |g| ≈ 1) loses
    /// √(2·ε) ≈ 5e-4 rad ≈ 0.03° however the map is written; 0.05° leaves room without hiding a wrong formula
    /// (a wrong formula is off by degrees).
    const AGREE_DEG: f32 = 0.05;

    #[test]
    fn cry_and_ispc_decoders_agree_everywhere_in_the_disc() {
        let mut rng = crate::base::rng::SplitMix64::new(3);
        for _ in 0..50_000 {
            let n = sanitize(Vec3::new(rng.range_f32(-1., 1.), rng.range_f32(-1., 1.), rng.range_f32(-1., 1.)));
            let g = SpheremapCry::project(n);
            let a = finish(SpheremapCry::unproject(g));
            let b = finish(ispc_spheremap_decode(g * 0.5 + 0.5));
            assert!(angle_deg(a, n) < AGREE_DEG, "cry round trip of {n}: {a}");
            assert!(angle_deg(b, n) < AGREE_DEG, "ispc decode of {n}: {b}");
        }
    }
}
