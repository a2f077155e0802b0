//! The BRDFs, written once in f64 as the reference definition of what one light adds to one sample. The batched
//! f32 kernel (`kernel.rs`) evaluates the same formulas; the f64 reference evaluates them in lanes
//! (`reference_lanes.rs`), tested against these pair by pair.
//!
//! Conventions (view space, the crate's +X right, +Y up, looking −Z): `V = −p/|p|` points from the surface to the
//! eye; `L` points from the surface to the light (`−direction` for a directional light); `H = normalize(L + V)`.
//! The ISPC `deferred` sample writes the same half vector as `normalize(L − Vneg)` with `Vneg = p/|p|`.
//!
//! - `lambert`: `c · E · albedo/π · N·L`.
//! - `blinn-phong` (the demo, per light): `k = E · N·L · (1 + specAmount · (p + 2)/8 · max(N·H, 0)^p)`, colour +=
//!   `albedo ⊙ c · k`. There is no 1/π: the demo's light colours are calibrated for that.
//! - `ggx` (glTF 2.0 metallic-roughness, Appendix B): `α = max(roughness², MIN_ALPHA)`,
//!   `D = α²/(π((N·H)²(α² − 1) + 1)²)`, `Vis = 0.5/(N·L·√((N·V)²(1 − α²) + α²) + N·V·√((N·L)²(1 − α²) + α²))`,
//!   `F = F0 + (1 − F0)(1 − V·H)⁵`, `F0 = mix(0.04, albedo, metallic)`, `c_diff = albedo · (1 − metallic)`;
//!   colour += `c · E · N·L · ((1 − F) ⊙ c_diff/π + F · D · Vis)`. The dump's specular amount is not used (the
//!   metallic-roughness model has none).
//!
//! Here `c` is the light's colour × intensity and `E` its distance falloff × spot factor. N·L ≤ 0 contributes 0.

use super::config::{Brdf, Falloff};
use super::falloff::{attenuation, cone_constants, spot, MIN_DISTANCE};
use super::worklist::Surface;
use crate::light::{Light, LightKind};
use glam::DVec3;
use std::f64::consts::PI;

/// Smallest GGX α (= roughness²): roughness 0 would make `D` a delta (infinite at N·H = 1).
pub const MIN_ALPHA: f32 = 1e-3;
/// Smallest N·V used by GGX (normals facing away from the eye occur with interpolated or quantized normals).
pub const MIN_NDOTV: f32 = 1e-4;
/// Dielectric F0 of the glTF metallic-roughness model.
pub const DIELECTRIC_F0: f32 = 0.04;
/// Floor of `|L + V|` before normalising the half vector.
pub const MIN_HALF_LENGTH: f32 = 1e-12;

/// Everything about one light-sample pair the BRDFs need.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(test), allow(dead_code))] // the definition the reference's lanes are tested against
pub struct PairGeometry {
    /// Unit vector to the light (zero when the light sits on the sample).
    pub l: DVec3,
    /// Unit vector to the eye.
    pub v: DVec3,
    /// max(N·L, 0).
    pub ndl: f64,
    /// Distance falloff × spot factor × intensity-free colour scale (`c · E` per channel).
    pub radiance: DVec3,
}

/// Geometry and incoming radiance of `light` at surface `s` (f64).
#[must_use]
#[cfg_attr(not(test), allow(dead_code))] // the definition the reference's lanes are tested against
pub fn pair_geometry(s: &Surface, light: &Light, falloff: Falloff) -> PairGeometry {
    let p = s.p.as_dvec3();
    let n = s.n.as_dvec3();
    let v = -p / p.length();
    let (lvec, positional) = match light.kind {
        LightKind::Directional { direction } => (-direction.as_dvec3(), false),
        _ => (light.position.as_dvec3() - p, true),
    };
    let d = lvec.length();
    if positional && d >= f64::from(light.range) {
        // Both falloffs are exactly 0 here; returning early keeps the reference affordable with many lights.
        return PairGeometry { l: DVec3::ZERO, v, ndl: 0.0, radiance: DVec3::ZERO };
    }
    let l = lvec / d.max(f64::from(MIN_DISTANCE));
    let mut e = if positional { attenuation(falloff, d, f64::from(light.begin), f64::from(light.range)) } else { 1.0 };
    if let LightKind::Spot { direction, inner_cone_angle, outer_cone_angle } = light.kind {
        let (scale, offset) = cone_constants(inner_cone_angle, outer_cone_angle);
        e *= spot(-direction.as_dvec3().dot(l), f64::from(scale), f64::from(offset));
    }
    let c = light.color.as_dvec3() * f64::from(light.intensity);
    PairGeometry { l, v, ndl: n.dot(l).max(0.0), radiance: c * e }
}

/// What `light` adds to the radiance leaving `s` towards the eye (f64 reference).
#[must_use]
#[cfg_attr(not(test), allow(dead_code))] // the definition the reference's lanes are tested against
pub fn shade(s: &Surface, light: &Light, brdf: Brdf, falloff: Falloff) -> DVec3 {
    let g = pair_geometry(s, light, falloff);
    if g.ndl <= 0.0 {
        return DVec3::ZERO;
    }
    let n = s.n.as_dvec3();
    let albedo = s.albedo.as_dvec3();
    let h = {
        let h = g.l + g.v;
        h / h.length().max(f64::from(MIN_HALF_LENGTH))
    };
    match brdf {
        Brdf::Lambert => albedo / PI * g.radiance * g.ndl,
        Brdf::BlinnPhong => {
            let p = f64::from(s.power);
            let ndh = n.dot(h).max(0.0);
            let k = g.ndl * (1.0 + f64::from(s.specular) * (p + 2.0) / 8.0 * ndh.powf(p));
            albedo * g.radiance * k
        }
        Brdf::Ggx => {
            let alpha = (f64::from(s.roughness).powi(2)).max(f64::from(MIN_ALPHA));
            let a2 = alpha * alpha;
            let nv = n.dot(g.v).max(f64::from(MIN_NDOTV));
            let ndh = n.dot(h).max(0.0);
            let vdh = g.v.dot(h).max(0.0);
            let metallic = f64::from(s.metallic);
            let f0 = DVec3::splat(f64::from(DIELECTRIC_F0)).lerp(albedo, metallic);
            let c_diff = albedo * (1.0 - metallic);
            let f = f0 + (DVec3::ONE - f0) * (1.0 - vdh).powi(5);
            let t = ndh * ndh * (a2 - 1.0) + 1.0;
            let d = a2 / (PI * t * t);
            let vis_den = g.ndl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (g.ndl * g.ndl * (1.0 - a2) + a2).sqrt();
            let vis = 0.5 / vis_den.max(1e-12);
            let brdf = (DVec3::ONE - f) * c_diff / PI + f * (d * vis);
            g.radiance * brdf * g.ndl
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn surface(n: Vec3) -> Surface {
        Surface {
            p: Vec3::new(0.0, 0.0, -5.0),
            n,
            albedo: Vec3::new(0.5, 0.25, 1.0),
            specular: 1.0,
            power: 16.0,
            roughness: 0.5,
            metallic: 0.0,
        }
    }

    #[test]
    fn lambert_head_on_is_albedo_over_pi_times_falloff() {
        let s = surface(Vec3::Z);
        let l = Light::point(Vec3::new(0.0, 0.0, -3.0), Vec3::ONE, 4.0, f32::INFINITY);
        let c = shade(&s, &l, Brdf::Lambert, Falloff::Gltf);
        // d = 2: E = 4 / 4 = 1.
        let want = s.albedo.as_dvec3() / PI;
        assert!((c - want).abs().max_element() < 1e-9, "{c} vs {want}");
    }

    #[test]
    fn blinn_phong_matches_the_demo_formula_head_on() {
        // Light at the eye side: L = V = H = N, so N·L = N·H = 1 and k = atten · (1 + spec · (p + 2)/8).
        let s = surface(Vec3::Z);
        let mut l = Light::point(Vec3::new(0.0, 0.0, -1.0), Vec3::ONE, 1.0, 10.0);
        l.begin = 2.0;
        let c = shade(&s, &l, Brdf::BlinnPhong, Falloff::Linear);
        let atten = (10.0 - 4.0) / (10.0 - 2.0);
        let k = atten * (1.0 + 1.0 * 18.0 / 8.0);
        assert!((c - s.albedo.as_dvec3() * k).abs().max_element() < 1e-9, "{c}");
    }

    #[test]
    fn back_facing_and_out_of_range_lights_add_nothing() {
        let s = surface(Vec3::Z);
        let behind = Light::point(Vec3::new(0.0, 0.0, -9.0), Vec3::ONE, 1.0, 100.0);
        let far = Light::point(Vec3::new(0.0, 0.0, -1.0), Vec3::ONE, 1.0, 3.0);
        for brdf in &Brdf::ALL {
            for falloff in &Falloff::ALL {
                assert_eq!(shade(&s, &behind, *brdf, *falloff), DVec3::ZERO);
                assert_eq!(shade(&s, &far, *brdf, *falloff), DVec3::ZERO);
            }
        }
    }

    #[test]
    fn ggx_is_finite_for_roughness_zero_and_one_and_reciprocal() {
        let l = Light::point(Vec3::new(1.0, 0.5, -2.0), Vec3::ONE, 5.0, f32::INFINITY);
        for r in [0.0, 1.0] {
            let mut s = surface(Vec3::new(0.0, 0.3, 1.0).normalize());
            s.roughness = r;
            s.metallic = 1.0 - r;
            let c = shade(&s, &l, Brdf::Ggx, Falloff::Gltf);
            assert!(c.is_finite() && c.min_element() >= 0.0, "roughness {r}: {c}");
        }
        // A rough dielectric reflects less than a smooth one at the mirror direction.
        let mut s = surface(Vec3::Z);
        let mirror = Light::point(Vec3::new(0.0, 0.0, -1.0), Vec3::ONE, 1.0, f32::INFINITY);
        s.roughness = 0.1;
        let smooth = shade(&s, &mirror, Brdf::Ggx, Falloff::Gltf);
        s.roughness = 0.9;
        let rough = shade(&s, &mirror, Brdf::Ggx, Falloff::Gltf);
        assert!(smooth.x > rough.x, "{smooth} vs {rough}");
    }
}
