//! The closed choices of the resolve (culling, BRDF, falloff, schedule) and the configuration that bundles them.
//!
//! Every enum has `ALL`, a kebab-case `name()` (the one CLI / JSON spelling) and `from_name()`, from
//! [`crate::base::names`].

use serde::{Deserialize, Serialize};

crate::named_enum! {
    /// How lights are matched to samples before shading. Every method is conservative: it only drops lights whose
    /// contribution is exactly zero, so the image does not depend on the choice (see `tests/resolve_props.rs`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Culling: "culling" {
        /// Every light against every shaded sample.
        None => "none",
        /// Each light's screen-space bounding rectangle plus a per-sample depth-bounds test (the 2010 demo's
        /// "quad" method: a screen-aligned quad per light with depth bounds).
        Quad => "quad",
        /// Per tile: four side planes and the min/max depth slab of the tile's shaded samples.
        Tiled => "tiled",
        /// Tiles × depth slices: each slice of a tile gets its own planes and depth slab.
        Clustered => "clustered",
    }
}

crate::named_enum! {
    /// The surface response.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Brdf: "BRDF" {
        /// `albedo / π · N·L`.
        Lambert => "lambert",
        /// The 2010 tiled-deferred demo / ISPC `deferred` model:
        /// `k = atten · N·L · (1 + specAmount · (p + 2)/8 · max(N·H, 0)^p)`, colour += albedo ⊙ lightColour · k.
        BlinnPhong => "blinn-phong",
        /// glTF 2.0 metallic-roughness: GGX distribution, Smith height-correlated visibility, Schlick Fresnel.
        Ggx => "ggx",
    }
}

crate::named_enum! {
    /// Distance attenuation of point and spot lights (directional lights are not attenuated).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Falloff: "falloff" {
        /// KHR_lights_punctual: `clamp(1 − (d/range)⁴, 0, 1)² / d²`.
        Gltf => "gltf",
        /// The 2010 demo: `clamp((end − d)/(end − begin), 0, 1)`, zero beyond `end` (= the light's range).
        Linear => "linear",
    }
}

/// The lighting model a command lights with, and why: every output that lights names it (report header and JSON,
/// budget, resolve, pipelines), because a layout's ranking depends on what the BRDF reads.
///
/// Chosen from the data unless the user names one ([`Lighting::choose`]): a frame that stores roughness or
/// metallic is a metallic-roughness material and is lit with [`Brdf::Ggx`]; any other frame (a specular amount and
/// power, as the 2010 demo and the ISPC sample store, or nothing at all) with [`Brdf::BlinnPhong`]. The falloff
/// defaults to [`Falloff::Linear`] either way (the calibration of scattered lights and of the demo's own).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Lighting {
    /// The BRDF.
    pub brdf: Brdf,
    /// The distance falloff.
    pub falloff: Falloff,
    /// Why this BRDF, in words ("chosen with --brdf", "the frame stores roughness and metallic").
    pub why: String,
}

impl Lighting {
    /// The lighting for a frame whose stored attributes are `attributes`: `brdf` and `falloff` where given, the
    /// data's choice where not (see [`Lighting`]).
    #[must_use]
    pub fn choose(brdf: Option<Brdf>, falloff: Option<Falloff>, attributes: &[crate::gbuffer::Attribute]) -> Self {
        use crate::gbuffer::Attribute;
        let falloff = falloff.unwrap_or(Falloff::Linear);
        if let Some(brdf) = brdf {
            return Lighting { brdf, falloff, why: "chosen by the user".into() };
        }
        let pbr: Vec<&str> = [Attribute::Roughness, Attribute::Metallic]
            .into_iter()
            .filter(|a| attributes.contains(a))
            .map(|a| a.name())
            .collect();
        if pbr.is_empty() {
            let why = if attributes.contains(&Attribute::SpecularPower) {
                "the frame stores a specular power and no roughness or metallic"
            } else {
                "the frame stores no roughness or metallic"
            };
            Lighting { brdf: Brdf::BlinnPhong, falloff, why: why.into() }
        } else {
            Lighting {
                brdf: Brdf::Ggx,
                falloff,
                why: format!("the frame stores {}: a metallic-roughness material", pbr.join(" and ")),
            }
        }
    }

    /// The lighting `cfg` already holds, `why` given by the caller.
    #[must_use]
    pub fn of(cfg: &ResolveConfig, why: &str) -> Self {
        Lighting { brdf: cfg.brdf, falloff: cfg.falloff, why: why.into() }
    }

    /// `cfg` lit this way.
    #[must_use]
    pub fn apply(&self, cfg: ResolveConfig) -> ResolveConfig {
        ResolveConfig { brdf: self.brdf, falloff: self.falloff, ..cfg }
    }

    /// One line for people: `BRDF ggx, falloff linear (the frame stores roughness: …)`.
    #[must_use]
    pub fn summary(&self) -> String {
        format!("BRDF {}, falloff {} ({})", self.brdf, self.falloff, self.why)
    }
}

crate::named_enum! {
    /// How the shading work is organised.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Schedule: "schedule" {
        /// Full deferred shading: every shaded sample evaluates the whole BRDF per light.
        Deferred => "deferred",
        /// Deferred lighting (light pre-pass): lights accumulate RGB diffuse light and a monochromatic specular
        /// term, which a second pass combines with the albedo. Exact (up to f32 rounding) for Lambert, and for
        /// Blinn-Phong when all lights share one colour; approximate otherwise, and for GGX even under white
        /// light (see docs/RESOLVE.md, "Light pre-pass against full deferred").
        LightPrepass => "light-prepass",
    }
}

crate::named_enum! {
    /// How an MSAA tile's shading work is laid out over SIMD lanes. Every schedule gives the same image, bit for
    /// bit (each sample is shaded by the same arithmetic and the box filter adds in the same order); they differ in
    /// the idle lanes they run and, for `two-pass`, in the culling.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum MsaaSchedule: "MSAA schedule" {
        /// Lauritzen 2010: one packed list per tile — every pixel once, then the edge pixels' other samples — cut
        /// into vectors: only the list's last vector has idle lanes.
        #[default]
        Packed => "packed",
        /// Per-pixel branching: a vector holds one pixel per lane and steps through the samples its pixel needs,
        /// so each group of pixels runs as long as its slowest pixel (idle lanes: pixels that finished early).
        PerPixel => "per-pixel",
        /// Two passes, as with a stencil mask: every pixel once, then the edge pixels' other samples, each pass with
        /// its own light culling against its own samples' bounds (culling twice).
        TwoPass => "two-pass",
    }
}

/// Default tile edge in pixels (the 2010 demo and the ISPC sample use 16×16 tiles).
pub const DEFAULT_TILE_SIZE: u32 = 16;
/// Default number of depth slices per tile for clustered culling.
pub const DEFAULT_DEPTH_SLICES: u32 = 16;
/// Largest tile edge accepted (a tile's work list must stay cache-sized).
pub const MAX_TILE_SIZE: u32 = 256;
/// Largest number of depth slices accepted.
pub const MAX_DEPTH_SLICES: u32 = 256;

/// Everything that selects how [`crate::resolve::resolve`] lights a G-buffer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResolveConfig {
    /// Light culling method.
    pub culling: Culling,
    /// Surface BRDF.
    pub brdf: Brdf,
    /// Distance falloff.
    pub falloff: Falloff,
    /// Shading schedule.
    pub schedule: Schedule,
    /// Tile edge in pixels (1..=[`MAX_TILE_SIZE`]).
    pub tile_size: u32,
    /// Depth slices per tile for [`Culling::Clustered`] (1..=[`MAX_DEPTH_SLICES`]).
    pub depth_slices: u32,
    /// How MSAA work is laid out over SIMD lanes (the image does not depend on it).
    #[serde(default)]
    pub msaa: MsaaSchedule,
}

impl Default for ResolveConfig {
    /// Tiled culling, the demo's Blinn-Phong with its linear falloff, full deferred shading, 16×16 tiles.
    fn default() -> Self {
        ResolveConfig {
            culling: Culling::Tiled,
            brdf: Brdf::BlinnPhong,
            falloff: Falloff::Linear,
            schedule: Schedule::Deferred,
            tile_size: DEFAULT_TILE_SIZE,
            depth_slices: DEFAULT_DEPTH_SLICES,
            msaa: MsaaSchedule::Packed,
        }
    }
}

impl ResolveConfig {
    /// Checks the numeric fields.
    pub fn validate(&self) -> crate::Result<()> {
        if !(1..=MAX_TILE_SIZE).contains(&self.tile_size) {
            return Err(crate::Error::Argument(format!("tile size {} outside 1..={MAX_TILE_SIZE}", self.tile_size)));
        }
        if !(1..=MAX_DEPTH_SLICES).contains(&self.depth_slices) {
            return Err(crate::Error::Argument(format!(
                "depth slices {} outside 1..={MAX_DEPTH_SLICES}",
                self.depth_slices
            )));
        }
        if self.msaa != MsaaSchedule::Packed && self.culling == Culling::Clustered {
            return Err(crate::Error::Argument(format!(
                "the {} MSAA schedule runs with none, tiled or quad culling, not clustered",
                self.msaa
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn lighting_follows_the_data_unless_named() {
        use crate::gbuffer::Attribute::{Albedo, Metallic, Normal, Roughness, Specular, SpecularPower};
        for (attrs, brdf) in [
            (&[Normal, Albedo, Roughness][..], Brdf::Ggx),
            (&[Normal, Metallic][..], Brdf::Ggx),
            (&[Normal, Albedo, Specular, SpecularPower, Roughness, Metallic][..], Brdf::Ggx),
            (&[Normal, Albedo, Specular, SpecularPower][..], Brdf::BlinnPhong),
            (&[][..], Brdf::BlinnPhong),
        ] {
            let l = Lighting::choose(None, None, attrs);
            assert_eq!((l.brdf, l.falloff), (brdf, Falloff::Linear), "{attrs:?}");
            assert!(!l.why.is_empty());
            if brdf == Brdf::Ggx {
                assert!(l.why.contains("roughness") || l.why.contains("metallic"), "{}", l.why);
            }
            // Named choices win whatever the data holds.
            let named = Lighting::choose(Some(Brdf::Lambert), Some(Falloff::Gltf), attrs);
            assert_eq!((named.brdf, named.falloff), (Brdf::Lambert, Falloff::Gltf));
            let cfg = named.apply(ResolveConfig::default());
            assert_eq!((cfg.brdf, cfg.falloff, cfg.culling), (Brdf::Lambert, Falloff::Gltf, Culling::Tiled));
        }
    }

    use super::*;

    #[test]
    fn names_round_trip_for_every_variant() {
        for c in &Culling::ALL {
            assert_eq!(Culling::from_name(c.name()), Some(*c));
        }
        for b in &Brdf::ALL {
            assert_eq!(Brdf::from_name(b.name()), Some(*b));
        }
        for f in &Falloff::ALL {
            assert_eq!(Falloff::from_name(f.name()), Some(*f));
        }
        for s in &Schedule::ALL {
            assert_eq!(Schedule::from_name(s.name()), Some(*s));
        }
        assert_eq!(Brdf::from_name("Blinn_Phong"), Some(Brdf::BlinnPhong));
        assert_eq!(Culling::from_name("octree"), None);
        assert_eq!(serde_json::to_string(&Schedule::LightPrepass).unwrap(), "\"light-prepass\"");
    }

    #[test]
    fn validate_rejects_zero_and_huge_tiles() {
        let mut c = ResolveConfig::default();
        c.validate().unwrap();
        c.tile_size = 0;
        assert!(c.validate().is_err());
        c.tile_size = MAX_TILE_SIZE + 1;
        assert!(c.validate().is_err());
        c.tile_size = 7;
        c.depth_slices = 0;
        assert!(c.validate().is_err());
    }
}
