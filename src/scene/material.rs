//! Surface materials of the analytic scenes: the per-sample shading inputs a G-buffer stores.
//!
//! A material is one (albedo, specular, specular power, roughness, metallic) tuple. Every object carries exactly
//! one material, so "same object ⇒ same material" holds in every scene.

use glam::Vec3;

/// One material: what the ray caster writes into the shading planes of every sample that hits it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Short name, for summaries.
    pub name: &'static str,
    /// Diffuse albedo (linear RGB, each in [0, 1]).
    pub albedo: Vec3,
    /// Specular amount / scalar F0 in [0, 1].
    pub specular: f32,
    /// Blinn-Phong exponent.
    pub specular_power: f32,
    /// Perceptual roughness in [0, 1].
    pub roughness: f32,
    /// Metallic in [0, 1].
    pub metallic: f32,
}

/// The largest Blinn-Phong exponent [`blinn_phong_power`] returns (a mirror-like surface).
pub const MAX_SPECULAR_POWER: f32 = 1.0e4;

/// The Blinn-Phong exponent matching a perceptual roughness, via the usual GGX correspondence
/// `power = 2 / α² − 2` with `α = roughness²` (Walter et al. 2007; Karis 2013), clamped to
/// [0, [`MAX_SPECULAR_POWER`]].
#[must_use]
pub fn blinn_phong_power(roughness: f32) -> f32 {
    let a = (roughness * roughness).max(1e-4);
    (2.0 / (a * a) - 2.0).clamp(0.0, MAX_SPECULAR_POWER)
}

impl Material {
    /// A material whose specular power follows from its roughness (`blinn_phong_power`).
    #[must_use]
    pub fn pbr(name: &'static str, albedo: [f32; 3], specular: f32, roughness: f32, metallic: f32) -> Self {
        Material {
            name,
            albedo: Vec3::from(albedo),
            specular,
            specular_power: blinn_phong_power(roughness),
            roughness,
            metallic,
        }
    }
}

/// The room's palette: fourteen distinct tuples, from rough dielectrics to mirror-like metals. Material IDs are
/// `index + 1` (ID 0 is never used by a surface, so it cannot be confused with background).
#[must_use]
pub fn room_palette() -> Vec<Material> {
    vec![
        Material::pbr("tile-light", [0.80, 0.80, 0.78], 0.04, 0.80, 0.0),
        Material::pbr("tile-dark", [0.10, 0.10, 0.12], 0.04, 0.60, 0.0),
        Material::pbr("plaster", [0.70, 0.65, 0.60], 0.02, 0.95, 0.0),
        Material::pbr("brick", [0.55, 0.20, 0.15], 0.03, 0.90, 0.0),
        Material::pbr("wood", [0.45, 0.30, 0.15], 0.05, 0.60, 0.0),
        Material::pbr("gold", [1.00, 0.77, 0.34], 1.00, 0.20, 1.0),
        Material::pbr("chrome", [0.95, 0.95, 0.95], 1.00, 0.05, 1.0),
        Material::pbr("blue-plastic", [0.10, 0.20, 0.80], 0.50, 0.30, 0.0),
        Material::pbr("green-rubber", [0.10, 0.50, 0.10], 0.02, 1.00, 0.0),
        Material::pbr("soot", [0.02, 0.02, 0.02], 0.04, 0.50, 0.0),
        Material::pbr("white-paint", [0.95, 0.95, 0.95], 0.08, 0.40, 0.0),
        Material::pbr("copper", [0.95, 0.64, 0.54], 1.00, 0.35, 1.0),
        Material::pbr("steel", [0.50, 0.50, 0.52], 0.90, 0.50, 1.0),
        Material::pbr("red-lacquer", [0.70, 0.03, 0.05], 0.60, 0.10, 0.0),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn palette_tuples_are_distinct_and_in_range() {
        let p = room_palette();
        assert!(p.len() >= 12);
        for (i, a) in p.iter().enumerate() {
            assert!(a.albedo.min_element() >= 0.0 && a.albedo.max_element() <= 1.0, "{}", a.name);
            assert!((0.0..=1.0).contains(&a.roughness) && (0.0..=1.0).contains(&a.metallic), "{}", a.name);
            assert!((0.0..=MAX_SPECULAR_POWER).contains(&a.specular_power), "{}", a.name);
            for b in &p[i + 1..] {
                let same = a.albedo == b.albedo && a.roughness == b.roughness && a.metallic == b.metallic;
                assert!(!same, "{} and {} are the same tuple", a.name, b.name);
            }
        }
    }

    #[test]
    fn power_falls_with_roughness() {
        assert_eq!(blinn_phong_power(0.0), MAX_SPECULAR_POWER);
        assert_eq!(blinn_phong_power(1.0), 0.0);
        assert!(blinn_phong_power(0.3) > blinn_phong_power(0.6));
    }
}
